/* Tests of firmware/core/hover_est.h: the hover throttle learned from the vertical speed
 * and the collective throttle, alone (random throttle, random truth) and in closed loop
 * with alt_ctrl taking off from the ground with a nominal k_f 0.3x ... 3x the truth.
 * The plant: m z'' = s f cos(tilt) - m g with s = k_f,true / k_f,nominal, a one-frame
 * transport delay, a first-order thrust lag, per-rotor thrust noise and the ground
 * (z >= 0), in double precision with 10 sub-steps per 90 Hz frame. And from the accelerometer's
 * specific force instead of the vertical speed. */
#include "unit_scalar.h"
#include "alt_ctrl.h"
#include "hover_est.h"
#include "unit.h"
#include "unit_quat.h"

#include <math.h>
#include <string.h>
#ifdef TEST_VERBOSE
#include <stdio.h>
#endif

#define FRAME_S (1.0 / 90.0)
#define SUBSTEPS 10
#define G 9.796

static scalar_t s(double x) { return sc_from_float((float)x); }

struct plant {
	double z, vz, f_a, f_queue;
	double m, scale, lag_s, sigma_f; /* sigma_f: thrust noise of the total, N */
	struct unit_rng *rng;
};

/* One frame with the total thrust demand f_cmd (nominal newtons). */
static void plant_frame(struct plant *v, double f_cmd)
{
	double fin = v->f_queue;
	v->f_queue = f_cmd;
	double h = FRAME_S / SUBSTEPS, al = 1 - exp(-h / v->lag_s);
	double noise = v->sigma_f * unit_rand_normal(v->rng);
	for (int k = 0; k < SUBSTEPS; k++) {
		v->f_a += al * (fin * v->scale - v->f_a);
		double a = (v->f_a + noise) / v->m - G;
		v->z += h * v->vz + 0.5 * h * h * a;
		v->vz += h * a;
		if (v->z <= 0.0 && v->vz <= 0.0) { /* resting on the ground */
			v->z = 0.0;
			v->vz = 0.0;
		}
	}
}

/* Open loop: a random throttle around the true hover (+/-15 %, 2 Hz steps) with the
 * vehicle free in the air; the estimate starts 0.3x ... 3x off. Within 1 % after 10 s,
 * its error within 4 reported sd. Random truth u_h in [0.03, 0.6], random mass 1-5 kg. */
UNIT_TEST(hover_est_learns_random_truth_open_loop)
{
	struct unit_rng r = {0x40e5ULL};
	for (int trial = 0; trial < TRIALS(30); trial++) {
		double uh = unit_rand_uniform(&r, 0.03, 0.6), m = unit_rand_uniform(&r, 1.0, 5.0);
		double off = exp(unit_rand_uniform(&r, log(0.3), log(3.0)));
		struct hover_est_params hp = hover_est_params_default();
		struct hover_est he;
		hover_est_init(&he, &hp, s(uh * off));
		/* plant in throttle units: thrust = m g u / u_h */
		struct plant v = {
			50.0, 0, m * G, m * G, m, 1.0, unit_rand_uniform(&r, 0.01, 0.05), 0.01 * m * G / sqrt(8.0), &r};
		double thr = uh;
		for (int k = 0; k < (int)(10.0 / FRAME_S); k++) {
			if (k % 45 == 0)
				thr = uh * unit_rand_uniform(&r, 0.85, 1.15);
			hover_est_update(&he, s(v.vz), s(thr), SC(1.0), s(FRAME_S));
			plant_frame(&v, m * G * thr / uh);
		}
		double est = d(hover_est_u(&he)), sd = d(hover_est_sd(&he));
#ifdef TEST_VERBOSE
		printf("open loop u_h %.4f start %.2fx: est %.4f (%+.2f %%) sd %.3f %%\n", uh, off, est,
		       100 * (est / uh - 1), 100 * sd / est);
#endif
		CHECK_REL(est, uh, 0.01);
		CHECK(fabs(est - uh) < 4.0 * sd + 1e-4);
		CHECK(hover_est_converged(&he, SC(0.02)));
	}
}

