/*
 * fcmp.h - comparisons of floats and doubles by integer operations, for the per-frame
 * checks of the 90 Hz step. On a core without FPU (Cortex-M0) every float comparison is a
 * library call of some 30 to 40 instructions (two for a <= or >= of doubles); here a few.
 * Each gives the IEEE answer for every pair: false when either operand is NaN, -0 equal
 * to +0. On cores with a single-precision FPU (and on the host) the float comparisons are
 * the compiler's own; the double one is always by integers (the M4F's FPU has no doubles).
 * The _bits forms are the integer ones on every target (the unit tests check them there).
 */
#ifndef OCTO_APP_FCMP_H
#define OCTO_APP_FCMP_H

#include <stdbool.h>
#include <stdint.h>

/* a < b for plant times (doubles): sign and magnitude to a signed order, -m for negatives
 * (both zeros are 0) */
static inline bool app_t_before(double a, double b)
{
	union { double d; uint64_t u; } x = {a}, y = {b};
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
	union { float f; uint32_t u; } x = {a};
	int32_t m = (int32_t)(x.u & 0x7fffffffu);
	return (x.u >> 31) ? -m : m;
}

static inline bool app_f_nan2(float a, float b)
{
	union { float f; uint32_t u; } x = {a}, y = {b};
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

#endif /* OCTO_APP_FCMP_H */
