/* Tests of firmware/core/scalar.h in whichever build (float or Q16.16) this is. */
#include "unit_scalar.h"
#include "scalar.h"
#include "unit.h"

#include <math.h>
#include <string.h>

/* random cases per exactness test: fewer under QEMU, where each costs thousands of
 * emulated instructions */
#ifdef __arm__
#define N_RAND 3000
#else
#define N_RAND 50000
#endif

#if OCTO_FIXED
#define LSB (1.0 / 65536.0)
#else
#define LSB 1e-7
#endif

UNIT_TEST(scalar_arithmetic_matches_double)
{
	struct unit_rng r = {0x5ca1ab1eULL};
	for (int i = 0; i < 2000; i++) {
		double a = unit_rand_uniform(&r, -150.0, 150.0), b = unit_rand_uniform(&r, -150.0, 150.0);
		scalar_t sa = sc_from_float((float)a), sb = sc_from_float((float)b);
		double qa = d(sa), qb = d(sb); /* the values actually represented */
		CHECK_NEAR(d(sc_add(sa, sb)), qa + qb, OCTO_FIXED ? 0 : 1e-7 * (1 + fabs(qa + qb)));
		CHECK_NEAR(d(sc_sub(sa, sb)), qa - qb, OCTO_FIXED ? 0 : 1e-7 * (1 + fabs(qa - qb)));
		CHECK_NEAR(d(sc_mul(sa, sb)), qa * qb, OCTO_FIXED ? 0.5 * LSB : 1e-7 * (1 + fabs(qa * qb)));
		if (qb > 0.5 || qb < -0.5)
			CHECK_NEAR(d(sc_div(sa, sb)), qa / qb, OCTO_FIXED ? 0.5 * LSB : 1e-7 * (1 + fabs(qa / qb)));
		if (qa >= 0)
			CHECK_NEAR(d(sc_sqrt(sa)), sqrt(qa), OCTO_FIXED ? LSB : 1e-7 * (1 + sqrt(qa)));
	}
}

UNIT_TEST(scalar_saturates_and_guards)
{
	/* division by zero saturates by the sign of the dividend, never NaN */
	CHECK(sc_div(SC(1), SC(0)) == SC_MAX);
	CHECK(sc_div(SC(-1), SC(0)) == SC_MAX_NEG);
	CHECK(sc_div(SC(0), SC(0)) == SC(0));
	CHECK(sc_sqrt(SC(-4)) == SC(0));
	CHECK(sc_clamp(SC(3), SC(-1), SC(2)) == SC(2));
	CHECK(sc_clamp(SC(-3), SC(-1), SC(2)) == SC(-1));
	CHECK(sc_min(SC(1), SC(2)) == SC(1) && sc_max(SC(1), SC(2)) == SC(2));
#if OCTO_FIXED
	/* Q16.16 saturates instead of wrapping */
	CHECK(sc_add(SC(30000), SC(30000)) == SC_MAX);
	CHECK(sc_sub(SC(-30000), SC(30000)) == SC_MAX_NEG);
	CHECK(sc_mul(SC(300), SC(300)) == SC_MAX);
	CHECK(sc_mul(SC(-300), SC(300)) == SC_MAX_NEG);
	CHECK(sc_from_float(1e9f) == SC_MAX);
	CHECK(sc_from_float(-1e9f) == SC_MAX_NEG);
	CHECK(sc_from_float(__builtin_nanf("")) == 0);
	CHECK(sc_neg(INT32_MIN) == SC_MAX);
	/* rounding to nearest: 1.5 * 2^-16 * 1.0 stays, 3 LSB / 2 rounds away from zero */
	CHECK(sc_mul(3, SC(0.5)) == 2);
	CHECK(sc_mul(-3, SC(0.5)) == -2);
	CHECK(sc_div(SC(1), SC(3)) == 21845);
	CHECK(sc_div(SC(2), SC(3)) == 43691);
	CHECK(SC(0.5) == 32768 && SC(-0.25) == -16384);
#else
	CHECK(sc_isfinite(SC(1)));
	CHECK(!sc_isfinite(sc_from_float(__builtin_inff())));
#endif
}