/* On the ground nothing is learned (the acceleration is zero whatever the throttle):
 * hover_est_track leaves the state alone; spool-up raises u_h at its rate, up to u_max. */
UNIT_TEST(hover_est_ground_and_spool)
{
	struct hover_est_params hp = hover_est_params_default();
	struct hover_est he;
	hover_est_init(&he, &hp, SC(0.1));
	for (int k = 0; k < 200; k++)
		hover_est_track(&he, SC(0.0), SC(0.05), SC(1.0), s(FRAME_S));
	CHECK_REL(d(hover_est_u(&he)), 0.1, 1e-3);
	for (int k = 0; k < 90; k++)
		hover_est_spool(&he, s(FRAME_S));
	CHECK_REL(d(hover_est_u(&he)), 0.1 * pow(1 + 0.6 * FRAME_S, 90), 2e-3);
	CHECK(!hover_est_converged(&he, SC(0.5)));
	for (int k = 0; k < 2000; k++)
		hover_est_spool(&he, s(FRAME_S));
	CHECK_REL(d(hover_est_u(&he)), d(hp.u_max), 1e-3); /* the spool stops at u_max */
	/* bad input: no update, no NaN */
	CHECK(!hover_est_update(&he, SC(0.0), SC(0.1), SC(1.0), SC(0.0)));
#if !OCTO_FIXED
	CHECK(!hover_est_update(&he, s((double)NAN), SC(0.1), SC(1.0), s(FRAME_S)));
#endif
	CHECK(sc_isfinite(hover_est_u(&he)));
}

/* Closed loop, as the firmware flies it: take-off from the ground to 5 m with a nominal
 * k_f 0.3x ... 3x the truth (random), hover throttle 0.03 ... 0.6 and mass 1 ... 5 kg
 * (random). The height controller takes its hover thrust from the estimator; on the
 * ground while a climb is commanded the estimator spools up. Within 30 s: at 5 m
 * (+/-5 cm, settled), hover throttle within 2 % and converged, k_f = m g / (8 u_h)
 * within 2 % of the truth; the height never more than 2.5 m above the target. */
UNIT_TEST(hover_est_takeoff_from_any_nominal)
{
	struct unit_rng r = {0x7a6eULL};
	for (int trial = 0; trial < TRIALS(24); trial++) {
		double m = unit_rand_uniform(&r, 1.0, 5.0), uh = unit_rand_uniform(&r, 0.03, 0.6);
		double kf_true = m * G / (8 * uh);
		double ratio = trial < 2 ? (trial == 0 ? 0.3 : 3.0) : exp(unit_rand_uniform(&r, log(0.3), log(3.0)));
		double kf_nom = kf_true * ratio;
		struct alt_ctrl_params ap = alt_ctrl_params_default();
		ap.f_max_n = s(8 * kf_nom);
		ap.f_min_n = s(0.02 * 8 * kf_nom);
		struct alt_ctrl ac;
		alt_ctrl_init(&ac, &ap);
		struct hover_est_params hp = hover_est_params_default();
		struct hover_est he;
		hover_est_init(&he, &hp, s(m * G / (8 * kf_nom)));
		struct plant v = {
			0, 0, 0, 0, m, kf_true / kf_nom, unit_rand_uniform(&r, 0.01, 0.05), 0.01 * m * G / sqrt(8.0),
			&r};
		struct alt_ctrl_input in;
		memset(&in, 0, sizeof in);
		in.q_b2i = tq_from_euler(SC_ZERO, SC_ZERO, SC_ZERO);
		in.mass_kg = s(m);
		in.dt_s = s(FRAME_S);
		double zsp = 0, zmax = 0, settled_err = 0, f = 0;
		int n = (int)(30.0 / FRAME_S);
		for (int k = 0; k < n; k++) {
			double t = k * FRAME_S;
			zsp = fmin(5.0, t * 1.0); /* 1 m/s ramp */
			double thr = f / (8 * kf_nom);
			if (v.z > 0.1)
				hover_est_update(&he, s(v.vz), s(thr), SC(1.0), s(FRAME_S));
			else {
				hover_est_track(&he, s(v.vz), s(thr), SC(1.0), s(FRAME_S));
				if (zsp > v.z + 0.05)
					hover_est_spool(&he, s(FRAME_S));
			}
			in.hover_f_n = s(8 * kf_nom * d(hover_est_u(&he)));
			in.z_sp_m = s(zsp);
			in.vz_ff_mps = s(t < 5.0 ? 1.0 : 0.0);
			in.z_m = s(v.z);
			in.vz_mps = s(v.vz);
			f = d(alt_ctrl_update(&ac, &in));
			plant_frame(&v, f);
			zmax = fmax(zmax, v.z);
			if (t > 25.0)
				settled_err = fmax(settled_err, fabs(v.z - 5.0));
		}
		double est = d(hover_est_u(&he)), kf_est = m * G / (8 * est);
#ifdef TEST_VERBOSE
		printf("takeoff m %.2f u_h %.3f nominal %.2fx: est %+.2f %% sd %.2f %% k_f %+.2f %% zmax %.2f err %.3f\n",
		       m, uh, ratio, 100 * (est / uh - 1), 100 * d(hover_est_sd(&he)) / est,
		       100 * (kf_est / kf_true - 1), zmax, settled_err);
#endif
		CHECK(settled_err < 0.05);
		CHECK(zmax < 7.5);
		CHECK_REL(est, uh, 0.02);
		CHECK_REL(kf_est, kf_true, 0.02);
		CHECK(hover_est_converged(&he, SC(0.02)));
	}
}

