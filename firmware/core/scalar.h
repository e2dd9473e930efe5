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
 *   - sc_sqrt of a negative number is 0; the result is the root rounded to nearest.
 *   - sc_from_float/sc_to_float assemble the IEEE bits with integer operations (no
 *     soft-float call on a core without FPU); sc_to_float gives (float)a / 65536 exactly.
 *   - Trigonometry is integer in the fixed build: sc_sin, sc_cos (the attitude set point,
 *     at 90 Hz), sc_atan2, sc_asin (Euler angles for telemetry and commands), each within
 *     0.6 LSB of the exact value.
 *     sc_exp is integer in the fixed build (lag coefficients are recomputed in the 90 Hz
 *     path when the frame period changes). The hot path (control, mixer, throttle map,
 *     estimators) uses only integer operations.
 *
 * Constants: SC(x) turns a literal into a scalar at compile time, e.g. SC(0.5).
 * Values entering the core from the outside (parameters, sensor frames) go
 * through sc_from_float; values leaving it through sc_to_float.
 *
 * The float build wraps <math.h> here and nowhere else in the core: this file
 * is the only libc the core uses besides <stdint.h>, <stdbool.h>, <stddef.h>.
 * Other fixed-point formats and their integer helpers: qfmt.h.
 *
 * Linkage in the fixed build: the non-trivial primitives (sc_from_float, sc_to_float,
 * sc_add, sc_sub, sc_mul, sc_recip_norm, sc_div_prepared) are inline definitions with
 * external linkage and sc_div a plain function, each with its one out-of-line copy in
 * scalar.c: an object that does not inline one calls that copy (no static copy per object).
 * sca_add and sca_sub are sc_add and sc_sub always inlined, for the few sums of the 90 Hz
 * step's loops where the call costs more than the flash its inline copy takes.
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

/* for the few primitives whose call costs more than their body (GCC and Clang; other
 * compilers inline as they see fit) */
#if defined(__GNUC__)
#define SC_ALWAYS_INLINE __attribute__((always_inline))
#else
#define SC_ALWAYS_INLINE
#endif
/* an external inline definition (C11 6.7.4) that is always inlined: usable from the external
 * inline definitions below, which may not call a static function; scalar.c keeps an
 * out-of-line copy for compilers without always_inline */
#define SC_ALWAYS_INLINE_EXT inline SC_ALWAYS_INLINE

#if OCTO_FIXED
/* ------------------------------------------------------------ Q16.16 */
typedef int32_t scalar_t;

#define SC_FRAC 16
#define SC_SOFT_FLOAT 0
#define SC_ONE ((scalar_t)65536)
#define SC_MAX ((scalar_t)INT32_MAX)
#define SC_MAX_NEG ((scalar_t)(-INT32_MAX))
#define SC_EPS ((scalar_t)1)
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

/* Conversions to and from IEEE binary32 by integer bit assembly: no soft-float routine on a
 * core without FPU. sc_from_float rounds x 2^16 to nearest (ties away from zero). */
inline scalar_t sc_from_float(float x)
{
	union {
		float f;
		uint32_t u;
	} v = {x};
	uint32_t e = (v.u >> 23) & 0xffu, m = (v.u & 0x7fffffu) | 0x800000u;
	bool neg = (v.u >> 31) != 0u;
	if (e == 0xffu && (v.u & 0x7fffffu))
		return 0; /* NaN */
	if (e >= 142u)    /* |x| >= 2^15, and infinities */
		return neg ? SC_MAX_NEG : SC_MAX;
	if (e < 109u) /* |x| < 2^-18 (and subnormals): 0 */
		return 0;
	/* |x| 2^16 = m 2^(e - 134) */
	uint32_t r = e >= 134u ? m << (e - 134u) : (m + (1u << (133u - e))) >> (134u - e);
	return neg ? -(scalar_t)r : (scalar_t)r;
}

