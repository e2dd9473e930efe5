/*
 * est_ops.h - integer operations of the estimators' per-frame updates (rls.c, motor_id.c)
 * in forms that cost less on Cortex-M0 than their qfmt.h definitions, with the same results.
 *
 * Cortex-M0 has no 64-bit shift: a 64-bit shift by a variable count is a library call there
 * (__ashldi3, __ashrdi3), and at -Os the compiler calls qfmt.h's small functions rather than
 * inlining them (q_scale32 -> q_scale64 -> q_shr64 -> __ashrdi3 is four calls deep). So
 *   - est_scale32, est_scale64 and est_mul64_32 do q_scale32's, q_scale64's and q_mul64_32's
 *     shifts by a variable count on 32-bit words;
 *   - the est_*c functions are qfmt.h's shifts and products always inlined, for calls whose
 *     shift count is a constant: a 64-bit shift by a constant is a few 32-bit shifts. They are
 *     meant for the few hottest calls only (each inlined copy costs flash).
 *   - est_umul32, est_clz64 and est_top32 are q_umul32, q_clz64 and a 64-bit shift always
 *     inlined or on 32-bit halves, for est_recip and est30_mul_recip (q_recip and
 *     q30_mul_recip: the RLS update's reciprocals and gains) and the products above.
 *   - est_mul_unit is sc_mul by a factor in [0, 1] (a throttle, a lag coefficient) in 32-bit
 *     words, one copy per object (the trackers' per-frame products); est_div_int is
 *     sc_div_int by 3 or 100 without a library division; est_div_near is sc_div of
 *     non-negative operands from a close guess of the quotient (kf_track's quotients change
 *     little from frame to frame), without preparing a reciprocal; est_sqrt_near is sc_sqrt
 *     from a close guess of the root.
 * tests/core/test_est_ops.c compares each function here with its qfmt.h (or scalar.h)
 * definition bit for bit over every shift count and operands of every size, on the host and
 * under QEMU.
 */
#ifndef OCTO_EST_OPS_H
#define OCTO_EST_OPS_H

#include "qfmt.h"
#include "scalar.h"
#include "scalar_ops.h"

#if defined(__GNUC__)
#define EST_INLINE static inline __attribute__((always_inline))
#else
#define EST_INLINE static inline
#endif

/* q_umul32(a, b) always inlined: the products below are the RLS update's most frequent
 * operation, and a call costs about half as much again as the product on Cortex-M0 */
EST_INLINE uint64_t est_umul32(uint32_t a, uint32_t b) { return qa_umul32(a, b); }

/* q_clz32(v) always inlined */
EST_INLINE int est_clz32(uint32_t v) { return qa_clz32(v); }

/* q_clz64(v) from the clz of the word that holds the leading one */
EST_INLINE int est_clz64(uint64_t v)
{
	uint32_t hi = (uint32_t)(v >> 32);
	return hi ? est_clz32(hi) : 32 + est_clz32((uint32_t)v);
}

/* (uint32_t)((v << s) >> 32) for s in [0, 63]: the word below bit 64 - s, on the 32-bit
 * halves (a 64-bit shift by a variable count is a library call on Cortex-M0) */
EST_INLINE uint32_t est_top32(uint64_t v, int s)
{
	uint32_t hi = (uint32_t)(v >> 32), lo = (uint32_t)v;
	if (s >= 32)
		return lo << (s - 32);
	return s == 0 ? hi : (hi << s) | (lo >> (32 - s));
}

/* q_shr64(v, s): v / 2^s rounded to nearest (ties away from zero), s in [0, 62] */
EST_INLINE int64_t est_shr64c(int64_t v, unsigned s) { return qa_shr64(v, s); }

/* q_shl64(v, s): v 2^s saturating to +/-INT64_MAX, s in [0, 62] */
EST_INLINE int64_t est_shl64c(int64_t v, unsigned s) { return qa_shl64(v, s); }

/* q_sat32(q_shr64(v, s)), s in [0, 62] */
EST_INLINE int32_t est_sat_shr64c(int64_t v, unsigned s)
{
	int64_t q = est_shr64c(v, s);
	return q > (int64_t)INT32_MAX ? INT32_MAX : (q < -(int64_t)INT32_MAX ? -INT32_MAX : (int32_t)q);
}

/* q_mul64_32(a, b, s): a b / 2^s for int64 a, int32 b, s in [1, 62] (its two products are
 * q_umul32 calls; the shift after them is inlined) */