/* An estimate that converged wrong (variance small, value 25-40 % off, random) in a steady
 * hover at the true throttle: every innovation is beyond the gate. A run of them lasting
 * HOVER_EST_GATED_S raises the variance, and the estimate reaches the truth within 1 %
 * in a few seconds; a single gust-like outlier does not. */
UNIT_TEST(hover_est_recovers_from_a_wrong_convergence)
{
	struct unit_rng g = {0x40e5ULL};
	for (int v = 0; v < TRIALS(10); v++) {
		double uh = unit_rand_uniform(&g, 0.05, 0.5);
		double off = unit_rand_uniform(&g, 0.25, 0.40) * (unit_rand_uniform(&g, 0, 1) < 0.5 ? -1 : 1);
		struct hover_est_params p = hover_est_params_default();
		struct hover_est h;
		hover_est_init(&h, &p, s(uh * (1.0 + off)));
		h.p_pct2 = s(1.0); /* "converged": sd 1 % */
		for (int k = 0; k < 90 * 6; k++) {
			double vz = 0.02 * unit_rand_normal(&g);
			hover_est_update(&h, s(vz), s(uh), s(1.0), s(1.0 / 90.0));
		}
		CHECK_REL(sc_to_float(hover_est_u(&h)), uh, 0.01);
		CHECK(h.rejected > 0);
	}
} /* From the accelerometer (hover_est_update_acc): the specific force along body z, g u / u_h
 * through a 10-50 ms motor lag, with the vibration of a 90 Hz read (a fold near 44 Hz of
 * 0.2-0.4 m/s^2, white noise 0.05 m/s^2). Random truth u_h in [0.03, 0.6], start 0.3x ... 3x off:
 * within 1 % after 10 s and within 4 reported sd. */