/* a 2^-16 as float, rounded to nearest even: the same value as (float)a / 65536 */
inline float sc_to_float(scalar_t a)
{
	union {
		float f;
		uint32_t u;
	} v = {0.0f};
	if (a == 0)
		return 0.0f;
	uint32_t m = a < 0 ? 0u - (uint32_t)a : (uint32_t)a;
	uint32_t e = 31u - (uint32_t)q_clz32(m); /* m in [2^e, 2^(e + 1)) */
	if (e > 23u) {
		uint32_t sh = e - 23u, rem = m & ((1u << sh) - 1u), half = 1u << (sh - 1u);
		m >>= sh;
		if (rem > half || (rem == half && (m & 1u)))
			m++;
		if (m >> 24) { /* rounded up to the next power of 2 */
			m >>= 1;
			e++;
		}
	} else {
		m <<= 23u - e;
	}
	/* |a| 2^-16 = (m 2^-23) 2^(e - 16): biased exponent e - 16 + 127 */
	v.u = (a < 0 ? 0x80000000u : 0u) | ((e + 111u) << 23) | (m & 0x7fffffu);
	return v.f;
}
static inline scalar_t sc_from_int(int32_t i) { return sc_sat64((int64_t)i * 65536); }

/* saturating sums in 32-bit words (no 64-bit arithmetic on Cortex-M0): the wrapped sum,
 * then overflow (operands of one sign, a result of the other) saturates by the operands'
 * sign, and INT32_MIN (outside the range; the one r with r << 1 == 0 but r != 0, tested so
 * by a shift instead of loading the constant on Cortex-M0) becomes SC_MAX_NEG.
 * sca_add/sca_sub: always inline, for the hottest loops of the 90 Hz step, where a call
 * costs more than the operation (register moves and the call itself on Cortex-M0).
 * sc_add/sc_sub: the same, external inline definitions with their one copy in scalar.c: a
 * compiler optimising for size calls that copy (smaller than a copy per use on Cortex-M0),
 * one optimising for speed inlines them. */
SC_ALWAYS_INLINE_EXT scalar_t sca_add(scalar_t a, scalar_t b)
{
	uint32_t r = (uint32_t)a + (uint32_t)b;
	if ((int32_t)(((uint32_t)a ^ r) & ((uint32_t)b ^ r)) < 0)
		return a < 0 ? SC_MAX_NEG : SC_MAX;
	return (r << 1) == 0u && r != 0u ? SC_MAX_NEG : (scalar_t)r;
}
SC_ALWAYS_INLINE_EXT scalar_t sca_sub(scalar_t a, scalar_t b)
{
	uint32_t r = (uint32_t)a - (uint32_t)b;
	if ((int32_t)(((uint32_t)a ^ (uint32_t)b) & ((uint32_t)a ^ r)) < 0)
		return a < 0 ? SC_MAX_NEG : SC_MAX;
	return (r << 1) == 0u && r != 0u ? SC_MAX_NEG : (scalar_t)r;
}
inline scalar_t sc_add(scalar_t a, scalar_t b) { return sca_add(a, b); }
inline scalar_t sc_sub(scalar_t a, scalar_t b) { return sca_sub(a, b); }
static inline scalar_t sc_neg(scalar_t a) { return a == INT32_MIN ? SC_MAX : -a; }
static inline scalar_t sc_abs(scalar_t a) { return a < 0 ? sc_neg(a) : a; }

/* a b 2^-16 rounded to nearest, ties away from zero, saturating.
 * With a long multiply (Cortex-M3/M4, hosts): the 64-bit product.
 * Cortex-M0 has none (a 64-bit product is a library call there): |a b| 2^-16 rounded from
 * 16 x 16 products in 32-bit words, the sign applied last as (m ^ s) - s (s all ones for a
 * negative product; SC_MAX signed so is SC_MAX_NEG).
 *   - |b| < 1 (the common case: gains, time steps, unit quaternions' components), or |a| < 1
 *     with the operands' roles swapped: |a| = ah 2^16 + al gives
 *     round(|a b| / 2^16) = ah |b| + floor((al |b| + 2^15) / 2^16) exactly, at most
 *     (2^15 - 1)(2^16 - 1) + 2^16 < 2^31 (2^15 |b| for |a| = 2^31): two products, no
 *     saturation. floor((x + 2^15) / 2^16) = (floor(x / 2^15) + 1) / 2: no constant to load.
 *   - both >= 1: |a b| = hh 2^32 + (lh + hl) 2^16 + ll, so that
 *     round(|a b| / 2^16) = hh 2^16 + lh + hl + floor((ll + 2^15) / 2^16) exactly; each carry
 *     out of 32 bits, and a sum beyond INT32_MAX, saturates. */
