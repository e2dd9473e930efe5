/* Tests of firmware/core/filt.h in whichever build this is. References in double;
 * tolerances per check (float ~1e-6, Q16.16 a few LSB of 1.5e-5 per step, accumulated). */
#include "unit_scalar.h"
#include "filt.h"
#include "unit.h"

#include <math.h>

#define PI 3.14159265358979323846
#define FRAME_S (1.0 / 90.0)

static scalar_t s(double x) { return sc_from_float((float)x); }

/* Step response of the ZOH-exact lag equals 1 - exp(-t / tau) at every sample. */
UNIT_TEST(filt_lag_step_matches_exp)
{
	const double taus[3] = {0.03, 0.1, 1.0};
	for (int j = 0; j < 3; j++) {
		struct filt_lag f;
		filt_lag_init(&f, s(taus[j]), s(FRAME_S), SC_ZERO);
		/* reference with the dt and tau actually represented (Q16.16: 1/90 s is
		 * 2.5e-4 short) */
		double dt = d(s(FRAME_S)), tau = d(s(taus[j]));
		double alpha = d(f.alpha);
		CHECK_NEAR(alpha, 1 - exp(-dt / tau), OCTO_FIXED ? 3e-5 : 1e-6);
		for (int k = 1; k <= 300; k++) {
			scalar_t y = filt_lag_update(&f, SC(1));
			/* Q16.16: alpha off by <= 2 LSB and 0.5 LSB rounding per step, both bounded by
			 * ~1 / alpha LSB: 1e-3 covers tau = 1 s (alpha = 0.011) */
			CHECK_NEAR(d(y), 1 - exp(-k * dt / tau), OCTO_FIXED ? 1e-3 : 1e-5);
		}
	}
	/* tau <= 0 passes through */
	struct filt_lag f;
	filt_lag_init(&f, SC(0), s(FRAME_S), SC(3));
	CHECK(f.y == SC(3));
	CHECK(filt_lag_update(&f, SC(2)) == SC(2));
}

UNIT_TEST(filt_delay_exact)
{
	for (uint32_t n = 0; n <= FILT_DELAY_MAX + 2; n++) {
		struct filt_delay dl;
		filt_delay_init(&dl, n, SC(-7));
		uint32_t ne = n > FILT_DELAY_MAX ? FILT_DELAY_MAX : n; /* clamped */
		for (int k = 0; k < 60; k++) {
			scalar_t y = filt_delay_update(&dl, sc_from_int(k));
			scalar_t want = k >= (int)ne ? sc_from_int(k - (int)ne) : SC(-7);
			CHECK(y == want);
		}
	}
}

/* Steady-state response of the SVF to a sine: the bilinear rule maps the analogue
 * frequency exactly through Omega = (2 / T) tan(w T / 2), so y_f and y_f_dot follow
 * H(j Omega) and j Omega H(j Omega) exactly (float 1e-5, Q16.16 1e-3 of the amplitude);
 * against the derivative of the true (unwarped) filtered sine the error is the warping,
 * (w T)^2 / 12 relative (0.3 % here). */
UNIT_TEST(filt_svf_sine_derivative)
{
	const double wc = 2 * PI * 4.0, zeta = 0.7071, w = 2 * PI * 1.3, A = 0.8;
	struct filt_svf f;
	filt_svf_init(&f, s(wc), s(zeta), s(FRAME_S), SC_ZERO);
	double T = FRAME_S, W = 2 / T * tan(w * T / 2);
	/* H(jW) = wc^2 / (wc^2 - W^2 + j 2 zeta wc W) */
	double re = wc * wc - W * W, im = 2 * zeta * wc * W, den = re * re + im * im;
	double hr = wc * wc * re / den, hi = -wc * wc * im / den;
	double mag = sqrt(hr * hr + hi * hi), ph = atan2(hi, hr);
	/* unwarped analogue H(jw) for the "analytic derivative" comparison */
	double re0 = wc * wc - w * w, im0 = 2 * zeta * wc * w, den0 = re0 * re0 + im0 * im0;
	double mag0 = wc * wc / sqrt(den0), ph0 = atan2(-im0, re0);
	double worst_exact = 0, worst_an = 0, worst_y = 0;
	for (int k = 0; k < 900; k++) {
		double t = k * T;
		filt_svf_update(&f, s(A * sin(w * t)));
		if (t < 4.0) /* transient: decays as exp(-zeta wc t) */
			continue;
		double y_ex = A * mag * sin(w * t + ph), yd_ex = A * mag * W * cos(w * t + ph);
		double yd_an = A * mag0 * w * cos(w * t + ph0);
		worst_y = fmax(worst_y, fabs(d(f.y) - y_ex));
		worst_exact = fmax(worst_exact, fabs(d(f.ydot) - yd_ex));
		worst_an = fmax(worst_an, fabs(d(f.ydot) - yd_an));
	}
	double amp_d = A * mag * W; /* amplitude of the derivative, ~6 */
	CHECK_NEAR(worst_y, 0, OCTO_FIXED ? 1e-3 * A : 1e-5 * A);
	CHECK_NEAR(worst_exact, 0, OCTO_FIXED ? 2e-3 * amp_d : 1e-5 * amp_d);
	CHECK_NEAR(worst_an, 0, 0.01 * amp_d);
}