UNIT_TEST(scalar_trigonometry)
{
	for (int i = -30; i <= 30; i++) {
		double x = i * 0.1;
		scalar_t s = sc_from_float((float)x);
		double tol = OCTO_FIXED ? 4 * LSB : 1e-6;
		CHECK_NEAR(d(sc_sin(s)), sin(d(s)), tol);
		CHECK_NEAR(d(sc_cos(s)), cos(d(s)), tol);
		CHECK_NEAR(d(sc_atan2(s, SC(1))), atan2(d(s), 1.0), tol);
	}
	CHECK_NEAR(d(sc_asin(SC(0.5))), 0.5235987755982988, OCTO_FIXED ? 4 * LSB : 1e-6);
}

UNIT_TEST(scalar_exp)
{
	for (int i = -40; i <= 20; i++) {
		double x = i * 0.25;
		scalar_t s = sc_from_float((float)x);
		double ref = exp(d(s));
		/* Q16.16: through float, rounded to 1 LSB plus float's relative error */
		double tol = OCTO_FIXED ? LSB + 2e-7 * ref : 2e-7 * ref;
		CHECK_NEAR(d(sc_exp(s)), ref, tol);
	}
#if OCTO_FIXED
	CHECK(sc_exp(SC(20)) == SC_MAX); /* e^20 > 32768 saturates */
	CHECK(sc_exp(SC(10.397)) < SC_MAX && sc_exp(SC(10.3973)) == SC_MAX);
	CHECK(sc_exp(SC_MAX) == SC_MAX && sc_exp(SC_MAX_NEG) == 0 && sc_exp(SC(-13)) == 0);
	CHECK(sc_exp(0) == SC(1));
	/* integer in the fixed build: within 0.5 LSB + 1e-8 relative over the whole range */
	struct unit_rng g = {0xe4bULL};
	for (int i = 0; i < 5000; i++) {
		scalar_t s = (scalar_t)unit_rand_uniform(&g, -13.0 * 65536, 10.39 * 65536);
		double ref = exp(d(s));
		CHECK_NEAR(d(sc_exp(s)), ref, 0.5 * LSB + 1e-8 * ref);
	}
#endif
}

/* sc_div is exact: the quotient rounded to nearest (ties away from zero), as a 64-bit
 * division gives it, for divisors and dividends of every size, and saturated beyond */
UNIT_TEST(scalar_div_exact)
{
#if OCTO_FIXED
	struct unit_rng g = {0xd1fULL};
	for (int i = 0; i < 20000; i++) {
		int32_t a = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		int32_t b = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		a >>= (int)unit_rand_uniform(&g, 0, 31);
		b >>= (int)unit_rand_uniform(&g, 0, 31);
		if (b == 0)
			continue;
		int64_t n = (int64_t)a * 65536, half = (b > 0 ? (int64_t)b : -(int64_t)b) / 2;
		n += ((n >= 0) == (b > 0)) ? (b > 0 ? half : -half) : -(b > 0 ? half : -half);
		int64_t q = n / b;
		scalar_t ref = q > INT32_MAX ? SC_MAX : (q < -(int64_t)INT32_MAX ? SC_MAX_NEG : (scalar_t)q);
		if (sc_div(a, b) != ref) {
			unit_fail(u, __FILE__, __LINE__, "sc_div(%d, %d) = %d, expected %d", (int)a, (int)b,
				  (int)sc_div(a, b), (int)ref);
			return;
		}
	}
	CHECK(sc_div(SC_MAX, 1) == SC_MAX && sc_div(SC_MAX_NEG, 1) == SC_MAX_NEG);
	CHECK(sc_div(SC(1), SC(3)) == 21845 && sc_div(SC(-1), SC(3)) == -21845);
	CHECK(sc_div(1, 2) == 32768 && sc_div(SC_MAX, SC_MAX) == SC(1));
#else
	/* float: the IEEE quotient, and zero divisors saturate */
	struct unit_rng g = {0xd1fULL};
	for (int i = 0; i < 2000; i++) {
		float a = (float)unit_rand_uniform(&g, -1e4, 1e4), b = (float)unit_rand_uniform(&g, -10, 10);
		CHECK(b == 0.0f || sc_div(a, b) == a / b);
	}
	CHECK(sc_div(1.0f, 0.0f) == SC_MAX && sc_div(-1.0f, 0.0f) == SC_MAX_NEG);
#endif
}

