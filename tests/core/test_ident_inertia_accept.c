/* Tests of ident_inertia_accept (firmware/core/ident.h): the range is relative to the
 * vehicle's m l^2 (random mass and arm), not to a nominal inertia; rejections return the
 * bounds; an uncertain estimate returns the factor that would reach the asked accuracy. */
#include "ident.h"
#include "unit.h"

#include <math.h>

UNIT_TEST(ident_inertia_accept_scale_bounds_and_advice)
{
	struct unit_rng r = { 0x1a7eULL };
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
