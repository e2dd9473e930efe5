/*
 * qfmt.h - named fixed-point formats and the saturating integer operations behind them.
 *
 * A value v of format Qm.f is the integer round(v * 2^f) in a signed word of m + f + 1 bits.
 * Every quantity the fixed build keeps in a format other than scalar.h's Q16.16 names its
 * number of fractional bits here, so that a conversion reads "result of source"
 * (q24_of_q16) and a shift is never a bare constant. docs/number-formats.md lists which
 * quantity uses which format, with its range and resolution.
 *
 *   format       frac bits         word     range               resolution
 *   Q16.16       QF_SC_FRAC   16   int32    [-32768, 32768)     1.5e-5   scalar_t (scalar.h)
 *   Q7.24        QF_SIG_FRAC  24   int32    [-128, 128)         6.0e-8   normalised signals
 *   Q1.30        QF_UNIT_FRAC 30   int32    [-2, 2)             9.3e-10  ratios, factors <= 1
 *   Q23.40       QF_ACC_FRAC  40   int64    [-8.4e6, 8.4e6)     9.1e-13  accumulators
 *   Q15.48       QF_PAR_FRAC  48   int64    [-32768, 32768)     3.6e-15  estimates
 *   Q9.54        QF_INN_FRAC  54   int64    [-512, 512)         5.6e-17  innovation terms
 *   Q1.62        QF_WIDE_FRAC 62   int64    [-2, 2)             2.2e-19  wide mantissas
 *
 * Overflow behaviour of every function below (as CMSIS-DSP states for its Q functions):
 * results saturate to the word's range (int32: [-INT32_MAX, INT32_MAX], int64:
 * [-INT64_MAX, INT64_MAX]); nothing wraps. Products and quotients round to nearest, ties
 * away from zero. Division by zero returns the saturated value with the dividend's sign
 * (0/0 = 0). Only integer arithmetic: no float, no libc. The ratios (q30_ratio*) multiply
 * by a reciprocal from Newton's iteration instead of dividing: Cortex-M0 has neither a
 * divider nor a long multiply, and a 64-bit division there is a slow library loop;
 * q_div64 and q_muldiv divide (for work off the 90 Hz path).
 *
 * These functions are compiled in both builds (they are plain integer code); the float
 * build's algorithms do not call them.
 */
#ifndef OCTO_QFMT_H
#define OCTO_QFMT_H

#include <stdbool.h>
#include <stdint.h>

#define QF_SC_FRAC 16   /* Q16.16: scalar_t of the fixed build */
#define QF_SIG_FRAC 24  /* Q7.24: a signal or parameter normalised to about 1 */
#define QF_UNIT_FRAC 30 /* Q1.30: forgetting factors, covariance mantissas, ratios in (0, 2) */
#define QF_ACC_FRAC 40  /* Q23.40 in int64: sums of products of normalised signals */
#define QF_PAR_FRAC 48  /* Q15.48 in int64: estimated parameters, normalised */
#define QF_INN_FRAC 54  /* Q9.54 in int64: innovation terms, precise for tiny ones */
#define QF_WIDE_FRAC 62 /* Q1.62 in int64: mantissas that need more than 31 bits */

#define QF_ONE(frac) ((int64_t)1 << (frac))

/* The non-trivial functions below have external linkage in the fixed build: C11 inline
 * definitions, with their one out-of-line copy in scalar.c, so that an object that does not
 * inline one calls that copy instead of keeping its own. The float build, whose algorithms
 * do not call them, keeps them static. */
#if OCTO_FIXED
#define QF_INLINE inline
#else
#define QF_INLINE static inline
#endif
/* The same operations always inlined (qa_*): one definition each, which the q_* functions
 * wrap and est_ops.h uses for the estimators' hottest calls. Their linkage follows
 * QF_INLINE's (an external inline definition may not use a static function); scalar.c
 * holds out-of-line copies only for compilers without always_inline. */
#if defined(__GNUC__)
#define QF_ALWAYS QF_INLINE __attribute__((always_inline))
#else
#define QF_ALWAYS QF_INLINE
#endif

/* int64 to int32, saturating */
static inline int32_t q_sat32(int64_t v)
{
	if (v > (int64_t)INT32_MAX)
		return INT32_MAX;
	if (v < -(int64_t)INT32_MAX)
		return -INT32_MAX;
	return (int32_t)v;
}

/* a + b in int64, saturating */
QF_INLINE int64_t q_add64(int64_t a, int64_t b)
{
	if (b > 0 && a > INT64_MAX - b)
		return INT64_MAX;
	if (b < 0 && a < -INT64_MAX - b)
		return -INT64_MAX;
	return a + b;
}