inline scalar_t sc_mul(scalar_t a, scalar_t b)
{
#if !defined(__ARM_ARCH_6M__)
	int64_t p = (int64_t)a * b; /* |p| <= 2^62 */
	int64_t r = p >= 0 ? (p + 32768) >> 16 : -((32768 - p) >> 16);
	return r > INT32_MAX ? SC_MAX : (r < -INT32_MAX ? SC_MAX_NEG : (scalar_t)r);
#else
	uint32_t s = 0u - (((uint32_t)a ^ (uint32_t)b) >> 31);
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a, ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	uint32_t r;
	/* the two short cases written alike, each with the operands where they are: no moves */
	if (!(ub >> 16)) {
		r = (ua >> 16) * ub + (((((ua & 0xffffu) * ub) >> 15) + 1u) >> 1);
	} else if (!(ua >> 16)) {
		r = (ub >> 16) * ua + (((((ub & 0xffffu) * ua) >> 15) + 1u) >> 1);
	} else {
		uint32_t al = ua & 0xffffu, ah = ua >> 16, bl = ub & 0xffffu, bh = ub >> 16;
		uint32_t hh = ah * bh, lh = al * bh;
		r = ah * bl + ((al * bl + 0x8000u) >> 16); /* < 2^31 + 2^16: no carry */
		if (hh >= 0x8000u)
			r = (uint32_t)INT32_MAX;
		else if ((r += hh << 16) < (hh << 16) || (r += lh) < lh || r > (uint32_t)INT32_MAX)
			r = (uint32_t)INT32_MAX;
	}
	return (scalar_t)((r ^ s) - s);
#endif
}

/* 2^63 / v for v in [2^31, 2^32), within 2^-27 relative (at most 2^32 - 1): two Newton
 * steps y <- y (2 - v y) in 16-bit words from 48/17 - 32/17 v, then one on 2^47 - v y */
inline uint32_t sc_recip_norm(uint32_t v)
{
	uint32_t v16 = v >> 16;                       /* Q16, [0.5, 1) */
	uint32_t y = 92521u - ((61681u * v16) >> 16); /* 1 / v in Q15 (error < 1/17) */
	for (int i = 0; i < 2; i++) {
		uint32_t t = v16 * y;             /* v y in Q31, about 2^31 */
		y = (y * ((0u - t) >> 16)) >> 15; /* y (2 - v y), Q15: error < 2^-14 */
	}
	/* v y 2^16 with y <= 2^16 is 2^63 (1 - e): e 2^47 = 2^47 - v y, |e| < 2^-14 */
	uint64_t vy = ((uint64_t)((v >> 16) * y) << 16) + (v & 0xffffu) * y;
	int64_t err = (int64_t)(((uint64_t)1 << 47) - vy); /* |err| < 2^33 */
	uint32_t ue = (uint32_t)((err < 0 ? (uint64_t)0 - (uint64_t)err : (uint64_t)err) >> 18);
	uint32_t c = (y * (ue > 0xffffu ? 0xffffu : ue)) >> 13; /* y 2^16 |e| */
	uint64_t r = ((uint64_t)y << 16);
	r = err < 0 ? r - c : r + c; /* y 2^16 (1 + e) */
	return r > 0xffffffffu ? 0xffffffffu : (uint32_t)r;
}

/* |q| = floor((|a| 2^16 + floor(|b| / 2)) / |b|): round to nearest, ties away from zero,
 * saturating, given ub = |b| and its reciprocal 1 / ub = y 2^(s - 63), s = q_clz32(ub),
 * y = sc_recip_norm(ub << s) (0 when b is 0). The quotient from the reciprocal, made exact
 * by its remainder. sc_div prepares the reciprocal on every call; sc_recip.h keeps it for a
 * divisor that changes rarely. */
