/* sc_recip.h: a division by a prepared reciprocal is sc_div bit for bit, in both builds */
#include "unit.h"
#include "sc_recip.h"

/* random cases: fewer under QEMU */
#ifdef __arm__
#define N_RAND 3000
#else
#define N_RAND 50000
#endif

UNIT_TEST(sc_recip_div_equals_sc_div)
{
	struct unit_rng g = {0x5ec1ULL};
#if OCTO_FIXED
	for (int i = 0; i < N_RAND; i++) {
		int32_t a = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		int32_t b = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		a >>= (int)unit_rand_uniform(&g, 0, 31);
		b >>= (int)unit_rand_uniform(&g, 0, 31);
		struct sc_recip r = sc_recip_of(b);
		if (sc_div_r(a, b, &r) != sc_div(a, b)) {
			unit_fail(u, __FILE__, __LINE__, "sc_div_r(%d, %d) = %d, sc_div %d", (int)a, (int)b,
				  (int)sc_div_r(a, b, &r), (int)sc_div(a, b));
			return;
		}
	}
	/* edges: zero divisors, saturation, the extreme operands */
	static const int32_t v[] = {0,      1,      -1,         2,         3,          65535,      65536,
				    -65536, 0x8000, 0x40000000, INT32_MAX, -INT32_MAX, 0x55555555, 12345677};
	for (size_t i = 0; i < sizeof v / sizeof v[0]; i++) {
		struct sc_recip r = sc_recip_of(v[i]);
		for (size_t j = 0; j < sizeof v / sizeof v[0]; j++)
			CHECK(sc_div_r(v[j], v[i], &r) == sc_div(v[j], v[i]));
	}
#else
	for (int i = 0; i < 2000; i++) {
		float a = (float)unit_rand_uniform(&g, -1e4, 1e4), b = (float)unit_rand_uniform(&g, -10, 10);
		struct sc_recip r = sc_recip_of(b);
		CHECK(sc_div_r(a, b, &r) == sc_div(a, b));
	}
	struct sc_recip z = sc_recip_of(0.0f);
	CHECK(sc_div_r(1.0f, 0.0f, &z) == SC_MAX && sc_div_r(-1.0f, 0.0f, &z) == SC_MAX_NEG);
	CHECK(sc_div_r(0.0f, 0.0f, &z) == 0.0f);
#endif
}

/* quotients near the saturation bound (2^31 LSB), where the prepared reciprocal's error is
 * largest in units of the quotient, and just beyond it */
UNIT_TEST(sc_recip_div_large_quotients)
{
#if OCTO_FIXED
	struct unit_rng g = {0x1a59ULL};
	for (int i = 0; i < N_RAND; i++) {
		int32_t b = (int32_t)unit_rand_uniform(&g, 1.0, 65536.0);
		int32_t a = (int32_t)((double)b * unit_rand_uniform(&g, 32760.0, 32768.5));
		if (unit_rand_uniform(&g, 0, 1) < 0.5)
			b = -b;
		struct sc_recip r = sc_recip_of(b);
		if (sc_div_r(a, b, &r) != sc_div(a, b) || sc_div_r(-a, b, &r) != sc_div(-a, b)) {
			unit_fail(u, __FILE__, __LINE__, "sc_div_r(%d, %d) = %d, sc_div %d", (int)a, (int)b,
				  (int)sc_div_r(a, b, &r), (int)sc_div(a, b));
			return;
		}
	}
#else
	(void)u; /* the float build's quotients are the IEEE ones: nothing prepared */
#endif
}