EST_INLINE int64_t est_mul64_32c(int64_t a, int32_t b, unsigned s)
{
	bool neg = (a < 0) != (b < 0);
	uint64_t ua = a < 0 ? (uint64_t)0 - (uint64_t)a : (uint64_t)a;
	uint32_t ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	uint64_t hi = est_umul32((uint32_t)(ua >> 32), ub);
	uint64_t lo = est_umul32((uint32_t)ua, ub) >> 32;
	int64_t sum = (int64_t)(hi + lo);
	sum = neg ? -sum : sum;
	return s >= 32u ? est_shr64c(sum, s - 32u) : est_shl64c(sum, 32u - s);
}

/* q_shr64(q_smul32(a, b), s) for |a|, |b| < 2^31 and s in [1, 62]: a b / 2^s rounded to
 * nearest (ties away from zero). On Cortex-M0 (no long multiply, no 64-bit shift) in 32-bit
 * words, elsewhere one 64-bit product (motor_id's and imu_id's per-frame products) */
EST_INLINE int64_t est_mul_rnd(int32_t a, int32_t b, unsigned s)
{
	bool neg = (a < 0) != (b < 0);
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a, ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	uint64_t r;
#if defined(__ARM_ARCH_6M__)
	uint32_t al = ua & 0xffffu, ah = ua >> 16, bl = ub & 0xffffu, bh = ub >> 16;
	uint32_t ll = al * bl, lh = al * bh, hl = ah * bl, hh = ah * bh;
	uint32_t mid = (ll >> 16) + (lh & 0xffffu) + (hl & 0xffffu);
	uint32_t hi = hh + (lh >> 16) + (hl >> 16) + (mid >> 16), lo = (mid << 16) | (ll & 0xffffu);
	if (s >= 32u) { /* |a b| < 2^62: hi < 2^30, the sum below 2^31 */
		hi += s > 32u ? 1u << (s - 33u) : (lo >> 31);
		r = hi >> (s - 32u);
	} else {
		uint32_t l2 = lo + (1u << (s - 1u));
		hi += l2 < lo;
		r = ((uint64_t)(hi >> s) << 32) | (uint32_t)((hi << (32u - s)) | (l2 >> s));
	}
#else
	r = ((uint64_t)ua * ub + ((uint64_t)1 << (s - 1u))) >> s; /* |a b| < 2^62 */
#endif
	return neg ? -(int64_t)r : (int64_t)r;
}

/* v 2^s for s in [0, 30], saturating to +/-INT32_MAX (est_scale32's left shifts), always
 * inlined: for a constant s, a comparison and a shift (the per-frame conversions of
 * throttles into motor_id's Q1.30) */
EST_INLINE int32_t est_shl32c(int32_t v, unsigned s)
{
	int32_t lim = INT32_MAX >> s;
	if (v > lim)
		return INT32_MAX;
	if (v < -lim)
		return -INT32_MAX;
	return v >= 0 ? (int32_t)((uint32_t)v << s) : -(int32_t)((uint32_t)-v << s);
}

/* q_scale32(v, s) in 32-bit words: v 2^s, left shifts saturating to +/-INT32_MAX, right
 * shifts rounded to nearest (ties away from zero), INT32_MIN taken as -2^31; any s */
static inline int32_t est_scale32(int32_t v, int s)
{
	if (s >= 0) {
		if (s > 30)
			return v > 0 ? INT32_MAX : (v < 0 ? -INT32_MAX : 0);
		return est_shl32c(v, (unsigned)s);
	}
	unsigned r = (unsigned)-s;
	uint32_t m = v < 0 ? 0u - (uint32_t)v : (uint32_t)v; /* |v| <= 2^31 */
	uint32_t q;
	if (r > 32u)
		q = 0u;
	else if (r == 32u)
		q = m >> 31; /* 1 only for |v| = 2^31: exactly half, rounded away from zero */
	else
		q = (m >> r) + ((m >> (r - 1u)) & 1u); /* at most 2^30 + 1 */
	return v < 0 ? -(int32_t)q : (int32_t)q;
}

/* q_scale64(v, s): v 2^s, left shifts saturating to +/-INT64_MAX, right shifts rounded to
 * nearest (ties away from zero), INT64_MIN taken as -INT64_MAX; any s. Its shifts by the
 * variable count are done on the two 32-bit halves (a 64-bit one is a library call on
 * Cortex-M0, two of them in q_shr64). */
