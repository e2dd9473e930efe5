/*
 * Tests of firmware/core/qfmt.h (plain integer code, the same in both builds): rounding
 * against double, and saturation instead of wrapping at the edge of every format.
 */
#include "qfmt.h"
#include "unit.h"

#include <math.h>

static double q(int64_t v, int frac) { return ldexp((double)v, -frac); }

UNIT_TEST(qfmt_shifts_round_and_saturate)
{
	CHECK(q_shr64(5, 1) == 3 && q_shr64(-5, 1) == -3 && q_shr64(4, 1) == 2);
	CHECK(q_shr64(INT64_MAX, 1) == ((int64_t)1 << 62)); /* no overflow while rounding */
	CHECK(q_shr64(-INT64_MAX, 62) == -2 && q_shr64(INT64_MIN, 62) == -2);
	CHECK(q_shl64((int64_t)1 << 61, 1) == ((int64_t)1 << 62));
	CHECK(q_shl64((int64_t)1 << 62, 1) == INT64_MAX);
	CHECK(q_shl64(-((int64_t)1 << 62), 1) == -INT64_MAX);
	CHECK(q_scale64(7, 70) == INT64_MAX && q_scale64(-7, 70) == -INT64_MAX && q_scale64(7, -70) == 0);
	CHECK(q_scale32(INT32_MAX, 1) == INT32_MAX && q_scale32(-INT32_MAX, 1) == -INT32_MAX);
	CHECK(q_sat32((int64_t)INT32_MIN) == -INT32_MAX); /* symmetric range: never INT32_MIN */
	CHECK(q_add64(INT64_MAX - 1, 5) == INT64_MAX && q_add64(-INT64_MAX + 1, -5) == -INT64_MAX);
}

UNIT_TEST(qfmt_named_conversions)
{
	/* Q16.16 -> Q7.24: exact inside [-128, 128), saturated outside */
	CHECK(q24_of_q16(65536) == (1 << 24));
	CHECK(q24_of_q16(-3 * 65536) == -3 * (1 << 24));
	CHECK(q24_of_q16(128 * 65536) == INT32_MAX);
	CHECK(q24_of_q16(-200 * 65536) == -INT32_MAX);
	/* Q7.24 -> Q16.16 rounds to nearest */
	CHECK(q16_of_q24(383) == 1 && q16_of_q24(384) == 2 && q16_of_q24(-384) == -2);
	CHECK(q16_of_q24(INT32_MAX) == 8388608);
}

UNIT_TEST(qfmt_products_match_double)
{
	struct unit_rng g = {0x9f0ULL};
	for (int k = 0; k < 3000; k++) {
		int32_t a = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		int32_t b = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		int64_t w = (int64_t)unit_rand_uniform(&g, -9.2e18, 9.2e18);
		/* Q7.24 * Q7.24 -> Q7.24, saturating */
		double p24 = q(a, 24) * q(b, 24);
		int32_t m = q_mul32(a, b, 24);
		if (fabs(p24) < 127.9)
			CHECK_NEAR(q(m, 24), p24, ldexp(0.5, -24) + 1e-15 * fabs(p24));
		else
			CHECK(m == (p24 > 0 ? INT32_MAX : -INT32_MAX));
		/* int64 * Q1.30 keeps the int64's format (saturating) */
		double pw = (double)w * q(b, 30);
		int64_t mw = q_mul64_q30(w, b);
		if (fabs(pw) < 9.2e18)
			CHECK_NEAR((double)mw, pw, 2.0 + 1e-15 * fabs(pw));
		else
			CHECK(mw == (pw > 0 ? INT64_MAX : -INT64_MAX));
		/* int64 * int32 / 2^s */
		for (unsigned s = 20; s <= 60; s += 20) {
			double ps = ldexp((double)w * (double)a, -(int)s);
			int64_t ms = q_mul64_32(w, a, s);
			if (fabs(ps) < 9.2e18)
				CHECK_NEAR((double)ms, ps,
					   (s >= 32 ? 1.0 : ldexp(1.0, 32 - (int)s)) + 1e-15 * fabs(ps));
			else
				CHECK(ms == (ps > 0 ? INT64_MAX : -INT64_MAX));
		}
	}
}

UNIT_TEST(qfmt_quotients_match_double)
{
	struct unit_rng g = {0x7a7ULL};
	for (int k = 0; k < 3000; k++) {
		/* operands over many decades */
		int64_t a = (int64_t)ldexp(unit_rand_uniform(&g, 0.5, 1.0), (int)unit_rand_uniform(&g, 1, 62));
		int64_t b = (int64_t)ldexp(unit_rand_uniform(&g, 0.5, 1.0), (int)unit_rand_uniform(&g, 1, 62));
		double r = (double)a / (double)b;
		int32_t q30 = q30_ratio(a, b);
		if (r < 1.999)
			CHECK_NEAR(q(q30, 30), r, ldexp(1.0, -30) + 1e-9 * r);
		else
			CHECK(q30 == INT32_MAX);
		int sh;
		int32_t m = q30_ratio_sh(a, b, &sh);
		if (r <= 1.0) /* any small ratio keeps 30 significant bits */
			CHECK_REL(ldexp(q(m, 30), -sh), r, 3e-9);
		int32_t x = q30_ratio_x(k & 1 ? -a : a, b, &sh);
		CHECK_REL(ldexp(q(x, 30), -sh), k & 1 ? -r : r, 3e-9);
		CHECK(x == 0 || (fabs(q(x, 30)) >= 0.5 && fabs(q(x, 30)) < 2.0));
		int64_t d = q_div64(a, b);
		CHECK_NEAR((double)d, r, 0.5 + 1e-15 * r);
		/* a b / c for signals: the result's format is the operands' plus s */
		int32_t sa = (int32_t)(a >> 33), sb = (int32_t)(b >> 33);
		int64_t c = b | 1;
		double mdd = ldexp((double)sa * (double)sb / (double)c, 16);
		int64_t md = q_muldiv(sa, sb, c, 16);
		if (fabs(mdd) < 9e18)
			CHECK_NEAR((double)md, mdd, 1.0 + 1e-12 * fabs(mdd));
		else
			CHECK(md == INT64_MAX);
	}
	/* zero and sign cases */
	int sh;
	CHECK(q30_ratio(0, 5) == 0 && q30_ratio(5, 0) == INT32_MAX && q30_ratio(-5, 3) == 0);
	CHECK(q30_ratio_x(0, 7, &sh) == 0 && sh == 0);
	CHECK(q30_ratio_x(7, 0, &sh) == INT32_MAX && q30_ratio_x(-7, 0, &sh) == -INT32_MAX);
	CHECK(q30_ratio_x(INT64_MAX, 1, &sh) != 0 && sh < -60);
	CHECK(q_div64(5, 0) == INT64_MAX && q_div64(-5, 0) == -INT64_MAX && q_div64(0, 0) == 0);
	CHECK(q_div64(INT64_MAX, 1) == INT64_MAX && q_div64(INT64_MIN, -1) == INT64_MAX);
	CHECK(q_muldiv(INT32_MAX, INT32_MAX, 1, 31) == INT64_MAX);
	CHECK(q_muldiv(3, 5, 0, 0) == INT64_MAX && q_muldiv(-3, 5, 0, 0) == -INT64_MAX);
	CHECK(q_muldiv(6, 5, -3, 0) == -10);
}
