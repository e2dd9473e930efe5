/*
 * scalar.c - the one out-of-line copy of the scalar primitives: sc_div in both builds, the
 * soft-float build's roots and comparisons, the fixed build's non-trivial primitives.
 *
 * scalar.h (Q16.16) and qfmt.h define their non-trivial primitives `inline` with external
 * linkage (C11 6.7.4): a compiler inlines one where it would inline a static function, and
 * where it does not (Cortex-M0 builds at -Os) the object calls the copy emitted here by the
 * `extern` declarations below, instead of keeping a static copy of its own. So do sc_add and
 * sc_sub: their inline forms sca_add and sca_sub serve the hottest loops. The trivial
 * primitives (sc_neg, q_sat32 ...) stay static inline. sc_div, a call wherever it is
 * used, is defined here only, in the fixed build and where float is soft (an FPU's build
 * inlines it: scalar.h); so are sc_sqrt, sc_min, sc_max and sc_clamp where float is soft
 * (SC_SOFT_FLOAT); the fixed build's sc_sqrt and sc_exp too.
 */
#include "scalar.h"
#include "fbits.h"

#if OCTO_FIXED
extern inline int64_t q_add64(int64_t a, int64_t b);
extern inline uint64_t q_umul32(uint32_t a, uint32_t b);
extern inline int64_t q_smul32(int32_t a, int32_t b);
extern inline int q_clz32(uint32_t v);
extern inline int q_clz64(uint64_t v);
extern inline int64_t q_shr64(int64_t v, unsigned s);
extern inline int64_t q_shl64(int64_t v, unsigned s);
extern inline int64_t q_scale64(int64_t v, int s);
extern inline int64_t q_mul64_32(int64_t a, int32_t b, unsigned s);
#if !defined(__GNUC__) /* GCC and Clang always inline qa_* (or fail to compile): no copy */
extern inline uint64_t qa_umul32(uint32_t a, uint32_t b);
extern inline int qa_clz32(uint32_t v);
extern inline int64_t qa_shr64(int64_t v, unsigned s);
extern inline int64_t qa_shl64(int64_t v, unsigned s);
extern inline scalar_t sca_add(scalar_t a, scalar_t b);
extern inline scalar_t sca_sub(scalar_t a, scalar_t b);
#endif

extern inline scalar_t sc_from_float(float x);
extern inline float sc_to_float(scalar_t a);
extern inline scalar_t sc_add(scalar_t a, scalar_t b);
extern inline scalar_t sc_sub(scalar_t a, scalar_t b);
extern inline scalar_t sc_mul(scalar_t a, scalar_t b);
extern inline uint32_t sc_recip_norm(uint32_t v);
extern inline scalar_t sc_div_prepared(scalar_t a, scalar_t b, uint32_t ub, int s, uint32_t y);

/* step of the digit-by-digit square root: the next two bits of the radicand */
static void sc_sqrt_step(uint32_t *r, uint32_t *rem, uint32_t pair)
{
	*rem = (*rem << 2) | pair;
	uint32_t t = (*r << 2) | 1u;
	if (*rem >= t) {
		*rem -= t;
		*r = (*r << 1) | 1u;
	} else {
		*r <<= 1;
	}
}

/* sqrt(a 2^16) rounded to nearest, digit by digit in 32-bit words (no 64-bit arithmetic on
 * Cortex-M0): a's bit pairs from its highest non-zero one, then 8 zero pairs for the 2^16;
 * the root stays below 2^24 and the remainder, at most twice the root, below 2^26 */
scalar_t sc_sqrt(scalar_t a)
{
	if (a <= 0)
		return 0;
	uint32_t v = (uint32_t)a, r = 0, rem = 0;
	int sh = 30;
	while (!(v >> sh))
		sh -= 2;
	for (; sh >= 0; sh -= 2)
		sc_sqrt_step(&r, &rem, (v >> sh) & 3u);
	for (int i = 0; i < 8; i++)
		sc_sqrt_step(&r, &rem, 0u);
	if (rem > r) /* a 2^16 > r^2 + r: nearer r + 1 */
		r++;
	return (scalar_t)r;
}

/* e^a in integer arithmetic (filter and lag coefficients): a = k ln 2 + r with r in
 * [0, ln 2) in Q32, e^r by its Taylor series in Q30 (13 terms: error < 1e-9 relative), then
 * scaled by 2^k and rounded to Q16.16: within 0.5 LSB + 1e-9 relative; saturates to
 * SC_MAX above ln(32768) and gives 0 below ln(2^-17) */
scalar_t sc_exp(scalar_t a)
{
	if (a >= 681391) /* 10.3972 = ln(32768) in Q16.16 */
		return SC_MAX;
	if (a <= -794978) /* -12.1301 = ln(2^-17.5) */
		return 0;
	const int64_t ln2_q32 = 2977044472LL; /* ln 2 * 2^32, rounded */
	int64_t x = (int64_t)a * 65536;       /* Q32 */
	int64_t k = x / ln2_q32;
	if (k * ln2_q32 > x)
		k--;                        /* floor */
	int64_t r = (x - k * ln2_q32) >> 2; /* Q30, [0, ln 2) */
	int64_t term = (int64_t)1 << 30, sum = term;
	for (int i = 1; i <= 13; i++) {
		term = (term * r >> 30) / i;
		sum += term;
	}
	int sh = 14 - (int)k; /* Q30 * 2^k -> Q16 */
	if (sh <= 0)
		return sc_sat64(sum << -sh);
	return sc_sat64((sum + ((int64_t)1 << (sh - 1))) >> sh);
}

scalar_t sc_div(scalar_t a, scalar_t b)
{
	uint32_t ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	int s = q_clz32(ub);
	return sc_div_prepared(a, b, ub, s, ub ? sc_recip_norm(ub << s) : 0u);
}
#elif SC_SOFT_FLOAT
scalar_t sc_div(scalar_t a, scalar_t b)
{
	if (b == 0.0f)
		return a > 0.0f ? SC_MAX : (a < 0.0f ? SC_MAX_NEG : 0.0f);
	return a / b;
}

scalar_t sc_sqrt(scalar_t a)
{
	/* a > 0 from its bits: one word test, not a soft-float comparison */
	return fb_pos(a) ? sqrtf(a) : 0.0f;
}

scalar_t sc_min(scalar_t a, scalar_t b) { return a < b ? a : b; }
scalar_t sc_max(scalar_t a, scalar_t b) { return a > b ? a : b; }
scalar_t sc_clamp(scalar_t x, scalar_t lo, scalar_t hi) { return x < lo ? lo : (x > hi ? hi : x); }
#endif