static inline int64_t est_scale64(int64_t v, int s)
{
	if (s > 62)
		return v > 0 ? INT64_MAX : (v < 0 ? -INT64_MAX : 0);
	if (s < -62)
		return 0;
	bool neg = v < 0;
	uint64_t m = neg ? (v == INT64_MIN ? (uint64_t)INT64_MAX : (uint64_t)0 - (uint64_t)v) : (uint64_t)v;
	uint32_t hi = (uint32_t)(m >> 32), lo = (uint32_t)m;
	uint64_t r;
	if (s >= 0) {
		unsigned t = (unsigned)s;
		/* m 2^t fits below 2^63 when m < 2^(63 - t) */
		bool over = t <= 31u ? (hi >> (31u - t)) != 0u : (hi != 0u || (lo >> (63u - t)) != 0u);
		if (over)
			return neg ? -INT64_MAX : INT64_MAX;
		if (t == 0u)
			r = m;
		else if (t >= 32u)
			r = (uint64_t)(lo << (t - 32u)) << 32;
		else
			r = ((uint64_t)((hi << t) | (lo >> (32u - t))) << 32) | (uint32_t)(lo << t);
	} else {
		unsigned t = (unsigned)-s - 1u; /* m / 2^(t + 1), rounded: (m 2^-t + 1) / 2 */
		uint64_t q;
		if (t == 0u)
			q = m;
		else if (t >= 32u)
			q = hi >> (t - 32u);
		else
			q = ((uint64_t)(hi >> t) << 32) | ((lo >> t) | (hi << (32u - t)));
		r = (q + 1u) >> 1;
	}
	return neg ? -(int64_t)r : (int64_t)r;
}

/* q_mul64_32(a, b, s) for a variable s in [1, 62]: its two products, then est_scale64 (the
 * signed sum of the products stays below 2^63 in magnitude: est_scale64 and q_mul64_32's
 * q_shr64 / q_shl64 agree on it) */
static inline int64_t est_mul64_32(int64_t a, int32_t b, unsigned s)
{
	bool neg = (a < 0) != (b < 0);
	uint64_t ua = a < 0 ? (uint64_t)0 - (uint64_t)a : (uint64_t)a;
	uint32_t ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	uint64_t hi = est_umul32((uint32_t)(ua >> 32), ub);
	uint64_t lo = est_umul32((uint32_t)ua, ub) >> 32;
	int64_t sum = (int64_t)(hi + lo);
	return est_scale64(neg ? -sum : sum, 32 - (int)s);
}

/* q_recip(x, e): 1 / x = y 2^-e for x > 0 (0 otherwise), its Newton iteration with the
 * products and shifts above */
static inline uint32_t est_recip(int64_t x, int *e)
{
	*e = 0;
	if (x <= 0)
		return 0;
	int s = est_clz64((uint64_t)x);
	uint32_t v = est_top32((uint64_t)x, s);                                  /* Q32, [0.5, 1) */
	uint32_t y = 3031741621u - (uint32_t)(est_umul32(2021161081u, v) >> 32); /* Q30 */
	for (int i = 0; i < 3; i++) {
		uint32_t t = (uint32_t)(est_umul32(v, y) >> 32);
		y = (uint32_t)((est_umul32(y, 0x80000000u - t) + ((uint64_t)1 << 29)) >> 30);
	}
	*e = 94 - s;
	return y;
}

/* q30_mul_recip(a, y, eb, sh): a / b = r 2^-sh from the reciprocal of b, the same way */
static inline int32_t est30_mul_recip(int64_t a, uint32_t y, int eb, int *sh)
{
	*sh = 0;
	if (a == 0 || y == 0u)
		return 0;
	uint64_t ua = a < 0 ? (uint64_t)0 - (uint64_t)a : (uint64_t)a;
	int sa = est_clz64(ua);
	uint64_t p = est_umul32(est_top32(ua, sa), y);
	uint64_t rr = (p + ((uint64_t)1 << 31)) >> 32;
	int32_t r = rr > (uint64_t)INT32_MAX ? INT32_MAX : (int32_t)rr;
	*sh = sa + eb - 94;
	return a < 0 ? -r : r;
}

/* sc_mul(a, u), bit for bit, for any a and u; cheapest for u in [0, 1] (raw u <= 2^16 in the
 * fixed build), where |a| = ah 2^16 + al (ah <= 2^15, al < 2^16) gives
 * |a| u / 2^16 = ah u + al u / 2^16 with ah u <= 2^31 and al u + 2^15 < 2^32: the product
 * rounded to nearest (ties away from zero, as sc_mul) in 32-bit words, at most |a| (only
 * a = INT32_MIN, u = 1 saturates). Other u: sc_mul. Float build: sc_mul. */
