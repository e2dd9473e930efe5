/*
 * fcmp.h - comparisons of floats and doubles by integer operations, for the per-frame
 * checks of the 90 Hz step, and the frame's plant-time step (app_t_gap). On a core without
 * FPU (Cortex-M0) every float comparison is a library call (two for a <= or >= of doubles);
 * here a few integer operations.
 * Each gives the IEEE answer for every pair: false when either operand is NaN, -0 equal
 * to +0. On cores with a single-precision FPU (and on the host) the float comparisons are
 * the compiler's own; the double one is always by integers (the M4F's FPU has no doubles).
 * The _bits forms are the integer ones on every target (the unit tests check them there).
 */
#ifndef OCTO_APP_FCMP_H
#define OCTO_APP_FCMP_H

#include <stdbool.h>
#include <stdint.h>

#include "qfmt.h"

/* a < b for plant times (doubles): sign and magnitude to a signed order, -m for negatives
 * (both zeros are 0) */
static inline bool app_t_before(double a, double b)
{
	union {
		double d;
		uint64_t u;
	} x = {a}, y = {b};
	const uint64_t mag = 0x7fffffffffffffffu, inf = 0x7ff0000000000000u;
	uint64_t ma = x.u & mag, mb = y.u & mag;
	if (ma > inf || mb > inf)
		return false;
	int64_t ka = (x.u >> 63) ? -(int64_t)ma : (int64_t)ma, kb = (y.u >> 63) ? -(int64_t)mb : (int64_t)mb;
	return ka < kb;
}

/* a float's bits in the same signed order; NaN is told apart by app_f_nan */
static inline int32_t app_f_key(float a)
{
	union {
		float f;
		uint32_t u;
	} x = {a};
	int32_t m = (int32_t)(x.u & 0x7fffffffu);
	return (x.u >> 31) ? -m : m;
}

static inline bool app_f_nan2(float a, float b)
{
	union {
		float f;
		uint32_t u;
	} x = {a}, y = {b};
	return (x.u & 0x7fffffffu) > 0x7f800000u || (y.u & 0x7fffffffu) > 0x7f800000u;
}

static inline bool app_f_lt_bits(float a, float b) { return !app_f_nan2(a, b) && app_f_key(a) < app_f_key(b); }
static inline bool app_f_le_bits(float a, float b) { return !app_f_nan2(a, b) && app_f_key(a) <= app_f_key(b); }
static inline bool app_f_eq_bits(float a, float b) { return !app_f_nan2(a, b) && app_f_key(a) == app_f_key(b); }

#if defined(__ARM_ARCH) && !defined(__ARM_FP)
static inline bool app_f_lt(float a, float b) { return app_f_lt_bits(a, b); }
static inline bool app_f_le(float a, float b) { return app_f_le_bits(a, b); }
static inline bool app_f_eq(float a, float b) { return app_f_eq_bits(a, b); }
#else
static inline bool app_f_lt(float a, float b) { return a < b; }
static inline bool app_f_le(float a, float b) { return a <= b; }
static inline bool app_f_eq(float a, float b) { return a == b; }
#endif

/* (float)(t - t_prev) for plant times: the same value bit for bit, by integer operations
 * in the common case, instead of a double subtraction and a conversion (two library calls
 * on a core without a double-precision FPU).
 * Common case: both normal and positive, t > t_prev, exponents equal or one apart, and a
 * difference of at most 53 bits: the double subtraction is then exact, and the one rounding
 * is the conversion's (to nearest, ties to even), done here on the difference of the
 * mantissas. Every other case (and a result outside float's normal range) takes the double
 * expression itself. */
static inline float app_t_gap(double t, double t_prev)
{
	union {
		double d;
		uint64_t u;
	} x = {t}, y = {t_prev};
	/* exponent fields with the sign bit above them: a negative operand is out of range */
	uint32_t ea = (uint32_t)(x.u >> 52), eb = (uint32_t)(y.u >> 52), de = ea - eb;
	if (eb == 0u || ea >= 0x7ffu || de > 1u || x.u <= y.u)
		return (float)(t - t_prev);
	const uint64_t frac = (1ull << 52) - 1u, one = 1ull << 52;
	uint64_t ma = (x.u & frac) | one, mb = (y.u & frac) | one;
	uint64_t diff = (de ? ma << 1 : ma) - mb; /* > 0; t - t_prev = diff 2^(eb - 1075) */
	if (diff >> 53)
		return (float)(t - t_prev);
	uint32_t hi = (uint32_t)(diff >> 32), lo = (uint32_t)diff, q, r;
	int n; /* diff in [2^(n - 1), 2^n) */
	if (hi) {
		n = 64 - q_clz32(hi); /* 33 .. 53: 9 .. 29 bits dropped, all of lo's */
		int sh = n - 24;
		q = (hi << (32 - sh)) | (lo >> sh);
		r = lo << (32 - sh); /* the dropped bits, at the top */
	} else if ((n = 32 - q_clz32(lo)) > 24) {
		int sh = n - 24;
		q = lo >> sh;
		r = lo << (32 - sh);
	} else {
		q = lo << (24 - n);
		r = 0u;
	}
	if (r > 0x80000000u || (r == 0x80000000u && (q & 1u))) {
		q++;
		if (q >> 24) { /* rounded up to the next power of two */
			q >>= 1;
			n++;
		}
	}
	int fe = n + (int)eb - 949; /* biased float exponent: (n - 1) + (eb - 1075) + 127 */
	if (fe < 1 || fe > 254)
		return (float)(t - t_prev);
	union {
		uint32_t u;
		float f;
	} v = {((uint32_t)fe << 23) | (q & 0x7fffffu)};
	return v.f;
}

#endif /* OCTO_APP_FCMP_H */