/* sc_mul is exact: |a b| / 2^16 rounded to nearest (ties away from zero) as a 64-bit product
 * gives it, for operands of every size, saturated beyond */
UNIT_TEST(scalar_mul_exact)
{
#if OCTO_FIXED
	struct unit_rng g = {0x3a1ULL};
	for (int i = 0; i < N_RAND; i++) {
		int32_t a = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		int32_t b = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		a >>= (int)unit_rand_uniform(&g, 0, 31);
		b >>= (int)unit_rand_uniform(&g, 0, 31);
		int64_t p = (int64_t)a * b;
		p = (p >= 0 ? p + 32768 : p - 32768) / 65536;
		scalar_t ref = p > INT32_MAX ? SC_MAX : (p < -(int64_t)INT32_MAX ? SC_MAX_NEG : (scalar_t)p);
		if (sc_mul(a, b) != ref) {
			unit_fail(u, __FILE__, __LINE__, "sc_mul(%d, %d) = %d, expected %d", (int)a, (int)b,
				  (int)sc_mul(a, b), (int)ref);
			return;
		}
	}
	CHECK(sc_mul(INT32_MIN, 1) == -32768 && sc_mul(INT32_MIN, INT32_MIN) == SC_MAX);
	CHECK(sc_mul(INT32_MIN, SC(1)) == SC_MAX_NEG && sc_mul(SC_MAX, SC(-1)) == SC_MAX_NEG);
	CHECK(sc_mul(SC(181), SC(181)) == SC(32761) && sc_mul(SC(182), SC(181)) == SC_MAX);
	CHECK(sc_mul(46340 << 8, 46340 << 8) == (scalar_t)(((int64_t)46340 * 46340 * 65536 + 32768) / 65536));
	CHECK(sc_mul(SC(0.5), SC(0.5)) == SC(0.25) && sc_mul(1, 32768) == 1 && sc_mul(1, 32767) == 0);
#else
	CHECK(sc_mul(3.0f, 0.5f) == 1.5f && sc_mul(-2.0f, 1e30f) == -2e30f);
#endif
}

/* sc_mul's two paths: the smaller magnitude below 1 (two products) or not (four), at their
 * boundary (|b| = 2^16 - 1, 2^16, 2^16 + 1), in either operand order and both signs, with
 * the other operand of every size up to saturation; against the 64-bit definition */
