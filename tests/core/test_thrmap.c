/* Tests of firmware/core/thrmap.h, eqs. (16)-(17), in whichever build this is.
 * Tolerances: float 1e-6 relative; Q16.16 a few LSB of T (1.5e-5) and of f (k_f * LSB). */
#include "unit_scalar.h"
#include "thrmap.h"
#include "unit.h"

#include <math.h>

static scalar_t s(double x) { return sc_from_float((float)x); }

/* the throttle of one thrust through thrmap_update (rotor 0, scale 1 unless given) */
static scalar_t throttle_of(const struct thrmap *m, scalar_t f, bool *clamped)
{
	scalar_t fs[THRMAP_ROTORS] = {f}, t[THRMAP_ROTORS];
	uint32_t mask = thrmap_update(m, fs, t, 1);
	if (clamped)
		*clamped = (mask & 1u) != 0;
	return t[0];
}

UNIT_TEST(thrmap_linear_round_trip_and_clamp)
{
	struct thrmap_params p = {SC(28.0269), SC(0), {0}};
	struct thrmap m;
	thrmap_init(&m, &p);
	/* hover: 2.132 * 9.796 / 8 = 2.6106 N per rotor -> T = 0.0931 */
	bool c = true;
	scalar_t t = throttle_of(&m, s(2.132 * 9.796 / 8), &c);
	CHECK(!c);
	CHECK_NEAR(d(t), 2.132 * 9.796 / 8 / 28.0269, OCTO_FIXED ? 2e-5 : 1e-7);
	for (int i = 0; i <= 100; i++) {
		double T = i / 100.0;
		scalar_t f = s(d(m.k_f_n) * T);
		CHECK_NEAR(d(throttle_of(&m, f, NULL)), d(f) / d(m.k_f_n), OCTO_FIXED ? 1e-5 : 1e-7);
	}
	/* clamping and flags */
	CHECK(throttle_of(&m, SC(-1), &c) == SC_ZERO && c);
	CHECK(throttle_of(&m, SC(30), &c) == SC(1) && c);
	CHECK(throttle_of(&m, SC(0), &c) == SC_ZERO && !c);
#if !OCTO_FIXED
	CHECK(throttle_of(&m, __builtin_nanf(""), &c) == 0.0f && c); /* NaN: no thrust */
	CHECK(throttle_of(&m, __builtin_inff(), &c) == 1.0f && c);
#endif
	/* rotors beyond THRMAP_ROTORS: scale 1, the same map */
	scalar_t f[THRMAP_ROTORS + 2], tt[THRMAP_ROTORS + 2];
	for (int j = 0; j < THRMAP_ROTORS + 2; j++)
		f[j] = s(0.5 + 3.2 * j); /* the last above k_f */
	CHECK(thrmap_update(&m, f, tt, THRMAP_ROTORS + 2) == (1u << (THRMAP_ROTORS + 1)));
	CHECK_NEAR(d(tt[THRMAP_ROTORS]), d(f[THRMAP_ROTORS]) / d(m.k_f_n), OCTO_FIXED ? 1e-5 : 1e-7);
	CHECK(tt[THRMAP_ROTORS + 1] == SC(1));
}

UNIT_TEST(thrmap_update_mask)
{
	struct thrmap_params p = {SC(28), SC(0), {0}};
	struct thrmap m;
	thrmap_init(&m, &p);
	scalar_t f[8] = {SC(2.6), SC(-0.1), SC(2.6), SC(40), SC(0), SC(28), SC(14), SC(2.6)};
	scalar_t t[8];
	uint32_t mask = thrmap_update(&m, f, t, 8);
	CHECK(mask == ((1u << 1) | (1u << 3)));
	CHECK(t[1] == SC_ZERO && t[3] == SC(1) && t[5] == SC(1));
	CHECK_NEAR(d(t[6]), 0.5, OCTO_FIXED ? 2e-5 : 1e-7);
}

/* Thrust curve f = k_f ((1 - a) T + a T^2): closed-form inverse against double, for convex
 * (a > 0) and concave (a < 0, down to THRMAP_CURVE_MIN) rotors. */