/* 32 x 32 -> 64-bit products. Cortex-M0 (ARMv6-M) has no long multiply: a 64-bit product
 * is a library call there, four 16 x 16 products inline are about three times cheaper. */
QF_ALWAYS uint64_t qa_umul32(uint32_t a, uint32_t b)
{
#if defined(__ARM_ARCH_6M__)
	uint32_t al = a & 0xffffu, ah = a >> 16, bl = b & 0xffffu, bh = b >> 16;
	uint32_t ll = al * bl, lh = al * bh, hl = ah * bl, hh = ah * bh;
	uint32_t mid = (ll >> 16) + (lh & 0xffffu) + (hl & 0xffffu);
	return ((uint64_t)(hh + (lh >> 16) + (hl >> 16) + (mid >> 16)) << 32) | ((mid << 16) | (ll & 0xffffu));
#else
	return (uint64_t)a * b;
#endif
}

QF_INLINE uint64_t q_umul32(uint32_t a, uint32_t b) { return qa_umul32(a, b); }

QF_INLINE int64_t q_smul32(int32_t a, int32_t b)
{
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a, ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	uint64_t p = q_umul32(ua, ub); /* < 2^64, and <= 2^62 unless an operand is INT32_MIN */
	if (p > (uint64_t)INT64_MAX)
		return (a < 0) != (b < 0) ? -INT64_MAX : INT64_MAX;
	return (a < 0) != (b < 0) ? -(int64_t)p : (int64_t)p;
}

/* number of leading zero bits of v (32 for 0), by halving: Cortex-M0 has no clz, and
 * this costs less there than libgcc's __clzsi2 */
QF_ALWAYS int qa_clz32(uint32_t v)
{
	if (v == 0u)
		return 32;
	int n = 0;
	if (!(v >> 16)) {
		n += 16;
		v <<= 16;
	}
	if (!(v >> 24)) {
		n += 8;
		v <<= 8;
	}
	if (!(v >> 28)) {
		n += 4;
		v <<= 4;
	}
	if (!(v >> 30)) {
		n += 2;
		v <<= 2;
	}
	if (!(v >> 31)) {
		n += 1;
	}
	return n;
}

QF_INLINE int q_clz32(uint32_t v) { return qa_clz32(v); }

/* number of leading zero bits of v (64 for 0), by halving */
QF_INLINE int q_clz64(uint64_t v)
{
	if (v == 0u)
		return 64;
	int n = 0;
	if (!(v >> 32)) {
		n += 32;
		v <<= 32;
	}
	if (!(v >> 48)) {
		n += 16;
		v <<= 16;
	}
	if (!(v >> 56)) {
		n += 8;
		v <<= 8;
	}
	if (!(v >> 60)) {
		n += 4;
		v <<= 4;
	}
	if (!(v >> 62)) {
		n += 2;
		v <<= 2;
	}
	if (!(v >> 63)) {
		n += 1;
	}
	return n;
}

/* v / 2^s, rounded to nearest (ties away from zero); s in [0, 62] */
QF_ALWAYS int64_t qa_shr64(int64_t v, unsigned s)
{
	if (s == 0u)
		return v;
	/* the bit below the cut decides the rounding: no intermediate can overflow */
	if (v >= 0)
		return (v >> s) + ((v >> (s - 1u)) & 1);
	int64_t m = v == INT64_MIN ? INT64_MAX : -v;
	return -((m >> s) + ((m >> (s - 1u)) & 1));
}

QF_INLINE int64_t q_shr64(int64_t v, unsigned s) { return qa_shr64(v, s); }

/* v * 2^s, saturating; s in [0, 62] */
QF_ALWAYS int64_t qa_shl64(int64_t v, unsigned s)
{
	int64_t lim = INT64_MAX >> s;
	if (v > lim)
		return INT64_MAX;
	if (v < -lim)
		return -INT64_MAX;
	return v >= 0 ? (int64_t)((uint64_t)v << s) : -(int64_t)((uint64_t)-v << s);
}

QF_INLINE int64_t q_shl64(int64_t v, unsigned s) { return qa_shl64(v, s); }

/* v * 2^s for s of either sign: left shifts saturate, right shifts round (beyond 62 bits
 * to 0) */
QF_INLINE int64_t q_scale64(int64_t v, int s)
{
	if (s > 62)
		return v > 0 ? INT64_MAX : (v < 0 ? -INT64_MAX : 0);
	if (s < -62)
		return 0;
	return s >= 0 ? q_shl64(v, (unsigned)s) : q_shr64(v, (unsigned)-s);
}