UNIT_TEST(scalar_mul_paths_exact)
{
#if OCTO_FIXED
	struct unit_rng g = {0x5a1ULL};
	static const int32_t small[] = {0,      1,      2,       0x7fff,  0x8000,  0x8001,
					0xfffe, 0xffff, 0x10000, 0x10001, 0x1ffff, 0x20000};
	for (int i = 0; i < N_RAND; i++) {
		int32_t b = small[i % (int)(sizeof small / sizeof small[0])];
		double hi = 2147483647.0;
		if (i % 3 == 0 && b) /* near the saturation bound: |a b| / 2^16 up to about 2^31 */
			hi = fmin(hi, 2147483647.0 / ((double)b / 65536.0) * 1.001);
		int32_t a = (int32_t)unit_rand_uniform(&g, 0, hi);
		if (i % 3 == 1)
			a >>= (int)unit_rand_uniform(&g, 0, 31);
		for (int k = 0; k < 8; k++) {
			int32_t x = k & 1 ? -a : a, y = k & 2 ? -b : b;
			if (k & 4) {
				int32_t tmp = x;
				x = y;
				y = tmp;
			}
			int64_t p = (int64_t)x * y;
			p = (p >= 0 ? p + 32768 : p - 32768) / 65536;
			scalar_t ref = p > INT32_MAX ? SC_MAX : (p < -(int64_t)INT32_MAX ? SC_MAX_NEG : (scalar_t)p);
			if (sc_mul(x, y) != ref) {
				unit_fail(u, __FILE__, __LINE__, "sc_mul(%d, %d) = %d, expected %d", (int)x, (int)y,
					  (int)sc_mul(x, y), (int)ref);
				return;
			}
		}
	}
	/* the smaller operand just below 1 with the largest other: the two-product path's
	 * largest sum (ah bl + rounding), and ties */
	CHECK(sc_mul(INT32_MAX, 0xffff) == (scalar_t)(((int64_t)INT32_MAX * 0xffff + 32768) / 65536));
	CHECK(sc_mul(INT32_MIN, 0xffff) == -(scalar_t)(((int64_t)2147483648LL * 0xffff + 32768) / 65536));
	CHECK(sc_mul(0xffff, INT32_MIN) == sc_mul(INT32_MIN, 0xffff));
	CHECK(sc_mul(INT32_MIN, 0x10000) == SC_MAX_NEG && sc_mul(INT32_MAX, 0x10000) == INT32_MAX);
	CHECK(sc_mul(3, 0x8000) == 2 && sc_mul(-3, 0x8000) == -2 && sc_mul(0x8000, 1) == 1);
#else
	(void)u;
#endif
}

/* sc_div's worst cases: quotients near 2^31 and divisors near powers of two */
UNIT_TEST(scalar_div_exact_edges)
{
#if OCTO_FIXED
	static const int32_t bs[] = {1,      2,      3,          65535,      65536,     65537,      0x7fff,
				     0x8000, 0x8001, 0x40000000, 0x3fffffff, INT32_MAX, 0x55555555, 12345677};
	for (size_t i = 0; i < sizeof bs / sizeof bs[0]; i++) {
		for (int k = -40; k <= 40; k++) {
			int32_t b = bs[i];
			int64_t a64 = (int64_t)b / 2 + k * 9973; /* quotients near 32768 */
			for (int sh = 0; sh < 2; sh++) {
				int32_t a = (int32_t)(sh ? (a64 % INT32_MAX) : (int64_t)b * 3 / 4 + k);
				int64_t n = (int64_t)a * 65536, half = (int64_t)b / 2;
				n += n >= 0 ? half : -half;
				int64_t q = n / b;
				scalar_t ref =
					q > INT32_MAX ? SC_MAX : (q < -(int64_t)INT32_MAX ? SC_MAX_NEG : (scalar_t)q);
				CHECK(sc_div(a, b) == ref && sc_div(-a, -b) == ref);
			}
		}
		/* the largest quotients below saturation */
		int64_t a = ((int64_t)bs[i] * (INT32_MAX - 3)) >> 16;
		for (int k = -3; k <= 3; k++) {
			int64_t aa = a + k;
			if (aa > INT32_MAX || aa < -INT32_MAX)
				continue;
			int64_t n = aa * 65536 + bs[i] / 2, q = n / bs[i];
			scalar_t ref = q > INT32_MAX ? SC_MAX : (scalar_t)q;
			CHECK(sc_div((int32_t)aa, bs[i]) == ref);
		}
	}
#else
	CHECK(sc_div(3.0f, 4.0f) == 0.75f && sc_div(1.0f, 3.0f) == 1.0f / 3.0f);
#endif
}

/* float conversions by bit assembly: sc_to_float is (float)a / 65536 bit for bit, and
 * sc_from_float rounds x 2^16 to nearest (ties away from zero), as double arithmetic does */
