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

/* sc_div(a, r->b), step for step without the reciprocal */
static inline scalar_t sc_div_r(scalar_t a, const struct sc_recip *r)
{
	if (r->ub == 0u)
		return a > 0 ? SC_MAX : (a < 0 ? SC_MAX_NEG : 0);
	bool neg = (a < 0) != (r->b < 0);
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a, ub = r->ub;
	uint64_t x = ((uint64_t)ua << 16) + (ub >> 1);
	if ((x >> 31) >= ub)
		return neg ? SC_MAX_NEG : SC_MAX;
	int k = 31 - r->s;
	uint32_t xh = (uint32_t)(x >> 32), xl = (uint32_t)x;
	uint32_t x32 = k ? (xl >> k) | (xh << (32 - k)) : xl;
	uint32_t q = (uint32_t)(q_umul32(x32, r->y) >> 32);
	int64_t rem = (int64_t)x - (int64_t)q_umul32(q, ub);
	while (rem < 0) {
		q--;
		rem += ub;
	}
	while (rem >= (int64_t)ub) {
		q++;
		rem -= ub;
	}
	return neg ? -(scalar_t)q : (scalar_t)q;
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