inline scalar_t sc_div_prepared(scalar_t a, scalar_t b, uint32_t ub, int s, uint32_t y)
{
	if (ub == 0u)
		return a > 0 ? SC_MAX : (a < 0 ? SC_MAX_NEG : 0);
	bool neg = (a < 0) != (b < 0);
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a;
	uint64_t x = ((uint64_t)ua << 16) + (ub >> 1); /* < 2^48 + 2^31 */
	if ((x >> 31) >= ub)                           /* quotient >= 2^31 */
		return neg ? SC_MAX_NEG : SC_MAX;
	/* x32 = floor(x / 2^k) with 2^k <= |b| < 2^(k + 1): below 2^32 as the quotient is below
	 * 2^31, and dropping x's low k bits lowers the quotient by less than 1 */
	int k = 31 - s;
	uint32_t xh = (uint32_t)(x >> 32), xl = (uint32_t)x;
	uint32_t x32 = k ? (xl >> k) | (xh << (32 - k)) : xl;
	/* x / |b| = x32 2^k y 2^(s - 63) = x32 y 2^-32, within a few units */
	uint32_t q = (uint32_t)(q_umul32(x32, y) >> 32);
	int64_t r = (int64_t)x - (int64_t)q_umul32(q, ub);
	while (r < 0) {
		q--;
		r += ub;
	}
	while (r >= (int64_t)ub) {
		q++;
		r -= ub;
	}
	return neg ? -(scalar_t)q : (scalar_t)q;
}

/* a / b as sc_div_prepared defines it. No 64-bit division (a slow library loop on
 * Cortex-M0): the reciprocal of |b| by sc_recip_norm. Out of line (scalar.c): the compilers
 * kept it a call at every optimisation level. */
scalar_t sc_div(scalar_t a, scalar_t b);

/* sqrt(a 2^16) rounded to nearest, digit by digit in 32-bit words (no 64-bit arithmetic on
 * Cortex-M0); 0 for a <= 0. Out of line (scalar.c): a loop whose call costs little beside
 * it, used by several objects. */
scalar_t sc_sqrt(scalar_t a);

static inline bool sc_isfinite(scalar_t a)
{
	(void)a;
	return true;
}

/* The 64-bit product |a| |b| in two 32-bit words, from 16 x 16 products (as q_umul32 on
 * Cortex-M0), for the trigonometry below: with constant shifts it stays in 32-bit words
 * there, where a 64-bit product and a variable 64-bit shift are library calls. Always
 * inline, as sc_qmul32w: the set point's sine and cosine make 16 of these products in every
 * step, and inline, with their shift a constant, each costs about half as much. */
static inline SC_ALWAYS_INLINE void sc_umul32w(uint32_t a, uint32_t b, uint32_t *hi, uint32_t *lo)
{
	uint32_t al = a & 0xffffu, ah = a >> 16, bl = b & 0xffffu, bh = b >> 16;
	uint32_t ll = al * bl, lh = al * bh, hl = ah * bl;
	uint32_t mid = (ll >> 16) + (lh & 0xffffu) + (hl & 0xffffu);
	*lo = (mid << 16) | (ll & 0xffffu);
	*hi = ah * bh + (lh >> 16) + (hl >> 16) + (mid >> 16);
}

/* q_mul32(a, b, s) (qfmt.h: a b 2^-s rounded to nearest, ties away from zero, saturating to
 * +/-INT32_MAX) bit for bit, for s in [1, 63], in 32-bit words */
static inline SC_ALWAYS_INLINE int32_t sc_qmul32w(int32_t a, int32_t b, unsigned s)
{
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a, ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	uint32_t hi, lo, q, over;
	sc_umul32w(ua, ub, &hi, &lo); /* < 2^62 */
	if (s <= 32u) {               /* + 2^(s - 1), then / 2^s */
		uint32_t add = 1u << (s - 1u);
		lo += add;
		hi += lo < add ? 1u : 0u;
		q = s == 32u ? hi : (lo >> s) | (hi << (32u - s));
		over = s == 32u ? 0u : hi >> s;
	} else {
		hi += 1u << (s - 33u);
		q = hi >> (s - 32u);
		over = 0u;
	}
	if (over || q > (uint32_t)INT32_MAX)
		q = (uint32_t)INT32_MAX;
	return (a < 0) != (b < 0) ? -(int32_t)q : (int32_t)q;
}