UNIT_TEST(scalar_float_conversions_exact)
{
#if OCTO_FIXED
	struct unit_rng g = {0xf10aULL};
	for (int i = 0; i < N_RAND; i++) {
		int32_t a = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		a >>= (int)unit_rand_uniform(&g, 0, 31);
		float f = sc_to_float(a), ref = (float)a / 65536.0f;
		if (memcmp(&f, &ref, sizeof f) != 0) {
			unit_fail(u, __FILE__, __LINE__, "sc_to_float(%d) = %.9g, expected %.9g", (int)a, (double)f,
				  (double)ref);
			return;
		}
		double x = unit_rand_uniform(&g, -1.0, 1.0) * ldexp(1.0, (int)unit_rand_uniform(&g, -20, 17));
		float xf = (float)x;
		double s = (double)xf * 65536.0;
		double r = s >= 0 ? floor(s + 0.5) : -floor(-s + 0.5);
		scalar_t want = r >= 2147483647.0 ? SC_MAX : (r <= -2147483647.0 ? SC_MAX_NEG : (scalar_t)r);
		if (sc_from_float(xf) != want) {
			unit_fail(u, __FILE__, __LINE__, "sc_from_float(%.9g) = %d, expected %d", (double)xf,
				  (int)sc_from_float(xf), (int)want);
			return;
		}
	}
	CHECK(sc_to_float(INT32_MIN) == -32768.0f && sc_to_float(SC_MAX) == 32768.0f);
	CHECK(sc_to_float(1) == 1.0f / 65536.0f && sc_to_float(-1) == -1.0f / 65536.0f);
	CHECK(sc_from_float(32767.998046875f) == 2147483520 && sc_from_float(32768.0f) == SC_MAX);
	CHECK(sc_from_float(-32768.0f) == SC_MAX_NEG && sc_from_float(__builtin_inff()) == SC_MAX);
	CHECK(sc_from_float(-__builtin_inff()) == SC_MAX_NEG && sc_from_float(-0.0f) == 0);
	CHECK(sc_from_float(1.5f / 65536.0f) == 2 && sc_from_float(-1.5f / 65536.0f) == -2);
	CHECK(sc_from_float(0.49999997f / 65536.0f) == 0 && sc_from_float(1e-30f) == 0);
	CHECK(sc_from_float(128.0f + 3.0f / 65536.0f) == SC(128) + 3);
#else
	CHECK(sc_to_float(0.1f) == 0.1f && sc_from_float(-7.25f) == -7.25f);
#endif
}

/* integer sine and cosine over the whole Q16.16 range against libm, within 1 LSB (the
 * radians-to-turns phase is within |a| / 2 + 1 units of 2^-32 turn) */