static inline scalar_t est_mul_unit(scalar_t a, scalar_t u)
{
#if OCTO_FIXED
	if ((uint32_t)u > 65536u)
		return sc_mul(a, u);
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a, uu = (uint32_t)u;
	uint32_t r = (ua >> 16) * uu + (((ua & 0xffffu) * uu + 0x8000u) >> 16);
	if (r > (uint32_t)INT32_MAX)
		return SC_MAX_NEG;
	return a < 0 ? -(scalar_t)r : (scalar_t)r;
#else
	return sc_mul(a, u);
#endif
}

/* sc_div_int(a, n) for a constant n, bit for bit: floor((|a| + floor(n / 2)) / n) with a's
 * sign. For n = 3 and n = 100 the quotient of the (at most 2^31 + 50) dividend is its product
 * with a 32-bit reciprocal, the high word shifted (0xAAAAAAAB / 2^33, 0x51EB851F / 2^37:
 * exact for every 32-bit dividend), in place of a library division on Cortex-M0; other n:
 * sc_div_int. Float build: sc_div_int. */
EST_INLINE scalar_t est_div_int(scalar_t a, uint32_t n)
{
#if OCTO_FIXED
	if (n != 3u && n != 100u)
		return sc_div_int(a, n);
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a;
	uint64_t p = est_umul32(ua + n / 2u, n == 3u ? 0xAAAAAAABu : 0x51EB851Fu);
	uint32_t q = (uint32_t)(p >> 32) >> (n == 3u ? 1 : 5);
	return a < 0 ? -(scalar_t)q : (scalar_t)q;
#else
	return sc_div_int(a, n);
#endif
}

/* sc_div(a, b), bit for bit, for any a, b and guess q0; cheapest for a >= 0, b > 0 and q0
 * within a few units of the quotient. sc_div's quotient of such operands is the largest q with
 * q b <= x = a 2^16 + floor(b / 2) (rounded to nearest, ties up), or SC_MAX from 2^31 on: q0
 * is corrected by the remainder x - q0 b (below 2^63 in magnitude: x < 2^48, q0 b < 2^62) by
 * at most EST_DIV_STEPS units; a guess farther off, or a quotient beyond the format, is left to
 * sc_div. Float build: sc_div. */
#define EST_DIV_STEPS 8
static inline scalar_t est_div_near(scalar_t a, scalar_t b, scalar_t q0)
{
#if OCTO_FIXED
	if (a < 0 || b <= 0 || q0 < 0)
		return sc_div(a, b);
	int64_t x = ((int64_t)a << 16) + (b >> 1);
	uint32_t q = (uint32_t)q0;
	int64_t r = x - (int64_t)est_umul32(q, (uint32_t)b);
	for (int i = 0; i < EST_DIV_STEPS && r < 0; i++) {
		q--;
		r += b;
	}
	for (int i = 0; i < EST_DIV_STEPS && r >= b; i++) {
		q++;
		r -= b;
	}
	if (r < 0 || r >= b || q > (uint32_t)INT32_MAX)
		return sc_div(a, b);
	return (scalar_t)q;
#else
	(void)q0;
	return sc_div(a, b);
#endif
}

/* sc_sqrt(a), bit for bit, for any a and guess g; cheapest for g within a few units of the
 * root. sc_sqrt's root of a > 0 is the R with R^2 - R < N <= R^2 + R, N = a 2^16 (the root
 * of N rounded to nearest): g is corrected by D = N - g^2 (N < 2^47, g^2 < 2^62) by at most
 * EST_DIV_STEPS units, else sc_sqrt. Float build: sc_sqrt. */
static inline scalar_t est_sqrt_near(scalar_t a, scalar_t g)
{
#if OCTO_FIXED
	if (a <= 0 || g <= 0)
		return sc_sqrt(a);
	uint32_t r = (uint32_t)g;
	int64_t d = ((int64_t)a << 16) - (int64_t)est_umul32(r, r);
	for (int i = 0; i < EST_DIV_STEPS && d > (int64_t)r; i++) {
		d -= 2 * (int64_t)r + 1;
		r++;
	}
	for (int i = 0; i < EST_DIV_STEPS && d <= -(int64_t)r; i++) {
		r--;
		d += 2 * (int64_t)r + 1;
	}
	if (d > (int64_t)r || d <= -(int64_t)r)
		return sc_sqrt(a);
	return (scalar_t)r;
#else
	(void)g;
	return sc_sqrt(a);
#endif
}

#endif /* OCTO_EST_OPS_H */