/* the product of two Q formats for the trigonometry: q_mul32, in 32-bit words on Cortex-M0 */
#if defined(__ARM_ARCH_6M__)
#define SC_QMUL(a, b, s) sc_qmul32w(a, b, s)
#else
#define SC_QMUL(a, b, s) q_mul32(a, b, s)
#endif

/* sin of a phase p in turns (2^32 = one turn): sin(pi x / 2) on the quadrant's x in [0, 1]
 * (Q30) by an odd degree-7 minimax polynomial (error 6e-7, 0.04 LSB), rounded to Q16.16 */
static inline scalar_t sc_sin_turn(uint32_t p)
{
	uint32_t quad = p >> 30, f = p & 0x3fffffffu;
	if (quad & 1u)
		f = 0x40000000u - f; /* sin(pi/2 (1 - x)) = sin(pi/2 (1 + x)) */
	int32_t x = (int32_t)f, z = SC_QMUL(x, x, 30);
	int32_t r = -4652625; /* coefficients in Q30 */
	r = 85291977 + SC_QMUL(r, z, 30);
	r = -693522166 + SC_QMUL(r, z, 30);
	r = 1686624005 + SC_QMUL(r, z, 30);
	r = SC_QMUL(r, x, 44); /* Q30 x Q30 -> Q16 */
	return quad >= 2u ? -r : r;
}
/* radians to turns: a 2^16 / (2 pi) in units of 2^-32 turn (K = 2^32 / (2 pi), rounded, in
 * Q16), modulo one turn; the phase is within |a| 2^-17 units (2e-5 rad at |a| = 32768).
 * Bits 16 to 47 of the signed product a K: of the unsigned product of a's two's complement
 * word and K, less K 2^32 when a < 0 (the same bits as (uint64_t)q_smul32(a, K) >> 16). */
static inline uint32_t sc_turns(scalar_t a)
{
	uint32_t hi, lo;
	sc_umul32w((uint32_t)a, 683565276u, &hi, &lo);
	if (a < 0)
		hi -= 683565276u;
	return (lo >> 16) | (hi << 16);
}
/* integer in the fixed build (the set point's quat_from_euler_yh runs at 90 Hz): within
 * 0.5 LSB plus 0.04 LSB of the polynomial */
static inline scalar_t sc_sin(scalar_t a) { return sc_sin_turn(sc_turns(a)); }
static inline scalar_t sc_cos(scalar_t a) { return sc_sin_turn(sc_turns(a) + 0x40000000u); }
/* atan(n / d) in Q30 for 0 <= n <= d, 0 < d < 2^63 (one scale): the ratio in Q1.30 by
 * Newton's reciprocal (qfmt.h), then an odd degree-13 minimax polynomial (error 2.5e-7) */
static inline int32_t sc_atan_q30(uint64_t n, uint64_t d)
{
	int32_t t = q30_ratio((int64_t)n, (int64_t)d), z = q_mul32(t, t, 30);
	int32_t r = 7314099; /* coefficients in Q30 */
	r = -36082232 + q_mul32(r, z, 30);
	r = 85495239 + q_mul32(r, z, 30);
	r = -142091914 + q_mul32(r, z, 30);
	r = 212684797 + q_mul32(r, z, 30);
	r = -357742515 + q_mul32(r, z, 30);
	r = 1073737649 + q_mul32(r, z, 30);
	return q_mul32(r, t, 30);
}
/* the angle of (x, y) for magnitudes |x| = ax, |y| = ay of one scale (< 2^63), signs apart:
 * [0, pi/2] in Q30 */
static inline int64_t sc_angle_q30(uint64_t ay, uint64_t ax)
{
	if (ay == 0u)
		return 0;
	if (ay > ax)
		return 1686629713 - (int64_t)sc_atan_q30(ax, ay); /* pi / 2 in Q30 */
	return sc_atan_q30(ay, ax);
}
/* Integer in the fixed build (Euler angles for telemetry and commands): within 0.52 LSB of
 * the exact value (rounding, polynomial, ratio); atan2(0, 0) = 0 */