UNIT_TEST(scalar_sin_cos_integer)
{
#if OCTO_FIXED
	struct unit_rng g = {0x51cULL};
	for (int i = 0; i < N_RAND; i++) {
		scalar_t a = (scalar_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		a >>= (int)unit_rand_uniform(&g, 0, 31);
		double tol = 0.6 * LSB + (0.5 * fabs(d(a)) + 1.0) * 6.283185307179586 / 4294967296.0;
		CHECK_NEAR(d(sc_sin(a)), sin(d(a)), tol);
		CHECK_NEAR(d(sc_cos(a)), cos(d(a)), tol);
	}
	CHECK(sc_sin(0) == 0 && sc_cos(0) == SC(1) && sc_sin(SC(1.5707963)) == SC(1));
	CHECK(sc_cos(SC(3.14159265)) == SC(-1) && sc_sin(SC(-1.5707963)) == SC(-1));
#else
	CHECK(sc_sin(0.5f) == sinf(0.5f) && sc_cos(0.5f) == cosf(0.5f));
#endif
}

/* sc_add and sc_sub (and their always inline forms sca_add, sca_sub) are exact and saturate to
 * [SC_MAX_NEG, SC_MAX] for operands of every size */
UNIT_TEST(scalar_add_sub_exact)
{
#if OCTO_FIXED
	struct unit_rng g = {0xadd5ULL};
	for (int i = 0; i < N_RAND; i++) {
		int32_t a = (int32_t)unit_rand_uniform(&g, -2147483648.0, 2147483647.0);
		int32_t b = (int32_t)unit_rand_uniform(&g, -2147483648.0, 2147483647.0);
		a >>= (int)unit_rand_uniform(&g, 0, 3);
		if (i % 7 == 0)
			a = i % 2 ? INT32_MIN : INT32_MAX;
		if (i % 11 == 0)
			b = i % 3 ? INT32_MIN : (i % 2 ? 0 : INT32_MAX);
		int64_t s = (int64_t)a + b, d_ = (int64_t)a - b;
		scalar_t rs = s > INT32_MAX ? SC_MAX : (s < -(int64_t)INT32_MAX ? SC_MAX_NEG : (scalar_t)s);
		scalar_t rd = d_ > INT32_MAX ? SC_MAX : (d_ < -(int64_t)INT32_MAX ? SC_MAX_NEG : (scalar_t)d_);
		if (sc_add(a, b) != rs || sc_sub(a, b) != rd || sca_add(a, b) != rs || sca_sub(a, b) != rd) {
			unit_fail(u, __FILE__, __LINE__, "sc_add/sc_sub(%d, %d) = %d/%d, expected %d/%d", (int)a,
				  (int)b, (int)sc_add(a, b), (int)sc_sub(a, b), (int)rs, (int)rd);
			return;
		}
	}
	CHECK(sc_add(INT32_MIN, 0) == SC_MAX_NEG && sc_sub(INT32_MIN, 0) == SC_MAX_NEG);
	CHECK(sc_add(0, INT32_MIN) == SC_MAX_NEG && sc_add(-1, INT32_MIN + 1) == SC_MAX_NEG);
	CHECK(sc_add(INT32_MIN, INT32_MIN) == SC_MAX_NEG && sc_add(SC_MAX_NEG, SC_MAX_NEG) == SC_MAX_NEG);
	CHECK(sc_sub(-1, INT32_MAX) == SC_MAX_NEG && sc_sub(INT32_MIN, INT32_MIN) == 0);
	CHECK(sca_add(0, INT32_MIN) == SC_MAX_NEG && sca_sub(-1, INT32_MAX) == SC_MAX_NEG);
	CHECK(sca_add(SC_MAX, 1) == SC_MAX && sca_sub(0, INT32_MIN) == SC_MAX && sca_add(3, -5) == -2);
	CHECK(sc_sub(0, INT32_MIN) == SC_MAX && sc_sub(-1, INT32_MIN) == SC_MAX &&
	      sc_sub(-2, INT32_MIN) == INT32_MAX - 1);
	CHECK(sc_add(SC_MAX, SC_MAX_NEG) == 0 && sc_add(SC_MAX, 1) == SC_MAX && sc_sub(SC_MAX_NEG, 1) == SC_MAX_NEG);
#else
	CHECK(sc_add(1.5f, 2.25f) == 3.75f && sc_sub(1.5f, 2.25f) == -0.75f);
#endif
}

/* integer atan2 and asin against libm over operands of every size: within 0.6 LSB */
UNIT_TEST(scalar_atan2_asin_integer)
{
#if OCTO_FIXED
	struct unit_rng g = {0xa7a2ULL};
	for (int i = 0; i < N_RAND; i++) {
		scalar_t y = (scalar_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		scalar_t x = (scalar_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		y >>= (int)unit_rand_uniform(&g, 0, 31);
		x >>= (int)unit_rand_uniform(&g, 0, 31);
		CHECK_NEAR(d(sc_atan2(y, x)), atan2(d(y), d(x)), 0.6 * LSB);
		scalar_t a = (scalar_t)unit_rand_uniform(&g, -65536.0, 65536.0);
		CHECK_NEAR(d(sc_asin(a)), asin(d(a)), 0.6 * LSB);
	}
	CHECK(sc_atan2(0, 0) == 0 && sc_atan2(0, SC(-1)) == SC(3.14159265358979) && sc_atan2(0, 5) == 0);
	CHECK(sc_atan2(SC(1), 0) == SC(1.5707963267949) && sc_atan2(SC(-1), 0) == -SC(1.5707963267949));
	CHECK(sc_asin(SC(1)) == SC(1.5707963267949) && sc_asin(SC(-2)) == -SC(1.5707963267949));
	CHECK(sc_asin(SC(0.5)) == SC(0.5235987755982988) && sc_asin(0) == 0);
	CHECK(sc_asin(65535) == SC(asin(65535.0 / 65536.0)));
#else
	CHECK(sc_atan2(1.0f, 2.0f) == atan2f(1.0f, 2.0f) && sc_asin(0.5f) == asinf(0.5f));
#endif
}

/* sc_sqrt is sqrt(a 2^16) rounded to nearest for every a (ties cannot occur) */
UNIT_TEST(scalar_sqrt_exact)
{
#if OCTO_FIXED
	struct unit_rng g = {0x5a27ULL};
	for (int i = 0; i < N_RAND; i++) {
		int32_t a = (int32_t)unit_rand_uniform(&g, 0.0, 2147483647.0);
		a >>= (int)unit_rand_uniform(&g, 0, 31);
		if (i < 64)
			a = i < 32 ? i : INT32_MAX - (i - 32);
		int64_t n = (int64_t)a * 65536, r = (int64_t)floor(sqrt((double)n));
		while (r * r > n)
			r--;
		while ((r + 1) * (r + 1) <= n)
			r++;
		if (n - r * r > r)
			r++;
		if (a > 0 && sc_sqrt(a) != (scalar_t)r) {
			unit_fail(u, __FILE__, __LINE__, "sc_sqrt(%d) = %d, expected %d", (int)a, (int)sc_sqrt(a),
				  (int)r);
			return;
		}
	}
	CHECK(sc_sqrt(0) == 0 && sc_sqrt(-5) == 0 && sc_sqrt(SC(4)) == SC(2) && sc_sqrt(SC(2)) == 92682);
#else
	CHECK(sc_sqrt(4.0f) == 2.0f && sc_sqrt(-1.0f) == 0.0f);
#endif
}

/* The trigonometry's products in 32-bit words (sc_qmul32w, sc_turns) are qfmt.h's q_mul32
 * and the 64-bit phase product bit for bit: random operands of every size and sign, every
 * shift the trigonometry uses and the ends of the range (fixed build) */
UNIT_TEST(scalar_trig_products_in_words_exact)
{
#if OCTO_FIXED
	struct unit_rng g = {0x7e1ULL};
	static const unsigned sh[] = {1, 14, 16, 30, 31, 32, 33, 44, 62, 63};
	static const int32_t edge[] = {0,         1,          -1,        0x40000000, -0x40000000,
				       INT32_MAX, -INT32_MAX, INT32_MIN, 0xffff,     0x10000};
	for (int i = 0; i < N_RAND; i++) {
		int32_t a = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		int32_t b = (int32_t)unit_rand_uniform(&g, -2147483647.0, 2147483647.0);
		if (i % 4 == 1)
			a = edge[i / 4 % 10];
		a >>= (int)unit_rand_uniform(&g, 0, 31);
		b >>= (int)unit_rand_uniform(&g, 0, 31);
		unsigned s = sh[i % 10];
		if (sc_qmul32w(a, b, s) != q_mul32(a, b, s)) {
			unit_fail(u, __FILE__, __LINE__, "sc_qmul32w(%d, %d, %u) = %d, q_mul32 %d", (int)a, (int)b, s,
				  (int)sc_qmul32w(a, b, s), (int)q_mul32(a, b, s));
			return;
		}
		if (sc_turns(a) != (uint32_t)((uint64_t)q_smul32(a, 683565276) >> 16)) {
			unit_fail(u, __FILE__, __LINE__, "sc_turns(%d)", (int)a);
			return;
		}
	}
	for (int i = 0; i < 10; i++)
		for (int j = 0; j < 10; j++)
			for (int k = 0; k < 10; k++)
				CHECK(sc_qmul32w(edge[i], edge[j], sh[k]) == q_mul32(edge[i], edge[j], sh[k]));
	for (int i = 0; i < 10; i++)
		CHECK(sc_turns(edge[i]) == (uint32_t)((uint64_t)q_smul32(edge[i], 683565276) >> 16));
#else
	CHECK(sc_sin(0.0f) == 0.0f); /* float build: libm's trigonometry */
#endif
}