/* Format conversion of an int32 value by 2^s (s of either sign), saturating */
static inline int32_t q_scale32(int32_t v, int s) { return q_sat32(q_scale64(v, s)); }

/* Named conversions used by the core (result_of_source) */
static inline int32_t q24_of_q16(int32_t v) { return q_scale32(v, QF_SIG_FRAC - QF_SC_FRAC); }
static inline int32_t q16_of_q24(int32_t v) { return q_scale32(v, QF_SC_FRAC - QF_SIG_FRAC); }

/* a * b / 2^frac for int32 a, b (frac in [1, 62]): the product of two values of formats
 * Qx.fa and Qy.fb is returned in format Q.(fa + fb - frac); saturates to int32 */
static inline int32_t q_mul32(int32_t a, int32_t b, unsigned frac) { return q_sat32(q_shr64(q_smul32(a, b), frac)); }

/* a * b / 2^frac with the int64 result (exact for frac = 0; no saturation needed: |a b| < 2^62) */
static inline int64_t q_mul64(int32_t a, int32_t b, unsigned frac) { return q_shr64(q_smul32(a, b), frac); }

/* a * u / 2^30 for int64 a and a Q1.30 factor u: a keeps its format; saturating.
 * Split in two 32 x 32 products so that nothing overflows for any a. */
static inline int64_t q_mul64_q30(int64_t a, int32_t u)
{
	bool neg = (a < 0) != (u < 0);
	uint64_t ua = a < 0 ? (uint64_t)0 - (uint64_t)a : (uint64_t)a;
	uint32_t uu = u < 0 ? 0u - (uint32_t)u : (uint32_t)u;
	uint64_t hi = q_umul32((uint32_t)(ua >> 32), uu); /* a_hi u, < 2^63 */
	uint64_t lo = q_umul32((uint32_t)ua, uu);         /* a_lo u, < 2^64 */
	/* a u / 2^30 = hi 2^2 + lo / 2^30 */
	if (hi >= ((uint64_t)1 << 61))
		return neg ? -INT64_MAX : INT64_MAX;
	uint64_t r = (hi << 2) + ((lo + ((uint64_t)1 << 29)) >> 30);
	if (r > (uint64_t)INT64_MAX)
		return neg ? -INT64_MAX : INT64_MAX;
	return neg ? -(int64_t)r : (int64_t)r;
}

/* a * b / 2^s for int64 a, int32 b, s in [1, 62]: int64, saturating. Two 32 x 32 products
 * (no 128-bit type in C11); the low product's bits below 2^32 are truncated, an error
 * under 1 LSB of the result for s >= 32 and under 2^(32 - s) LSB otherwise. */
QF_INLINE int64_t q_mul64_32(int64_t a, int32_t b, unsigned s)
{
	bool neg = (a < 0) != (b < 0);
	uint64_t ua = a < 0 ? (uint64_t)0 - (uint64_t)a : (uint64_t)a;
	uint32_t ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	uint64_t hi = q_umul32((uint32_t)(ua >> 32), ub); /* < 2^63 */
	uint64_t lo = q_umul32((uint32_t)ua, ub) >> 32;   /* < 2^32 */
	int64_t sum = (int64_t)(hi + lo);                 /* |a b| / 2^32 */
	sum = neg ? -sum : sum;
	return s >= 32u ? q_shr64(sum, s - 32u) : q_shl64(sum, 32u - s);
}

/* n / d for int64 n, d, rounded to nearest; d = 0 gives the saturated value with n's sign */
static inline int64_t q_div64(int64_t n, int64_t d)
{
	if (d == 0)
		return n > 0 ? INT64_MAX : (n < 0 ? -INT64_MAX : 0);
	if (d < 0) {
		n = n == INT64_MIN ? INT64_MAX : -n;
		d = -d;
	}
	int64_t half = d / 2;
	return n >= 0 ? (n > INT64_MAX - half ? INT64_MAX / d : (n + half) / d)
		      : (n < -INT64_MAX + half ? -INT64_MAX / d : (n - half) / d);
}

/* 1 / x = y 2^-e for int64 x > 0: y an integer in (2^30, 2^31] (the mantissa 1 / v in Q30),
 * e through *e. Newton's
 * iteration y <- y (2 - v y) on the mantissa v of x in [0.5, 1), from 48/17 - 32/17 v
 * (error < 1/17), three times: multiplications only (no divider on Cortex-M0), error under
 * 3e-9 relative. x <= 0 gives y = 0. */
