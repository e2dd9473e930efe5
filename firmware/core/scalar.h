/*
 * scalar.h - the one scalar type of the firmware core.
 *
 * Every core algorithm is written against scalar_t and the sc_* operations below,
 * never against float or int directly, so that the same source builds two ways:
 *
 *   default        scalar_t is float (IEEE-754 binary32).
 *   OCTO_FIXED=1   scalar_t is Q16.16: int32_t with 16 fractional bits
 *                  (range [-32768, 32768), resolution 2^-16 = 1.53e-5).
 *
 * Q16.16 rules (what each operation guarantees):
 *   - sc_add/sc_sub/sc_mul/sc_div saturate to [SC_MAX_NEG, SC_MAX] instead of
 *     wrapping; products and quotients use 64-bit intermediates and round to
 *     nearest (ties away from zero).
 *   - sc_div by zero returns +/-SC_MAX by the sign of the dividend (0/0 = 0).
 *   - sc_from_float saturates, and maps NaN to 0.
 *   - sc_sqrt of a negative number is 0; the result is exact to 1 LSB.
 *   - Trigonometry (sc_sin, sc_cos, sc_atan2, sc_asin) is used only off the 90 Hz hot
 *     path (Euler conversions for setpoints and telemetry); in the fixed build it goes
 *     through float. sc_exp is integer in the fixed build (lag coefficients are
 *     recomputed in the 90 Hz path when the frame period changes). The hot path
 *     (control, mixer, throttle map, estimators) uses only integer operations.
 *
 * Constants: SC(x) turns a literal into a scalar at compile time, e.g. SC(0.5).
 * Values entering the core from the outside (parameters, sensor frames) go
 * through sc_from_float; values leaving it through sc_to_float.
 *
 * The float build wraps <math.h> here and nowhere else in the core: this file
 * is the only libc the core uses besides <stdint.h>, <stdbool.h>, <stddef.h>.
 * Other fixed-point formats and their integer helpers: qfmt.h.
 */
#ifndef OCTO_SCALAR_H
#define OCTO_SCALAR_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>

#include "qfmt.h"

#ifndef OCTO_FIXED
#define OCTO_FIXED 0
#endif

#define SC_PI_F 3.14159265358979323846f

#if OCTO_FIXED
/* ------------------------------------------------------------ Q16.16 */
typedef int32_t scalar_t;

#define SC_FRAC    16
#define SC_ONE     ((scalar_t)65536)
#define SC_MAX     ((scalar_t)INT32_MAX)
#define SC_MAX_NEG ((scalar_t)(-INT32_MAX))
#define SC_EPS     ((scalar_t)1)
/* Literal to Q16.16, rounded to nearest; for compile-time constants in range. */
#define SC(x) ((scalar_t)((x) >= 0 ? (double)(x) * 65536.0 + 0.5 : (double)(x) * 65536.0 - 0.5))

static inline scalar_t sc_sat64(int64_t v)
{
	if (v > (int64_t)INT32_MAX)
		return SC_MAX;
	if (v < -(int64_t)INT32_MAX)
		return SC_MAX_NEG;
	return (scalar_t)v;
}

static inline scalar_t sc_from_float(float x)
{
	if (!(x == x))
		return 0;
	if (x >= 32767.99998f)
		return SC_MAX;
	if (x <= -32767.99998f)
		return SC_MAX_NEG;
	float s = x * 65536.0f;
	return (scalar_t)(s >= 0.0f ? s + 0.5f : s - 0.5f);
}

static inline float sc_to_float(scalar_t a) { return (float)a * (1.0f / 65536.0f); }
static inline scalar_t sc_from_int(int32_t i) { return sc_sat64((int64_t)i * 65536); }

static inline scalar_t sc_add(scalar_t a, scalar_t b) { return sc_sat64((int64_t)a + b); }
static inline scalar_t sc_sub(scalar_t a, scalar_t b) { return sc_sat64((int64_t)a - b); }
static inline scalar_t sc_neg(scalar_t a) { return a == INT32_MIN ? SC_MAX : -a; }
static inline scalar_t sc_abs(scalar_t a) { return a < 0 ? sc_neg(a) : a; }

static inline scalar_t sc_mul(scalar_t a, scalar_t b)
{
	int64_t p = q_smul32(a, b); /* (int64_t)a * b, without a library call on Cortex-M0 */
	p = p >= 0 ? p + (1 << 15) : p - (1 << 15);
	return sc_sat64(p / 65536);
}

static inline scalar_t sc_div(scalar_t a, scalar_t b)
{
	if (b == 0)
		return a > 0 ? SC_MAX : (a < 0 ? SC_MAX_NEG : 0);
	int64_t n = (int64_t)a * 65536;
	int64_t half = (b > 0 ? (int64_t)b : -(int64_t)b) / 2;
	n = ((n >= 0) == (b > 0)) ? n + (b > 0 ? half : -half) : n - (b > 0 ? half : -half);
	return sc_sat64(n / b);
}

static inline scalar_t sc_sqrt(scalar_t a)
{
	if (a <= 0)
		return 0;
	/* integer square root of a * 2^16, bit by bit, then round */
	uint64_t v = (uint64_t)a << 16, r = 0, bit = (uint64_t)1 << 62;
	while (bit > v)
		bit >>= 2;
	while (bit) {
		if (v >= r + bit) {
			v -= r + bit;
			r = (r >> 1) + bit;
		} else {
			r >>= 1;
		}
		bit >>= 2;
	}
	if (v > r)
		r++;
	return (scalar_t)r;
}

