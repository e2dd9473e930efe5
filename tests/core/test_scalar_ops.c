/* scalar_ops.h: a product by a prepared factor 1 / (a b) against the exact quotient, with
 * its rounding and saturation, in both builds */
#include "unit.h"
#include "unit_scalar.h"
#include "scalar_ops.h"

#include <math.h>

#ifdef __arm__
#define N_RAND 2000
#else
#define N_RAND 50000
#endif

/* random operands over the ranges of the throttle map (scale 0.1..4, k_f 1e-3..1000 N) and
 * beyond, random x over the whole format */
UNIT_TEST(sc_mul_gain_against_exact_quotient)
{
	struct unit_rng g = {0x6a1dULL};
	for (int i = 0; i < N_RAND; i++) {
		double ad = exp(unit_rand_uniform(&g, log(0.05), log(8.0)));
		double bd = exp(unit_rand_uniform(&g, log(1e-3), log(2000.0)));
		scalar_t a = sc_from_float((float)ad), b = sc_from_float((float)bd);
		double xd = unit_rand_uniform(&g, -1.0, 1.0) * exp(unit_rand_uniform(&g, log(1e-4), log(32767.0)));
		scalar_t x = sc_from_float((float)xd);
		struct sc_gain k = sc_gain_recip2(a, b);
		double q = d(x) / (d(a) * d(b)); /* the exact quotient of the operands */
		double r = d(sc_mul_gain(x, &k));
#if OCTO_FIXED
		if (fabs(q) >= 32767.0) { /* saturates, with the sign of x */
			CHECK(r == (x < 0 ? d(SC_MAX_NEG) : d(SC_MAX)) || fabs(r - q) <= 0.5 / 65536 + 4e-8 * fabs(q));
			continue;
		}
		/* rounded to nearest, the factor within 2^-26 */
		if (!(fabs(r - q) <= 0.5 / 65536 + 2e-8 * fabs(q))) {
			unit_fail(u, __FILE__, __LINE__, "x %d a %d b %d: %.9g, exact %.9g", (int)x, (int)a, (int)b, r,
				  q);
			return;
		}
#else
		CHECK_REL(r, q, 3e-7);
#endif
	}
#if OCTO_FIXED
	/* exact cases: x = a b gives 1, 0 gives 0, the extremes saturate with their sign */
	struct sc_gain k = sc_gain_recip2(SC(1), SC(28));
	CHECK(sc_mul_gain(SC(28), &k) == SC(1));
	CHECK(sc_mul_gain(SC(14), &k) == SC(0.5));
	CHECK(sc_mul_gain(SC(-14), &k) == SC(-0.5));
	CHECK(sc_mul_gain(0, &k) == 0);
	struct sc_gain big = sc_gain_recip2(SC(0.01), SC(0.001)); /* 1e5 */
	CHECK(sc_mul_gain(SC(1), &big) == SC_MAX);
	CHECK(sc_mul_gain(SC(-1), &big) == SC_MAX_NEG);
	CHECK(sc_mul_gain(INT32_MIN, &big) == SC_MAX_NEG);
	/* the largest operand: 2147483647 / 28 = 76695844.54, within 0.5 + 2^-26 of it x 2^31 / 28 */
	scalar_t top = sc_mul_gain(INT32_MAX, &k);
	CHECK(top >= 76695843 && top <= 76695846);
#endif
}

/* sc_sincos is sc_sin and sc_cos; sc_div_int(a, n) is sc_div(a, SC(n)): bit for bit */
UNIT_TEST(sc_sincos_and_div_int_bit_for_bit)
{
	struct unit_rng g = {0x51c0ULL};
	static const uint32_t ns[] = {1u, 2u, 3u, 7u, 100u, 1000u, 32767u};
	for (int i = 0; i < N_RAND; i++) {
		scalar_t a = sc_from_float((float)(unit_rand_uniform(&g, -1.0, 1.0) *
						   exp(unit_rand_uniform(&g, log(1e-4), log(32767.0)))));
		scalar_t sn, cs;
		sc_sincos(a, &sn, &cs);
		if (sn != sc_sin(a) || cs != sc_cos(a)) {
			unit_fail(u, __FILE__, __LINE__, "sc_sincos(%.9g)", (double)sc_to_float(a));
			return;
		}
		uint32_t n = ns[i % (int)(sizeof ns / sizeof ns[0])];
		if (sc_div_int(a, n) != sc_div(a, sc_from_int((int32_t)n))) {
			unit_fail(u, __FILE__, __LINE__, "sc_div_int(%.9g, %u)", (double)sc_to_float(a), (unsigned)n);
			return;
		}
	}
#if OCTO_FIXED
	/* the extremes and the ties (2 r = n) */
	static const int32_t v[] = {0, 1, -1, 50, -50, 150, 49, 51, INT32_MAX, -INT32_MAX, INT32_MIN, 65536};
	for (size_t i = 0; i < sizeof v / sizeof v[0]; i++)
		for (size_t j = 0; j < sizeof ns / sizeof ns[0]; j++)
			CHECK(sc_div_int(v[i], ns[j]) == sc_div(v[i], sc_from_int((int32_t)ns[j])));
#endif
}

/* sc_mul_gain_ysh in 32-bit words is the 64-bit definition (floor(x y 2^(1 - sh)) + 1) / 2,
 * saturating, bit for bit: every shift, mantissas and operands of every size and sign */
UNIT_TEST(sc_mul_gain_words_exact)
{
#if OCTO_FIXED
	struct unit_rng g = {0x9a3ULL};
	for (int i = 0; i < N_RAND; i++) {
		uint32_t y = (uint32_t)unit_rand_uniform(&g, 2147483648.0, 4294967295.0);
		uint32_t sh = 1u + (uint32_t)i % 63u;
		int32_t x = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		x >>= (int)unit_rand_uniform(&g, 0, 31);
		if (i % 97 == 0)
			x = i % 2 ? INT32_MIN : INT32_MAX;
		uint32_t ux = x < 0 ? 0u - (uint32_t)x : (uint32_t)x;
		uint64_t r = (((uint64_t)ux * y) >> (sh - 1u)) + 1u;
		r >>= 1;
		scalar_t ref =
			r > (uint64_t)INT32_MAX ? (x < 0 ? SC_MAX_NEG : SC_MAX) : (x < 0 ? -(scalar_t)r : (scalar_t)r);
		if (sc_mul_gain_ysh(x, y, sh) != ref) {
			unit_fail(u, __FILE__, __LINE__, "sc_mul_gain_ysh(%d, %u, %u) = %d, expected %d", (int)x,
				  (unsigned)y, (unsigned)sh, (int)sc_mul_gain_ysh(x, y, sh), (int)ref);
			return;
		}
	}
#else
	struct sc_gain k = sc_gain_recip2(2.0f, 4.0f);
	CHECK(sc_mul_gain(1.0f, &k) == 0.125f);
#endif
}
