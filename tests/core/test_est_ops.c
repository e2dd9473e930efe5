/* Tests of firmware/core/est_ops.h: each operation against its qfmt.h definition, bit for bit,
 * over every shift count and operands of every size (the edges, powers of two and their
 * neighbours, and random words of random magnitude). */
#include "est_ops.h"
#include "unit.h"

static uint32_t rng = 2463534242u;
static uint32_t xr(void)
{
	rng ^= rng << 13;
	rng ^= rng >> 17;
	rng ^= rng << 5;
	return rng;
}

/* a Q16.16 raw word as a scalar: the word itself in the fixed build, its value in float */
static scalar_t sc_of_raw(int32_t a)
{
#if OCTO_FIXED
	return a;
#else
	return sc_from_float((float)a / 65536.0f);
#endif
}

#if OCTO_FIXED
/* a guess of the quotient or root q for est_div_near / est_sqrt_near: a few units off
 * either way (off), anything (every fifth), negative (some), clamped to [0, INT32_MAX] */
static scalar_t guess_near(int k, scalar_t q, int32_t off)
{
	if (k % 5 == 4)
		return (scalar_t)(xr() >> 1);
	if (k % 17 == 3)
		return -1;
	int64_t g = (int64_t)q + off;
	return (scalar_t)(g < 0 ? 0 : (g > INT32_MAX ? INT32_MAX : g));
}
#endif

UNIT_TEST(est_scale32_and_est_shl32c_equal_q_scale32)
{
	int32_t v[200];
	unsigned n = 0;
	const int32_t edge[] = {0, 1, -1, 2, -2, 3, -3, INT32_MAX, -INT32_MAX, INT32_MIN, INT32_MAX - 1, INT32_MIN + 2};
	for (unsigned i = 0; i < sizeof edge / sizeof edge[0]; i++)
		v[n++] = edge[i];
	for (int b = 1; b < 31; b++) {
		v[n++] = (int32_t)1 << b;
		v[n++] = ((int32_t)1 << b) + 1;
		v[n++] = -((int32_t)1 << b) - 1;
		v[n++] = ((int32_t)1 << b) - 1;
	}
	while (n < 200u) {
		uint32_t w = xr() >> (xr() % 32u);
		v[n++] = (xr() & 1u) ? -(int32_t)(w >> 1) : (int32_t)(w >> 1);
	}
	long bad = 0;
	for (int s = -70; s <= 70; s++)
		for (unsigned i = 0; i < n; i++)
			if (est_scale32(v[i], s) != q_scale32(v[i], s))
				bad++;
	for (unsigned s = 0; s <= 30u; s++)
		for (unsigned i = 0; i < n; i++)
			if (est_shl32c(v[i], s) != q_scale32(v[i], (int)s))
				bad++;
	for (int k = 0; k < 200000; k++) {
		int32_t x = (int32_t)xr();
		int s = (int)(xr() % 141u) - 70;
		if (est_scale32(x, s) != q_scale32(x, s))
			bad++;
		if (s >= 0 && s <= 30 && est_shl32c(x, (unsigned)s) != q_scale32(x, s))
			bad++;
	}
	CHECK(bad == 0);
}

/* an int64 of random magnitude and sign, often near a power of two or an edge */
static int64_t r64(void)
{
	uint32_t k = xr() % 8u;
	if (k == 0u)
		return (xr() & 1u) ? INT64_MAX : ((xr() & 1u) ? INT64_MIN : -INT64_MAX);
	int b = (int)(xr() % 64u);
	uint64_t w = ((uint64_t)xr() << 32 | xr()) >> (63 - (b > 62 ? 62 : b));
	if (k == 1u)
		w = ((uint64_t)1 << (b > 62 ? 62 : b)) + (xr() % 3u) - 1u;
	return (xr() & 1u) ? -(int64_t)w : (int64_t)w;
}

UNIT_TEST(est_shifts_and_products_equal_qfmt)
{
	long bad = 0;
	for (int k = 0; k < 20000; k++) {
		int64_t v = r64();
		int32_t b = (int32_t)(r64() >> 32);
		for (unsigned s = 0; s <= 62u; s++) {
			if (est_shr64c(v, s) != q_shr64(v, s))
				bad++;
			if (est_shl64c(v, s) != q_shl64(v, s))
				bad++;
			if (est_sat_shr64c(v, s) != q_sat32(q_shr64(v, s)))
				bad++;
			if (s >= 1u && est_mul64_32c(v, b, s) != q_mul64_32(v, b, s))
				bad++;
			if (s >= 1u && est_mul64_32(v, b, s) != q_mul64_32(v, b, s))
				bad++;
			int32_t a = (int32_t)(v >> 32), c = b == INT32_MIN ? -INT32_MAX : b;
			a = a == INT32_MIN ? -INT32_MAX : a;
			if (s >= 1u && est_mul_rnd(a, c, s) != q_shr64(q_smul32(a, c), s))
				bad++;
		}
		for (int s = -70; s <= 70; s++)
			if (est_scale64(v, s) != q_scale64(v, s))
				bad++;
	}
	CHECK(bad == 0);
}