static inline bool sc_isfinite(scalar_t a) { (void)a; return true; }

static inline scalar_t sc_sin(scalar_t a) { return sc_from_float(sinf(sc_to_float(a))); }
static inline scalar_t sc_cos(scalar_t a) { return sc_from_float(cosf(sc_to_float(a))); }
static inline scalar_t sc_asin(scalar_t a) { return sc_from_float(asinf(sc_to_float(a))); }
static inline scalar_t sc_atan2(scalar_t y, scalar_t x)
{
	return sc_from_float(atan2f(sc_to_float(y), sc_to_float(x)));
}
/* e^a in integer arithmetic (filter and lag coefficients): a = k ln 2 + r with r in
 * [0, ln 2) in Q32, e^r by its Taylor series in Q30 (13 terms: error < 1e-9 relative), then
 * scaled by 2^k and rounded to Q16.16: within 0.5 LSB + 1e-9 relative; saturates to
 * SC_MAX above ln(32768) and gives 0 below ln(2^-17) */
static inline scalar_t sc_exp(scalar_t a)
{
	if (a >= 681391)        /* 10.3972 = ln(32768) in Q16.16 */
		return SC_MAX;
	if (a <= -794978)       /* -12.1301 = ln(2^-17.5) */
		return 0;
	const int64_t ln2_q32 = 2977044472LL; /* ln 2 * 2^32, rounded */
	int64_t x = (int64_t)a * 65536;       /* Q32 */
	int64_t k = x / ln2_q32;
	if (k * ln2_q32 > x)
		k--;                              /* floor */
	int64_t r = (x - k * ln2_q32) >> 2;   /* Q30, [0, ln 2) */
	int64_t term = (int64_t)1 << 30, sum = term;
	for (int i = 1; i <= 13; i++) {
		term = (term * r >> 30) / i;
		sum += term;
	}
	int sh = 14 - (int)k;                 /* Q30 * 2^k -> Q16 */
	if (sh <= 0)
		return sc_sat64(sum << -sh);
	return sc_sat64((sum + ((int64_t)1 << (sh - 1))) >> sh);
}

#else
/* ------------------------------------------------------------ float32 */
typedef float scalar_t;

#define SC_MAX     3.0e38f
#define SC_MAX_NEG (-3.0e38f)
#define SC_EPS     1.1920929e-7f
#define SC(x) ((scalar_t)(x))

static inline scalar_t sc_from_float(float x) { return x; }
static inline float sc_to_float(scalar_t a) { return a; }
static inline scalar_t sc_from_int(int32_t i) { return (scalar_t)i; }

static inline scalar_t sc_add(scalar_t a, scalar_t b) { return a + b; }
static inline scalar_t sc_sub(scalar_t a, scalar_t b) { return a - b; }
static inline scalar_t sc_neg(scalar_t a) { return -a; }
static inline scalar_t sc_abs(scalar_t a) { return fabsf(a); }
static inline scalar_t sc_mul(scalar_t a, scalar_t b) { return a * b; }
/* Division by zero saturates like the fixed build instead of giving Inf/NaN. */
static inline scalar_t sc_div(scalar_t a, scalar_t b)
{
	if (b == 0.0f)
		return a > 0.0f ? SC_MAX : (a < 0.0f ? SC_MAX_NEG : 0.0f);
	return a / b;
}
static inline scalar_t sc_sqrt(scalar_t a) { return a > 0.0f ? sqrtf(a) : 0.0f; }
static inline bool sc_isfinite(scalar_t a) { return isfinite(a); }

static inline scalar_t sc_sin(scalar_t a) { return sinf(a); }
static inline scalar_t sc_cos(scalar_t a) { return cosf(a); }
static inline scalar_t sc_asin(scalar_t a) { return asinf(a); }
static inline scalar_t sc_atan2(scalar_t y, scalar_t x) { return atan2f(y, x); }
/* e^a, off the hot path only (filter and forgetting coefficients at init) */
static inline scalar_t sc_exp(scalar_t a) { return expf(a); }
#endif

/* ------------------------------------------------------------ both builds */
#define SC_ZERO SC(0)

/* 2^s as float, exact, from its exponent bits (no loop, no libm): s clamped to [-126, 127] */
static inline float sc_pow2f(int s)
{
	union { uint32_t u; float f; } v;
	s = s < -126 ? -126 : (s > 127 ? 127 : s);
	v.u = (uint32_t)(s + 127) << 23;
	return v.f;
}

static inline scalar_t sc_min(scalar_t a, scalar_t b) { return a < b ? a : b; }
static inline scalar_t sc_max(scalar_t a, scalar_t b) { return a > b ? a : b; }
static inline scalar_t sc_clamp(scalar_t x, scalar_t lo, scalar_t hi)
{
	return x < lo ? lo : (x > hi ? hi : x);
}
/* a * b + c */
static inline scalar_t sc_mac(scalar_t a, scalar_t b, scalar_t c) { return sc_add(sc_mul(a, b), c); }
static inline scalar_t sc_sq(scalar_t a) { return sc_mul(a, a); }

#endif /* OCTO_SCALAR_H */