static inline scalar_t sc_atan2(scalar_t y, scalar_t x)
{
	uint32_t ay = y < 0 ? 0u - (uint32_t)y : (uint32_t)y, ax = x < 0 ? 0u - (uint32_t)x : (uint32_t)x;
	int64_t r = sc_angle_q30(ay, ax);
	if (x < 0)
		r = 3373259426LL - r; /* pi in Q30 */
	return (scalar_t)q_shr64(y < 0 ? -r : r, 30 - SC_FRAC);
}
/* asin(a) = atan2(a, sqrt(1 - a^2)) with 1 - a^2 exact in Q32 and its root in Q30; |a| >= 1
 * gives +/-pi/2; within 0.52 LSB */
static inline scalar_t sc_asin(scalar_t a)
{
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a;
	if (ua >= 65536u)
		return a < 0 ? -102944 : 102944; /* pi / 2, rounded */
	uint64_t v = (((uint64_t)1 << 32) - (uint64_t)ua * ua) << 28, c = 0, bit = (uint64_t)1 << 60;
	while (bit) { /* c = floor(sqrt(v)): sqrt(1 - a^2) in Q30 */
		if (v >= c + bit) {
			v -= c + bit;
			c = (c >> 1) + bit;
		} else {
			c >>= 1;
		}
		bit >>= 2;
	}
	int64_t r = sc_angle_q30((uint64_t)ua << 14, c);
	return (scalar_t)q_shr64(a < 0 ? -r : r, 30 - SC_FRAC);
}
/* e^a in integer arithmetic (filter and lag coefficients): within 0.5 LSB + 1e-9 relative;
 * saturates to SC_MAX above ln(32768) and gives 0 below ln(2^-17). Out of line (scalar.c):
 * work when a time constant or the frame period changes, with 64-bit divisions. */
scalar_t sc_exp(scalar_t a);

#else
/* ------------------------------------------------------------ float32 */
typedef float scalar_t;

/* float in software: an ARM core without FPU (Cortex-M0), where every operation and every
 * comparison is a library call */
#if defined(__arm__) && !defined(__ARM_FP)
#define SC_SOFT_FLOAT 1
#else
#define SC_SOFT_FLOAT 0
#endif

#define SC_MAX 3.0e38f
#define SC_MAX_NEG (-3.0e38f)
#define SC_EPS 1.1920929e-7f
#define SC(x) ((scalar_t)(x))

static inline scalar_t sc_from_float(float x) { return x; }
static inline float sc_to_float(scalar_t a) { return a; }
static inline scalar_t sc_from_int(int32_t i) { return (scalar_t)i; }

static inline scalar_t sc_add(scalar_t a, scalar_t b) { return a + b; }
static inline scalar_t sc_sub(scalar_t a, scalar_t b) { return a - b; }
static inline scalar_t sca_add(scalar_t a, scalar_t b) { return a + b; }
static inline scalar_t sca_sub(scalar_t a, scalar_t b) { return a - b; }
static inline scalar_t sc_neg(scalar_t a) { return -a; }
static inline scalar_t sc_abs(scalar_t a) { return fabsf(a); }
static inline scalar_t sc_mul(scalar_t a, scalar_t b) { return a * b; }
/* a / b; division by zero saturates like the fixed build instead of giving Inf/NaN. Out of
 * line where float is soft (scalar.c): the test and the soft-float call are not worth a copy
 * per object; inline where the division is an instruction (the test and it cost less than a
 * call). */
#if SC_SOFT_FLOAT
scalar_t sc_div(scalar_t a, scalar_t b);
#else
static inline scalar_t sc_div(scalar_t a, scalar_t b)
{
	if (b == 0.0f)
		return a > 0.0f ? SC_MAX : (a < 0.0f ? SC_MAX_NEG : 0.0f);
	return a / b;
}
#endif
/* sqrt(a) for a > 0, else 0 (NaN included). Out of line where float is soft (scalar.c):
 * there the test and the call to sqrtf are not worth a copy per use; inline where the root
 * is an instruction. */
#if SC_SOFT_FLOAT
scalar_t sc_sqrt(scalar_t a);
#else
static inline scalar_t sc_sqrt(scalar_t a) { return a > 0.0f ? sqrtf(a) : 0.0f; }
#endif
/* isfinite(a) from the exponent bits (all ones: infinity or NaN): one test of a word, not
 * the two soft-float comparisons (unordered, greater than FLT_MAX) a core without FPU makes
 * of isfinite */