static inline uint32_t q_recip(int64_t x, int *e)
{
	*e = 0;
	if (x <= 0)
		return 0;
	int s = q_clz64((uint64_t)x);
	uint32_t v = (uint32_t)(((uint64_t)x << s) >> 32);                     /* Q32, [0.5, 1) */
	uint32_t y = 3031741621u - (uint32_t)(q_umul32(2021161081u, v) >> 32); /* Q30 */
	for (int i = 0; i < 3; i++) {
		uint32_t t = (uint32_t)(q_umul32(v, y) >> 32); /* v y in Q30, ~1 */
		y = (uint32_t)((q_umul32(y, 0x80000000u - t) + ((uint64_t)1 << 29)) >> 30);
	}
	*e = 94 - s; /* x = v 2^(64 - s): 1 / x = (1 / v) 2^(s - 64) = y 2^(s - 94) */
	return y;
}

/* a / b = r 2^-sh given the reciprocal of b (y, eb from q_recip): r in Q1.30 with |r| in
 * [0.5, 2) and 29 or more significant bits; a = 0 or y = 0 give 0 (sh 0) */
static inline int32_t q30_mul_recip(int64_t a, uint32_t y, int eb, int *sh)
{
	*sh = 0;
	if (a == 0 || y == 0u)
		return 0;
	uint64_t ua = a < 0 ? (uint64_t)0 - (uint64_t)a : (uint64_t)a;
	int sa = q_clz64(ua);
	uint32_t a32 = (uint32_t)((ua << sa) >> 32);   /* a = a32 2^(32 - sa) */
	uint64_t p = q_umul32(a32, y);                 /* [2^61, 2^63] */
	uint64_t rr = (p + ((uint64_t)1 << 31)) >> 32; /* [2^29, 2^31]: Q30 in [0.5, 2] */
	int32_t r = rr > (uint64_t)INT32_MAX ? INT32_MAX : (int32_t)rr;
	/* a / b = a32 2^(32 - sa) y 2^-eb = r 2^32 2^(32 - sa - eb) = (r 2^-30) 2^(94 - sa - eb) */
	*sh = sa + eb - 94;
	return a < 0 ? -r : r;
}

/* a / b in Q1.30 for 0 <= a, 0 < b (int64 of one and the same format): the ratio of two
 * values of any size; saturates at 2 - 2^-30 (a >= 2 b); b <= 0 gives 0 for a = 0 and the
 * saturated value otherwise */
static inline int32_t q30_ratio(int64_t a, int64_t b)
{
	if (a <= 0)
		return 0;
	if (b <= 0)
		return INT32_MAX;
	int eb, sh;
	uint32_t y = q_recip(b, &eb);
	int32_t r = q30_mul_recip(a, y, eb, &sh);
	if (sh < -1)
		return INT32_MAX;
	return q_sat32(q_scale64(r, -sh));
}

/* a / b = r 2^-sh for 0 < a, 0 < b: r in Q1.30 with 29 or more significant bits however
 * small a / b is; sh through *sh. For ratios that shrink a quantity kept with an exponent
 * (the RLS covariance): the caller applies sh to the exponent instead of losing the bits.
 * a <= 0 gives 0 (sh 0). */
static inline int32_t q30_ratio_sh(int64_t a, int64_t b, int *sh)
{
	*sh = 0;
	if (a <= 0 || b <= 0)
		return a > 0 ? INT32_MAX : 0;
	int eb;
	uint32_t y = q_recip(b, &eb);
	return q30_mul_recip(a, y, eb, sh);
}

/* a / b = r 2^-sh for int64 a, b (signed): r in Q1.30 with |r| in [0.5, 2) and 29 or more
 * significant bits for any a / b; sh of either sign. a = 0 gives 0 (sh 0); b = 0 gives the
 * saturated value with a's sign (sh 0). */
static inline int32_t q30_ratio_x(int64_t a, int64_t b, int *sh)
{
	*sh = 0;
	if (a == 0)
		return 0;
	if (b == 0)
		return a < 0 ? -INT32_MAX : INT32_MAX;
	int64_t ub = b < 0 ? (b == INT64_MIN ? INT64_MAX : -b) : b;
	int eb;
	uint32_t y = q_recip(ub, &eb);
	int32_t r = q30_mul_recip(a, y, eb, sh);
	return b < 0 ? -r : r;
}

/* a * b / c for int32 a, b and int64 c > 0, scaled by 2^s (s in [0, 31]): the result of
 * (Qa.fa * Qb.fb) / Qc.fc lands in format fa + fb - fc + s; int64, saturating; precision
 * is kept by shifting the product left first and c right only when the product is large */
