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
struct sc_recip {
	scalar_t b;   /* the divisor */
	uint32_t ub;  /* |b| */
	uint32_t y;   /* 1 / |b| = y 2^(s - 63) (sc_recip_norm of |b| << s); 0 when b is 0 */
	int s;        /* leading zero bits of |b| */
};

static inline struct sc_recip sc_recip_of(scalar_t b)
{
	struct sc_recip r;
	r.b = b;
	r.ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	r.s = q_clz32(r.ub);
	r.y = r.ub ? sc_recip_norm(r.ub << r.s) : 0u;
	return r;
}

/* sc_div(a, r->b) without preparing the reciprocal again */
static inline scalar_t sc_div_r(scalar_t a, const struct sc_recip *r)
{
	return sc_div_prepared(a, r->b, r->ub, r->s, r->y);
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