static inline bool sc_isfinite(scalar_t a)
{
	union {
		float f;
		uint32_t u;
	} v = {a};
	return (v.u & 0x7f800000u) != 0x7f800000u;
}

static inline scalar_t sc_sin(scalar_t a) { return sinf(a); }
static inline scalar_t sc_cos(scalar_t a) { return cosf(a); }
static inline scalar_t sc_asin(scalar_t a) { return asinf(a); }
static inline scalar_t sc_atan2(scalar_t y, scalar_t x) { return atan2f(y, x); }
/* e^a, off the hot path only (filter and forgetting coefficients at init) */
static inline scalar_t sc_exp(scalar_t a) { return expf(a); }
#endif

/* ------------------------------------------------------------ both builds */
#define SC_ZERO SC(0)

/* SC_HOT_UNROLL before a loop of the 90 Hz step over rotors or axes (a constant count)
 * unrolls it where float is an instruction (an FPU, the host): there the loop's counting
 * and addressing cost as much as its arithmetic. The fixed and soft-float builds keep such
 * loops rolled (flash). */
#if !OCTO_FIXED && !SC_SOFT_FLOAT
#define SC_HARD_FLOAT 1 /* float is an instruction */
#else
#define SC_HARD_FLOAT 0
#endif
#if SC_HARD_FLOAT && defined(__GNUC__)
#define SC_HOT_UNROLL _Pragma("GCC unroll 8")
#else
#define SC_HOT_UNROLL
#endif
/* SC_HOT_INLINE: a helper of such a loop, inlined into every copy where it is unrolled */
#if SC_HARD_FLOAT
#define SC_HOT_INLINE static inline SC_ALWAYS_INLINE
#else
#define SC_HOT_INLINE static
#endif

/* 2^s as float, exact, from its exponent bits (no loop, no libm): s clamped to [-126, 127] */
static inline float sc_pow2f(int s)
{
	union {
		uint32_t u;
		float f;
	} v;
	s = s < -126 ? -126 : (s > 127 ? 127 : s);
	v.u = (uint32_t)(s + 127) << 23;
	return v.f;
}

/* float to int32 x 2^frac, rounded to nearest (ties away from zero), saturating to
 * +/-INT32_MAX, NaN to INT32_MAX (no libm): the between-frames work's values into the
 * estimators' Q formats (motor_id_q.h, imu_id_q.h) */
static inline int32_t sc_q_of_float(float x, int frac)
{
	float v = x * sc_pow2f(frac);
	if (!(v < 2147483520.0f)) /* the largest float below 2^31; NaN too */
		return v < 0.0f ? -INT32_MAX : INT32_MAX;
	if (v <= -2147483520.0f)
		return -INT32_MAX;
	return (int32_t)(v >= 0.0f ? v + 0.5f : v - 0.5f);
}

/* Out of line where float is soft (scalar.c): each comparison is a library call, and the
 * call of these costs less flash than their copies and little time beside the comparisons */
#if SC_SOFT_FLOAT
scalar_t sc_min(scalar_t a, scalar_t b);
scalar_t sc_max(scalar_t a, scalar_t b);
scalar_t sc_clamp(scalar_t x, scalar_t lo, scalar_t hi);
#else
static inline scalar_t sc_min(scalar_t a, scalar_t b) { return a < b ? a : b; }
static inline scalar_t sc_max(scalar_t a, scalar_t b) { return a > b ? a : b; }
static inline scalar_t sc_clamp(scalar_t x, scalar_t lo, scalar_t hi) { return x < lo ? lo : (x > hi ? hi : x); }
#endif
/* a * b + c (always inline: a call around sc_mul and sc_add costs a call more) */
static inline SC_ALWAYS_INLINE scalar_t sc_mac(scalar_t a, scalar_t b, scalar_t c) { return sc_add(sc_mul(a, b), c); }
static inline scalar_t sc_sq(scalar_t a) { return sc_mul(a, a); }

#endif /* OCTO_SCALAR_H */