UNIT_TEST(thrmap_curve_inverse)
{
	const double kf = 28.0269;
	const double as[7] = {-0.5, -0.2, -0.01, 0.1, 0.3, 0.6, 0.95};
	for (int j = 0; j < 7; j++) {
		struct thrmap_params p = {s(kf), s(as[j]), {0}};
		struct thrmap m;
		thrmap_init(&m, &p);
		double a = d(p.curve);
		for (int i = 0; i <= 200; i++) {
			double T = i / 200.0;
			/* round trip: the thrust of T, rounded to a scalar, gives T back (Q16.16: within
			 * the rounding of f and u, 1 LSB each, divided by the slope df/dT) */
			double slope = (1 - a) + 2 * a * T;
			scalar_t f = s(d(p.k_f_n) * ((1 - a) * T + a * T * T));
			CHECK_NEAR(d(throttle_of(&m, f, NULL)), T, OCTO_FIXED ? 2e-5 + 4e-5 / slope : 2e-6);
			/* against the double inverse of an arbitrary thrust */
			double fx = kf * T * 0.97;
			double uu = d(s(fx)) / d(p.k_f_n);
			double Tref = 2 * uu / ((1 - a) + sqrt((1 - a) * (1 - a) + 4 * a * uu));
			CHECK_NEAR(d(throttle_of(&m, s(fx), NULL)), Tref, OCTO_FIXED ? 2e-5 + 4e-5 / slope : 2e-6);
		}
	}
	/* bad parameters are clamped, never divide by zero */
	struct thrmap_params bad = {SC(0), SC(2), {0}};
	struct thrmap m;
	thrmap_init(&m, &bad);
	CHECK(d(m.k_f_n) > 0 && d(m.curve) <= 0.99 + 1e-4);
	CHECK(throttle_of(&m, SC(1), NULL) == SC(1));
	bad.curve = SC(-3);
	thrmap_init(&m, &bad);
	CHECK_NEAR(d(m.curve), THRMAP_CURVE_MIN, 1e-4);
	scalar_t last = SC_ZERO;
	for (int i = 0; i <= 20; i++) { /* monotonic, within [0, 1] */
		scalar_t t = throttle_of(&m, sc_mul(m.k_f_n, s(i / 20.0)), NULL);
		CHECK(t >= last && t <= SC(1));
		last = t;
	}
}

/* Per-rotor effectiveness: rotor j's throttle gives scale_j times the nominal thrust, so the
 * map's throttle for f_j reproduces f_j through scale_j k_f g(T) (random scales and curve);
 * an unset scale (0) is 1 */
UNIT_TEST(thrmap_rotor_scale_round_trip)
{
	struct unit_rng g = {0x5ca1eULL};
	for (int v = 0; v < 20; v++) {
		double kf = unit_rand_uniform(&g, 15, 40), a = unit_rand_uniform(&g, 0, 0.6);
		struct thrmap_params p = {sc_from_float((float)kf), sc_from_float((float)a), {0}};
		double sc[THRMAP_ROTORS];
		for (int j = 0; j < THRMAP_ROTORS; j++) {
			sc[j] = j == v % THRMAP_ROTORS ? 1.0 : unit_rand_uniform(&g, 0.7, 1.2);
			p.scale[j] = j == v % THRMAP_ROTORS ? SC(0) : sc_from_float((float)sc[j]);
		}
		struct thrmap m;
		thrmap_init(&m, &p);
		scalar_t f[THRMAP_ROTORS], t[THRMAP_ROTORS];
		for (int j = 0; j < THRMAP_ROTORS; j++)
			f[j] = sc_from_float((float)unit_rand_uniform(&g, 1.0, 0.6 * kf * sc[j]));
		CHECK(thrmap_update(&m, f, t, THRMAP_ROTORS) == 0u);
		for (int j = 0; j < THRMAP_ROTORS; j++) {
			double tt = (double)sc_to_float(t[j]);
			double back = sc[j] * kf * ((1 - a) * tt + a * tt * tt);
			CHECK_REL(back, (double)sc_to_float(f[j]), OCTO_FIXED ? 2e-3 : 1e-5);
		}
	}
}
