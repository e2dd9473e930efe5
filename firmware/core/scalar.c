/*
 * scalar.c - the one out-of-line copy of the scalar primitives: sc_div in both builds, the
 * fixed build's non-trivial primitives.
 *
 * scalar.h (Q16.16) and qfmt.h define their non-trivial primitives `inline` with external
 * linkage (C11 6.7.4): a compiler inlines one where it would inline a static function, and
 * where it does not (Cortex-M0 builds at -Os) the object calls the copy emitted here by the
 * `extern` declarations below, instead of keeping a static copy of its own. So do sc_add and
 * sc_sub: their inline forms sca_add and sca_sub serve the hottest loops. The trivial
 * primitives (sc_neg, sc_min, q_sat32 ...) stay static inline. sc_div, a call wherever it is
 * used, is defined here only, in both builds.
 */
#include "scalar.h"

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
#if !defined(__GNUC__)   /* GCC and Clang always inline qa_* (or fail to compile): no copy */
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

scalar_t sc_div(scalar_t a, scalar_t b)
{
	uint32_t ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	int s = q_clz32(ub);
	return sc_div_prepared(a, b, ub, s, ub ? sc_recip_norm(ub << s) : 0u);
}
#else
scalar_t sc_div(scalar_t a, scalar_t b)
{
	if (b == 0.0f)
		return a > 0.0f ? SC_MAX : (a < 0.0f ? SC_MAX_NEG : 0.0f);
	return a / b;
}
#endif