UNIT_TEST(hover_est_learns_from_the_accelerometer)
{
	struct unit_rng r = {0x40e6ULL};
	for (int trial = 0; trial < TRIALS(30); trial++) {
		double uh = unit_rand_uniform(&r, 0.03, 0.6), off = exp(unit_rand_uniform(&r, log(0.3), log(3.0)));
		double lag = unit_rand_uniform(&r, 0.01, 0.05), vib = unit_rand_uniform(&r, 0.2, 0.4);
		double f_vib = unit_rand_uniform(&r, 40.0, 45.0), al = 1 - exp(-FRAME_S / lag);
		struct hover_est_params hp = hover_est_params_default();
		struct hover_est he;
		hover_est_init(&he, &hp, s(uh * off));
		double thr = uh, u_prev = uh, u_lag = uh;
		for (int k = 0; k < (int)(10.0 / FRAME_S); k++) {
			if (k % 45 == 0)
				thr = uh * unit_rand_uniform(&r, 0.85, 1.15);
			u_lag += al * (u_prev - u_lag); /* the last frame's command, through the lag */
			u_prev = thr;
			double a = G * u_lag / uh + vib * sin(6.283185 * f_vib * k * FRAME_S) +
				   0.05 * unit_rand_normal(&r);
			hover_est_update_acc(&he, s(a), s(thr), s(FRAME_S));
		}
		double est = d(hover_est_u(&he)), sd = d(hover_est_sd(&he));
#ifdef TEST_VERBOSE
		printf("accelerometer u_h %.4f start %.2fx: est %.4f (%+.2f %%) sd %.3f %%\n", uh, off, est,
		       100 * (est / uh - 1), 100 * sd / est);
#endif
		CHECK_REL(est, uh, 0.01);
		CHECK(fabs(est - uh) < 4.0 * sd + 1e-4);
		CHECK(hover_est_converged(&he, SC(0.02)));
	}
}

/* The error's sd as the data show it (hover_est_sd_err) against the error, in the set-up of
 * the test above held 20 s, the throttle dithered 3 % around hover: over 40 trials the error
 * over it has an rms within [0.6, 1.5] and stays within 4. The filter's own sd (hover_est_sd,
 * its random walk's) is several times the error: its rms would be about 0.2. */
UNIT_TEST(hover_est_sd_err_against_the_error)
{
	struct unit_rng r = {0x40e7ULL};
	double z2 = 0, zf2 = 0, worst = 0;
	int n = 0;
	for (int trial = 0; trial < TRIALS(40); trial++) {
		double uh = unit_rand_uniform(&r, 0.05, 0.5), lag = unit_rand_uniform(&r, 0.01, 0.05);
		double vib = unit_rand_uniform(&r, 0.2, 0.4), f_vib = unit_rand_uniform(&r, 40.0, 45.0);
		double wn = unit_rand_uniform(&r, 0.02, 0.1), al = 1 - exp(-FRAME_S / lag);
		struct hover_est_params hp = hover_est_params_default();
		struct hover_est he;
		hover_est_init(&he, &hp, s(uh * unit_rand_uniform(&r, 0.7, 1.4)));
		double thr = uh, u_prev = uh, u_lag = uh;
		for (int k = 0; k < (int)(20.0 / FRAME_S); k++) {
			if (k % 9 == 0)
				thr = uh * (1 + 0.03 * unit_rand_normal(&r));
			u_lag += al * (u_prev - u_lag);
			u_prev = thr;
			double a =
				G * u_lag / uh + vib * sin(6.283185 * f_vib * k * FRAME_S) + wn * unit_rand_normal(&r);
			hover_est_update_acc(&he, s(a), s(thr), s(FRAME_S));
		}
		double est = d(hover_est_u(&he)), z = (est - uh) / d(hover_est_sd_err(&he));
		double zf = (est - uh) / d(hover_est_sd(&he));
#ifdef TEST_VERBOSE
		printf("u_h %.3f: error %+.4f %%, sd %.4f %% (the filter's %.4f %%), z %+.2f\n", uh,
		       100 * (est / uh - 1), 100 * d(hover_est_sd_err(&he)) / est, 100 * d(hover_est_sd(&he)) / est, z);
#endif
		z2 += z * z;
		zf2 += zf * zf;
		worst = fmax(worst, fabs(z));
		n++;
	}
#ifdef TEST_VERBOSE
	printf("rms z %.3f (the filter's sd: %.3f), worst %.2f\n", sqrt(z2 / n), sqrt(zf2 / n), worst);
#endif
	(void)zf2;
	CHECK(sqrt(z2 / n) > 0.6 && sqrt(z2 / n) < 1.5);
	CHECK(worst < 4.0);
}