UNIT_TEST(est_products_and_reciprocals_equal_qfmt)
{
	long bad = 0;
	for (int k = 0; k < 200000; k++) {
		uint32_t a = xr() >> (xr() % 32u), b = xr() >> (xr() % 32u);
		if (est_umul32(a, b) != q_umul32(a, b))
			bad++;
		int64_t v = r64();
		uint64_t u = (uint64_t)v;
		if (est_clz64(u) != q_clz64(u))
			bad++;
		int s = (int)(xr() % 64u);
		if (est_top32(u, s) != (uint32_t)((u << s) >> 32))
			bad++;
		int e1, e2, s1, s2;
		uint32_t y1 = est_recip(v, &e1), y2 = q_recip(v, &e2);
		if (y1 != y2 || e1 != e2)
			bad++;
		/* a quotient by a positive denominator, whose reciprocal the RLS keeps */
		int64_t d = v < 0 ? (v == INT64_MIN ? INT64_MAX : -v) : (v == 0 ? 1 : v);
		uint32_t y = q_recip(d, &e2);
		int64_t n = r64();
		if (est30_mul_recip(n, y, e2, &s1) != q30_mul_recip(n, y, e2, &s2) || s1 != s2)
			bad++;
	}
	CHECK(bad == 0);
}

UNIT_TEST(est_mul_unit_equals_sc_mul)
{
	long bad = 0;
	const int32_t edge[] = {0,     1,     -1,     32767,     32768,      32769,    65535,
				65536, 65537, -65536, INT32_MAX, -INT32_MAX, INT32_MIN};
	const unsigned ne = sizeof edge / sizeof edge[0];
	for (int k = 0; k < 400000; k++) {
		int32_t a = k < (int)(ne * ne) ? edge[k % ne] : (int32_t)(xr() >> (xr() % 32u));
		int32_t u = k < (int)(ne * ne) ? edge[k / ne] : (int32_t)(xr() % 65537u);
		if (k >= (int)(ne * ne) && (xr() & 1u))
			a = -a;
		if (k % 16 == 0)
			u = (int32_t)(xr() >> (xr() % 32u)) * ((xr() & 1u) ? 1 : -1); /* beyond [0, 1] too */
		scalar_t x = sc_of_raw(a), y = sc_of_raw(u);
		scalar_t p = est_mul_unit(x, y), q = sc_mul(x, y);
		if (!(p == q))
			bad++;
	}
	CHECK(bad == 0);
}

UNIT_TEST(est_div_int_equals_sc_div_int)
{
	long bad = 0;
	const int32_t edge[] = {0,
				1,
				-1,
				2,
				-2,
				49,
				50,
				51,
				-50,
				99,
				100,
				101,
				INT32_MAX,
				-INT32_MAX,
				INT32_MIN,
				INT32_MAX - 50,
				-INT32_MAX + 50};
	const uint32_t ns[] = {3u, 100u, 7u};
	for (unsigned i = 0; i < sizeof edge / sizeof edge[0]; i++)
		for (unsigned k = 0; k < 3u; k++) {
			scalar_t x = sc_of_raw(edge[i]);
			if (!(est_div_int(x, ns[k]) == sc_div_int(x, ns[k])))
				bad++;
		}
	for (int k = 0; k < 400000; k++) {
		int32_t a = (int32_t)(xr() >> (xr() % 32u));
		if (xr() & 1u)
			a = -a;
		scalar_t x = sc_of_raw(a);
		uint32_t n = ns[k % 3];
		if (!(est_div_int(x, n) == sc_div_int(x, n)))
			bad++;
	}
	CHECK(bad == 0);
}

UNIT_TEST(est_div_near_equals_sc_div)
{
	long bad = 0;
#if OCTO_FIXED
	long near = 0;
#endif
	for (int k = 0; k < 400000; k++) {
		int32_t a = (int32_t)(xr() >> (xr() % 32u)), b = (int32_t)(xr() >> (xr() % 32u));
		if (k % 7 == 0)
			a = -a;
		if (k % 11 == 0)
			b = -b;
		if (k % 13 == 0)
			b = 0;
		scalar_t x = sc_of_raw(a), y = sc_of_raw(b);
		scalar_t q = sc_div(x, y), g = q;
		/* guesses: the quotient, a few units off either way, far off, negative */
		int32_t off = (int32_t)(xr() % 21u) - 10;
#if OCTO_FIXED
		g = guess_near(k, q, off);
		if (g >= q - EST_DIV_STEPS && g <= q + EST_DIV_STEPS)
			near++;
#else
		(void)off;
#endif
		if (!(est_div_near(x, y, g) == q))
			bad++;
	}
	CHECK(bad == 0);
#if OCTO_FIXED
	CHECK(near > 100000); /* the guessing path was taken */
#endif
}

UNIT_TEST(est_sqrt_near_equals_sc_sqrt)
{
	long bad = 0;
#if OCTO_FIXED
	long near = 0;
#endif
	for (int k = 0; k < 400000; k++) {
		int32_t a = (int32_t)(xr() >> (xr() % 32u));
		if (k % 9 == 0)
			a = -a;
		if (k < 64)
			a = k < 32 ? k : INT32_MAX - (k - 32);
		scalar_t x = sc_of_raw(a);
		scalar_t q = sc_sqrt(x), g = q;
		int32_t off = (int32_t)(xr() % 21u) - 10;
#if OCTO_FIXED
		g = guess_near(k, q, off);
		if (g >= q - EST_DIV_STEPS && g <= q + EST_DIV_STEPS)
			near++;
#else
		(void)off;
#endif
		if (!(est_sqrt_near(x, g) == q))
			bad++;
	}
	CHECK(bad == 0);
#if OCTO_FIXED
	CHECK(near > 100000);
#endif
}