/* DC gain exactly 1 (Q16.16: up to the rounding dead zone, see filt.h), derivative 0 at
 * rest; the state obeys the trapezoidal relation
 * y_f(k) - y_f(k-1) = T/2 (y_f_dot(k) + y_f_dot(k-1)) (float 2e-6; Q16.16 see below). */
UNIT_TEST(filt_svf_step_and_trapezoid)
{
	const double wcs[3] = {5.0, 30.0, 150.0};
	for (int j = 0; j < 3; j++) {
		struct filt_svf f;
		filt_svf_init(&f, s(wcs[j]), SC(1), s(FRAME_S), SC_ZERO);
		double yp = 0, ydp = 0, worst = 0, ymax = 0, ydmax = 0;
		for (int k = 0; k < 900; k++) {
			filt_svf_update(&f, SC(2));
			double y = d(f.y), yd = d(f.ydot);
			worst = fmax(worst, fabs((y - yp) - FRAME_S / 2 * (yd + ydp)));
			ymax = fmax(ymax, y);
			ydmax = fmax(ydmax, fabs(yd));
			yp = y, ydp = yd;
		}
		CHECK_NEAR(d(f.y), 2.0, OCTO_FIXED ? 2e-4 : 1e-6); /* Q16.16 dead zone: 8 LSB at wc 5 */
		CHECK_NEAR(d(f.ydot), 0.0, OCTO_FIXED ? 1e-3 : 1e-5);
		CHECK(ymax < 2.0 * 1.001); /* critically damped: no overshoot */
		/* Q16.16: the rounded coefficient 2h/det carries ~1 LSB / (2h) relative error */
		CHECK_NEAR(worst, 0, OCTO_FIXED ? 6e-5 + 2e-5 * ydmax : 2e-6);
	}
	/* reset puts the state at rest */
	struct filt_svf f;
	filt_svf_init(&f, SC(20), SC(0.7), s(FRAME_S), SC(1));
	CHECK(f.y == SC(1) && f.ydot == SC_ZERO);
	CHECK_NEAR(d(filt_svf_update(&f, SC(1))), 1.0, OCTO_FIXED ? 2e-5 : 1e-6);
}

/* The same SVF on two signals keeps a linear relation: filtering u = 3 y gives exactly
 * 3 times the outputs (what inertia regression relies on: tau_f = I d(omega_f)/dt). */
UNIT_TEST(filt_svf_linearity)
{
	struct filt_svf a, b;
	filt_svf_init(&a, SC(25), SC(0.8), s(FRAME_S), SC_ZERO);
	filt_svf_init(&b, SC(25), SC(0.8), s(FRAME_S), SC_ZERO);
	struct unit_rng r = {0x11ULL};
	double worst = 0;
	for (int k = 0; k < 500; k++) {
		double y = unit_rand_uniform(&r, -1, 1);
		filt_svf_update(&a, s(y));
		filt_svf_update(&b, s(3 * d(s(y))));
		worst = fmax(worst, fabs(d(b.ydot) - 3 * d(a.ydot)));
	}
	CHECK_NEAR(worst, 0, OCTO_FIXED ? 5e-3 : 1e-4);
}

/* Float build: a NaN sample is ignored by the lag and the SVF. */
UNIT_TEST(filt_nan_ignored)
{
#if OCTO_FIXED
	(void)u; /* Q16.16 has no NaN */
#else
	struct filt_lag l;
	filt_lag_init(&l, SC(0.1), s(FRAME_S), SC(1));
	CHECK(filt_lag_update(&l, __builtin_nanf("")) == 1.0f);
	struct filt_svf f;
	filt_svf_init(&f, SC(20), SC(1), s(FRAME_S), SC(1));
	filt_svf_update(&f, __builtin_nanf(""));
	CHECK(f.y == 1.0f && f.ydot == 0.0f && f.u_prev == 1.0f);
	filt_svf_update(&f, SC(1));
	CHECK(sc_isfinite(f.y) && sc_isfinite(f.ydot));
#endif
}