/* hover_est_u_ahead and hover_est_sd_err at a hold's entry some 6 s after lift-off, as the
 * firmware publishes them:
 * the take-off's throttle (a ramp to 1.3 u_h in 1 s, held 1 s, 0.85 u_h for 1 s, then
 * hover, dithered 1 %) through a motor lag of 20-80 ms the model leaves out, so that the
 * innovations' first blocks are the filter's convergence; the hover throttle drifting up
 * by 1.5-3 %/min (a battery; drift_per_s at 3 %/min); the accelerometer's white noise
 * 0.02-0.1 m/s^2 and a fold of the rotors' vibration near 0 Hz (0.2-1 Hz, up to
 * 0.05 m/s^2). Over 200 trials the error over the sd has an rms below 1.3 and at most 1 %
 * of them beyond 3 (rms 0.51, none; mean +0.25: the move ahead by the innovations' mean
 * overtakes the convergence still under way, where hover_est_u's lag made it -0.32). The sd
 * is pessimistic here (the estimate's wander after so large a swing of the unmodelled lag
 * counts whole): the rms is held within [0.3, 1.3]. */
UNIT_TEST(hover_est_sd_err_at_hold_entry)
{
	struct unit_rng r = {0x40e8ULL};
	double z2 = 0;
	int n = 0, beyond = 0;
	for (int trial = 0; trial < TRIALS(200); trial++) {
		double uh0 = unit_rand_uniform(&r, 0.06, 0.4), off = exp(unit_rand_uniform(&r, log(0.5), log(2.0)));
		double drift = unit_rand_uniform(&r, 0.015, 0.03) / 60.0; /* of u_h per s */
		double lag = unit_rand_uniform(&r, 0.02, 0.08), al = 1 - exp(-FRAME_S / lag);
		double wn = unit_rand_uniform(&r, 0.02, 0.1), fold = unit_rand_uniform(&r, 0.0, 0.05);
		double f_fold = unit_rand_uniform(&r, 0.2, 1.0), ph = unit_rand_uniform(&r, 0.0, 6.283185);
		struct hover_est_params hp = hover_est_params_default();
		hp.drift_per_s = s(0.03 / 60.0); /* the drift's bound (the app's KFT_DRIFT) */
		struct hover_est he;
		hover_est_init(&he, &hp, s(uh0 * off));
		double u_prev = uh0, u_lag = uh0, uh = uh0;
		for (int k = 0; k < (int)(6.0 / FRAME_S); k++) {
			double t = k * FRAME_S;
			uh = uh0 * (1 + drift * t); /* k_f falls: the hover throttle rises */
			double thr = t < 3.0 ? uh * (1 + 0.25 * sin(1.047198 * t)) : uh; /* up, then slowing */
			thr *= 1 + 0.01 * unit_rand_normal(&r);
			u_lag += al * (u_prev - u_lag);
			u_prev = thr;
			double a = G * u_lag / uh + fold * sin(6.283185 * f_fold * t + ph) + wn * unit_rand_normal(&r);
			hover_est_update_acc(&he, s(a), s(thr), s(FRAME_S));
		}
		double est = d(hover_est_u_ahead(&he)), z = (est - uh) / d(hover_est_sd_err(&he));
#ifdef TEST_VERBOSE
		printf("u_h %.3f start %.2fx lag %.0f ms: error %+.4f %%, sd %.4f %%, z %+.2f\n", uh0, off, 1e3 * lag,
		       100 * (est / uh - 1), 100 * d(hover_est_sd_err(&he)) / est, z);
#endif
		z2 += z * z;
		beyond += fabs(z) > 3.0;
		n++;
	}
#ifdef TEST_VERBOSE
	printf("rms z %.3f, beyond 3: %d of %d\n", sqrt(z2 / n), beyond, n);
#endif
	CHECK(z2 == z2);
	if (n >= 100) { /* a statistic of the host's sweep (two trials on the Cortex-M) */
		CHECK(sqrt(z2 / n) > 0.3 && sqrt(z2 / n) < 1.3);
		CHECK(beyond <= n / 100);
	}
}

