/* Tests of ident_inertia_accept (firmware/core/ident.h): the range is relative to the
 * vehicle's m l^2 (random mass and arm), not to a nominal inertia; rejections return the
 * bounds; an uncertain estimate returns the factor that would reach the asked accuracy. */
#include "ident.h"
#include "unit.h"

#include <math.h>

UNIT_TEST(ident_inertia_accept_scale_bounds_and_advice)
{
	struct unit_rng r = {0x1a7eULL};
	for (int i = 0; i < 200; i++) {
		float m = (float)unit_rand_uniform(&r, 1.0, 5.0), l = (float)unit_rand_uniform(&r, 0.15, 0.6);
		float ml2 = m * l * l, lo, hi, raise;
		/* any plausible body, 3x a nominal or not: accepted */
		float est = ml2 * (float)unit_rand_uniform(&r, 0.05, 1.5);
		CHECK(ident_inertia_accept(est, 0.001f * est, m, l, 0.02f, &lo, &hi, &raise) == IDENT_ACCEPT);
		CHECK_NEAR(lo, IDENT_INR_LO * ml2, 1e-6 * ml2);
		CHECK_NEAR(hi, IDENT_INR_HI * ml2, 1e-6 * ml2);
		CHECK(raise == 1.0f);
		/* beyond the bounds: rejected, with the bounds */
		CHECK(ident_inertia_accept(2.5f * ml2, 0.0f, m, l, 0.02f, &lo, &hi, &raise) == IDENT_OUT_OF_RANGE);
		CHECK(ident_inertia_accept(0.005f * ml2, 0.0f, m, l, 0.02f, &lo, &hi, &raise) == IDENT_OUT_OF_RANGE);
		/* too uncertain: the amplitude factor that reaches rsd_max */
		float rsd_max = (float)unit_rand_uniform(&r, 0.005, 0.05), k = (float)unit_rand_uniform(&r, 1.1, 4.0);
		CHECK(ident_inertia_accept(est, k * rsd_max * est, m, l, rsd_max, &lo, &hi, &raise) == IDENT_UNCERTAIN);
		CHECK_REL(raise, k, 1e-5);
	}
	float lo, hi, raise;
	CHECK(ident_inertia_accept(NAN, 0.0f, 2.0f, 0.35f, 0.02f, &lo, &hi, &raise) == IDENT_NOT_FINITE);
}

/* ident_body_torque_mixer: the mixer's own Gamma (random arm length, random rotor mask,
 * random rotor scales): roll and pitch equal Gamma f and mixer_wrench's rows 1 and 2 bit for
 * bit, yaw the signed sum of the measured torques of the rotors present; with all rotors and
 * eq. (14) it equals ident_body_torque. */
UNIT_TEST(ident_body_torque_mixer_follows_mask_and_arm)
{
#if defined(__arm__)
	/* a second struct mixer and its design do not fit the Cortex-M0's RAM beside the other
	 * tests' statics: host builds (float, Q16.16, sanitizers) only */
	(void)u;
	return;
#else
	struct unit_rng r = {0xb0d7ULL};
	for (int i = 0; i < 50; i++) {
		struct mixer_params mp;
		mixer_default_params(&mp);
		double l = unit_rand_uniform(&r, 0.15, 0.6);
		mp.arm_l_m = sc_from_float((float)l);
		mp.rotor_mask = i < 10 ? 0xFFu : (uint8_t)(0xFFu & ~(1u << (i % 8)));
		bool scaled = i >= 5 && i % 2;
		if (scaled)
			for (int j = 0; j < 8; j++)
				mp.scale[j] = sc_from_float((float)unit_rand_uniform(&r, 0.8, 1.0));
		static struct mixer m;
		static struct mixer_design dz;
		CHECK(mixer_init_design(&m, &mp, &dz));
		scalar_t f[8], tm[8], tau[3], ref[3];
		for (int j = 0; j < 8; j++) {
			f[j] = sc_from_float((float)unit_rand_uniform(&r, 0.5, 8.0));
			tm[j] = sc_from_float((float)unit_rand_uniform(&r, 0.01, 0.1));
		}
		ident_body_torque_mixer(&m, f, tm, tau);
		scalar_t w[MIXER_N_AXES];
		mixer_wrench(&m, f, w);
		CHECK(tau[0] == w[1]);
		CHECK(tau[1] == w[2]);
		double tx = 0, ty = 0, tz = 0;
		for (int j = 0; j < 8; j++) {
			double uj = (double)sc_to_float(f[j]) / (double)sc_to_float(m.p.scale[j]);
			tx += (double)dz.gamma_f[1][j] * uj;
			ty += (double)dz.gamma_f[2][j] * uj;
			if (mp.rotor_mask & (1u << j))
				tz += (j & 1 ? -1.0 : 1.0) * (double)sc_to_float(tm[j]);
		}
		CHECK_NEAR(sc_to_float(tau[0]), tx, 2e-3 * (1 + fabs(tx)));
		CHECK_NEAR(sc_to_float(tau[1]), ty, 2e-3 * (1 + fabs(ty)));
		CHECK_NEAR(sc_to_float(tau[2]), tz, 1e-3);
		if (mp.rotor_mask == 0xFFu && !scaled) {
			ident_body_torque(mp.arm_l_m, f, tm, ref);
			for (int k = 0; k < 3; k++)
				CHECK_NEAR(sc_to_float(tau[k]), sc_to_float(ref[k]),
					   2e-3 * (1 + fabs(sc_to_float(ref[k]))));
		}
	}
#endif
}