static inline int64_t q_muldiv(int32_t a, int32_t b, int64_t c, unsigned s)
{
	int64_t p = (int64_t)a * b;
	if (c <= 0)
		return c == 0 ? (p > 0 ? INT64_MAX : (p < 0 ? -INT64_MAX : 0)) : -q_muldiv(a, b, -c, s);
	uint64_t ap = p < 0 ? (uint64_t)0 - (uint64_t)p : (uint64_t)p;
	unsigned ls = s;
	while (ls > 0u && ap >= ((uint64_t)1 << (62u - ls)))
		ls--;
	int64_t n = p * ((int64_t)1 << ls);
	int64_t cc = q_shr64(c, s - ls);
	if (cc == 0)
		return p > 0 ? INT64_MAX : (p < 0 ? -INT64_MAX : 0);
	return q_div64(n, cc);
}

/* ---------------------------------------------------------------- motor_id (motor_id.h)
 * Formats of the joint rotor-model estimator's per-frame part:
 *   Q2.29        QF_MOTN_FRAC 29   int32    [-4, 4)             1.9e-9   thrusts, torques,
 *                residuals normalised by a power of two near the prior k_f
 *   block float  QF_MSUM_FRAC 25   int32    m 2^(e - 25)        2^-29 of the largest sum
 *                of a kind: least-squares, noise and whiteness sums (motor_id.h) */
#define QF_MOTN_FRAC 29 /* Q2.29: motor_id's normalised thrusts, torques and residuals */
#define QF_MSUM_FRAC 25 /* block floating point sums: fractional bits at exponent 0 */

/* ---------------------------------------------------------------- imu_id (imu_id_q.h)
 * Formats of the accelerometer's rotor-model estimator's per-frame part:
 *   Q6.25        QF_IMUX_FRAC 25   int32    [-64, 64)           3.0e-8   regressors, forces
 *                and torques normalised by a power of two near the reference's k_f, k_tau
 *   Q4.27        QF_IMUC_FRAC 27   int32    [-16, 16)           7.5e-9   coefficients
 *   block float  QF_MSUM_FRAC (above): its least-squares sums */
#define QF_IMUX_FRAC 25 /* Q6.25: imu_id's regressors and normalised forces */
#define QF_IMUC_FRAC 27 /* Q4.27: imu_id's coefficients */

/* ---------------------------------------------------------------- sums of products
 * The identification's running sums (ident.c) keep products of two Q16.16 values exactly:
 * Q31.32 in int64 (range +/-2.1e9, resolution 2.3e-10), and the squares of such sums
 * back in Q31.32 through q_mul64_64. */
#define QF_PROD_FRAC 32 /* Q31.32 in int64: products of two Q16.16 values and their sums */

/* a * b / 2^s for int64 a, b and s in [32, 62], rounded to nearest (ties away from zero):
 * int64, saturating (never wraps). The 126-bit product is formed from four 32 x 32
 * products in two 64-bit words (no 128-bit type in C11): exact. */
static inline int64_t q_mul64_64(int64_t a, int64_t b, unsigned s)
{
	bool neg = (a < 0) != (b < 0);
	uint64_t ua = a < 0 ? (uint64_t)0 - (uint64_t)a : (uint64_t)a;
	uint64_t ub = b < 0 ? (uint64_t)0 - (uint64_t)b : (uint64_t)b;
	uint32_t ah = (uint32_t)(ua >> 32), al = (uint32_t)ua, bh = (uint32_t)(ub >> 32), bl = (uint32_t)ub;
	uint64_t hi = q_umul32(ah, bh), lo = q_umul32(al, bl);
	uint64_t mid[2] = {q_umul32(ah, bl), q_umul32(al, bh)};
	for (int i = 0; i < 2; i++) { /* (hi, lo) += mid 2^32 */
		uint64_t m = mid[i] << 32;
		lo += m;
		hi += (mid[i] >> 32) + (lo < m ? 1u : 0u);
	}
	/* |a b| / 2^s < 2^63 exactly when hi < 2^(s - 1) */
	if (hi >= ((uint64_t)1 << (s - 1u)))
		return neg ? -INT64_MAX : INT64_MAX;
	uint64_t r = (hi << (64u - s)) | (lo >> s);
	r += (lo >> (s - 1u)) & 1u;
	if (r > (uint64_t)INT64_MAX)
		return neg ? -INT64_MAX : INT64_MAX;
	return neg ? -(int64_t)r : (int64_t)r;
}

#endif /* OCTO_QFMT_H */