/* hover_est_u_ahead and its sd against a drift faster than the one allowed for (drift_per_s
 * 2 %/min, the app's KFT_DRIFT; the hover throttle rising or falling by 3-4 %/min, a battery
 * sagging fast): the estimate lags the drift by some 1.2 s, 0.07 %, and the innovations' mean
 * shows it. The accelerometer's white noise 0.02-0.1 m/s^2, a modelled motor lag of 20-80 ms,
 * the throttle dithered 1 % around hover, the estimate starting within 10 %; judged after 12 s.
 * Over 100 trials the error over the sd, signed along the drift, has a mean within +/- 0.3
 * (0.1 its sd: 3 of them) and an rms within [0.7, 1.3] (an sd made 1.5 times too large to hide
 * the lag fails it), none beyond 4. Measured: mean +0.01, rms 0.93, largest 2.6 (Q16.16: +0.02,
 * 0.92, 2.6); hover_est_u with the sd of its lag behind a drift of drift_per_s: mean -0.86. */
UNIT_TEST(hover_est_ahead_of_a_fast_drift)
{
	struct unit_rng r = {0x40e9ULL};
	double zs = 0, z2 = 0, worst = 0;
	int n = 0;
	for (int trial = 0; trial < TRIALS(100); trial++) {
		double uh0 = unit_rand_uniform(&r, 0.06, 0.4),
		       sign = unit_rand_uniform(&r, 0.0, 1.0) < 0.5 ? -1.0 : 1.0;
		double drift = sign * unit_rand_uniform(&r, 0.03, 0.04) / 60.0; /* of u_h per s */
		double lag = unit_rand_uniform(&r, 0.02, 0.08), al = 1 - exp(-FRAME_S / lag);
		double wn = unit_rand_uniform(&r, 0.02, 0.1);
		struct hover_est_params hp = hover_est_params_default();
		hp.drift_per_s = s(0.02 / 60.0);
		hp.tau_m_s = s(lag);
		struct hover_est he;
		hover_est_init(&he, &hp, s(uh0 * unit_rand_uniform(&r, 0.9, 1.1)));
		double u_prev = uh0, u_lag = uh0, uh = uh0;
		for (int k = 0; k < (int)(12.0 / FRAME_S); k++) {
			uh = uh0 * (1 + drift * k * FRAME_S);
			double thr = uh * (1 + 0.01 * unit_rand_normal(&r));
			u_lag += al * (u_prev - u_lag);
			u_prev = thr;
			hover_est_update_acc(&he, s(G * u_lag / uh + wn * unit_rand_normal(&r)), s(thr), s(FRAME_S));
		}
		double est = d(hover_est_u_ahead(&he)), z = (est - uh) / d(hover_est_sd_err(&he));
#ifdef TEST_VERBOSE
		printf("u_h %.3f drift %+.1f %%/min: error %+.4f %% (hover_est_u %+.4f %%), sd %.4f %%, z %+.2f\n", uh0,
		       6000 * drift, 100 * (est / uh - 1), 100 * (d(hover_est_u(&he)) / uh - 1),
		       100 * d(hover_est_sd_err(&he)) / est, z);
#endif
		zs += sign * z;
		z2 += z * z;
		worst = fmax(worst, fabs(z));
		n++;
	}
#ifdef TEST_VERBOSE
	printf("mean z along the drift %+.3f, rms %.3f, worst %.2f\n", zs / n, sqrt(z2 / n), worst);
#endif
	CHECK(z2 == z2 && worst < 4.0);
	if (n >= 50) { /* a statistic of the host's sweep */
		CHECK(fabs(zs / n) < 0.3);
		CHECK(sqrt(z2 / n) > 0.7 && sqrt(z2 / n) < 1.3);
	}
}
