/*
 * sc_recip.h - division by a divisor that changes rarely (a parameter, the frame period):
 * its reciprocal is prepared once (sc_recip_of), each division then costs a product.
 *
 * sc_div_r(a, b, &r) returns exactly sc_div(a, b) in both builds, r = sc_recip_of(b):
 *   - float build: the IEEE quotient a / b (the same operation as sc_div);
 *   - fixed build: the quotient from the prepared reciprocal of |b| (what sc_div computes
 *     afresh on every call, two Newton steps and a correction on 64 bits), made exact by its
 *     remainder as sc_div makes it: round to nearest, ties away from zero, saturating.
 */
#ifndef OCTO_SC_RECIP_H
#define OCTO_SC_RECIP_H

#include "scalar.h"

/* One word: the divisor b itself is not kept (its owner keeps it, as a parameter, and
 * passes it to sc_div_r); |b| and q_clz32(|b|) follow from it, and the shift s (< 32) takes
 * the low 5 bits of the reciprocal y (about 2^31.5, within 2^-27 relative of
 * 2^63 / (|b| << s), so those bits are below its precision): y without them is within
 * 2^-26, and sc_div_prepared makes the quotient exact by its remainder all the same (the
 * same quotients as sc_div). The float build keeps nothing (ys 0). */
struct sc_recip {
	uint32_t ys; /* 1 / |b| = y 2^(s - 63): y = ys & ~SC_RECIP_SMASK, s = ys & SC_RECIP_SMASK;
		       * 0 when b is 0 */
};
#define SC_RECIP_SMASK 31u

#if OCTO_FIXED
static inline struct sc_recip sc_recip_of(scalar_t b)
{
	uint32_t ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	int s = q_clz32(ub);
	struct sc_recip r = {ub ? (sc_recip_norm(ub << s) & ~SC_RECIP_SMASK) | (uint32_t)s : 0u};
	return r;
}

/* sc_div(a, b) for the b that r was prepared from, without preparing the reciprocal again */
static inline scalar_t sc_div_r(scalar_t a, scalar_t b, const struct sc_recip *r)
{
	uint32_t ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	return sc_div_prepared(a, b, ub, (int)(r->ys & SC_RECIP_SMASK), r->ys & ~SC_RECIP_SMASK);
}
#else
static inline struct sc_recip sc_recip_of(scalar_t b)
{
	(void)b;
	struct sc_recip r = {0u};
	return r;
}

static inline scalar_t sc_div_r(scalar_t a, scalar_t b, const struct sc_recip *r)
{
	(void)r;
	return sc_div(a, b);
}
#endif

#endif /* OCTO_SC_RECIP_H */
