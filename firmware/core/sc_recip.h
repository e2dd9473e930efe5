/*
 * sc_recip.h - division by a divisor that changes rarely (a parameter, the frame period):
 * its reciprocal is prepared once (sc_recip_of), each division then costs a product.
 *
 * sc_div_r(a, &r) returns exactly sc_div(a, b) in both builds:
 *   - float build: the IEEE quotient a / b (the same operation as sc_div);
 *   - fixed build: the quotient from the prepared reciprocal of |b| (what sc_div computes
 *     afresh on every call, two Newton steps and a correction on 64 bits), made exact by its
 *     remainder as sc_div makes it: round to nearest, ties away from zero, saturating.
 */
#ifndef OCTO_SC_RECIP_H
#define OCTO_SC_RECIP_H

#include "scalar.h"

#if OCTO_FIXED
/* Two words: |b| and q_clz32(|b|) follow from b, and the shift s (< 32) takes the low 5 bits
 * of the reciprocal y (about 2^31.5, within 2^-27 relative of 2^63 / (|b| << s), so those
 * bits are below its precision): y without them is within 2^-26, and sc_div_prepared makes
 * the quotient exact by its remainder all the same (the same quotients as sc_div). */
struct sc_recip {
	scalar_t b;   /* the divisor */
	uint32_t ys;  /* 1 / |b| = y 2^(s - 63): y = ys & ~SC_RECIP_SMASK, s = ys & SC_RECIP_SMASK;
		       * 0 when b is 0 */
};
#define SC_RECIP_SMASK 31u

static inline struct sc_recip sc_recip_of(scalar_t b)
{
	uint32_t ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	int s = q_clz32(ub);
	struct sc_recip r = { b, ub ? (sc_recip_norm(ub << s) & ~SC_RECIP_SMASK) | (uint32_t)s : 0u };
	return r;
}

/* sc_div(a, r->b) without preparing the reciprocal again */
static inline scalar_t sc_div_r(scalar_t a, const struct sc_recip *r)
{
	uint32_t ub = r->b < 0 ? 0u - (uint32_t)r->b : (uint32_t)r->b;
	return sc_div_prepared(a, r->b, ub, (int)(r->ys & SC_RECIP_SMASK), r->ys & ~SC_RECIP_SMASK);
}
#else
struct sc_recip {
	scalar_t b;
};

static inline struct sc_recip sc_recip_of(scalar_t b)
{
	struct sc_recip r = { b };
	return r;
}

static inline scalar_t sc_div_r(scalar_t a, const struct sc_recip *r) { return sc_div(a, r->b); }
#endif

#endif /* OCTO_SC_RECIP_H */
