/*
 * scalar_ops.h - scalar operations of the 90 Hz path beyond scalar.h: a product by a factor
 * prepared when parameters change, in place of a division on every step.
 *
 * sc_sincos(a, &s, &c) is sc_sin(a) and sc_cos(a), bit for bit, with the angle reduced once
 * in the fixed build.
 *
 * sc_div_int(a, n) is sc_div(a, SC(n)) bit for bit for a small integer n > 0 (a constant such
 * as 100), by one integer division in the fixed build instead of a reciprocal.
 *
 * sc_gain_recip2(a, b) prepares g = 1 / (a b) for a, b > 0; sc_mul_gain(x, &g) returns x g.
 *   - float build: g = 1 / (a b) as a float, x g one product (rounding-level apart from
 *     x / (a b)).
 *   - fixed build: g kept as a 32-bit mantissa and a shift, g = y 2^-sh with y in
 *     (2^31, 2^32], so that x g costs one 32 x 32 -> 64-bit product and a rounding shift
 *     (no quotient on every step). y comes from sc_recip_norm of a b's leading 32 bits: within
 *     2^-26 relative of 1 / (a b), then x g is rounded to nearest (ties away from zero) and
 *     saturates to [SC_MAX_NEG, SC_MAX]. In range, x g is within 0.5 LSB + 2^-26 |x g| of
 *     the exact quotient (the rounded quotient of sc_div after a rounded sc_mul is within 1 LSB
 *     and more).
 */
#ifndef OCTO_SCALAR_OPS_H
#define OCTO_SCALAR_OPS_H

#include "scalar.h"

#if OCTO_FIXED
static inline void sc_sincos(scalar_t a, scalar_t *s, scalar_t *c)
{
	uint32_t p = sc_turns(a);
	*s = sc_sin_turn(p);
	*c = sc_sin_turn(p + 0x40000000u);
}

/* sc_div(a, n 2^16) = floor((|a| 2^16 + n 2^15) / (n 2^16)) = floor((2 |a| + n) / (2 n))
 * = q + (2 r >= n) with |a| = q n + r: one 32-bit division, signed like a, saturating like
 * sc_div (only INT32_MIN / 1 does); n in [1, 2^15) */
static inline scalar_t sc_div_int(scalar_t a, uint32_t n)
{
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a;
	uint32_t q = ua / n, r = ua - q * n;
	q += 2u * r >= n ? 1u : 0u;
	if (q > (uint32_t)INT32_MAX)
		return a < 0 ? SC_MAX_NEG : SC_MAX;
	return a < 0 ? -(scalar_t)q : (scalar_t)q;
}

struct sc_gain {
	uint32_t y;  /* mantissa: g = y 2^-sh in Q16.16 units */
	uint32_t sh; /* in [1, 63] */
};

/* 1 / (a b) for a, b > 0 (a b >= 2^-16 in real terms: a_raw b_raw >= 2^16) */
static inline struct sc_gain sc_gain_recip2(scalar_t a, scalar_t b)
{
	struct sc_gain g = {0u, 1u};
	if (a <= 0 || b <= 0)
		return g;
	/* 1 / (a b) in raw units: g_raw = 2^32 / (a_raw b_raw) = 2^32 / P. With P << c in
	 * [2^63, 2^64) and v its leading 32 bits, P ~ v 2^(32 - c) and 2^63 / v ~ y: g = y 2^(c - 63) */
	uint64_t p = q_umul32((uint32_t)a, (uint32_t)b);
	int c = q_clz64(p);
	if (c < 1)
		c = 1; /* cannot happen: a, b < 2^31 */
	uint32_t v = (uint32_t)((p << c) >> 32);
	g.y = sc_recip_norm(v);
	g.sh = (uint32_t)(63 - c);
	if (g.sh == 0u) { /* a b < 2^-15: g beyond the format anyway */
		g.y >>= 1;
		g.sh = 1u;
	}
	return g;
}

/* x g for g = y 2^-sh (an sc_gain's two fields, for a caller that keeps them apart) */
static inline scalar_t sc_mul_gain_ysh(scalar_t x, uint32_t y, uint32_t sh)
{
	uint32_t ux = x < 0 ? 0u - (uint32_t)x : (uint32_t)x;
	/* r = floor(p 2^(1 - sh)) = floor(2 x g), then (r + 1) / 2 rounded to nearest; in 32-bit
	 * words (sc_umul32w): a variable 64-bit shift is a library call on Cortex-M0 */
	uint32_t hi, lo, k = sh - 1u, rh, rl;
	sc_umul32w(ux, y, &hi, &lo); /* p = x y < 2^64 */
	if (k >= 32u) {
		rh = 0u;
		rl = hi >> (k - 32u);
	} else {
		rh = hi >> k;
		rl = k ? (lo >> k) | (hi << (32u - k)) : lo;
	}
	if (rh || rl == 0xffffffffu) /* (r + 1) / 2 > INT32_MAX */
		return x < 0 ? SC_MAX_NEG : SC_MAX;
	uint32_t q = (rl >> 1) + (rl & 1u); /* (r + 1) / 2 */
	return x < 0 ? -(scalar_t)q : (scalar_t)q;
}

static inline scalar_t sc_mul_gain(scalar_t x, const struct sc_gain *g) { return sc_mul_gain_ysh(x, g->y, g->sh); }
#else
static inline void sc_sincos(scalar_t a, scalar_t *s, scalar_t *c)
{
	*s = sc_sin(a);
	*c = sc_cos(a);
}

static inline scalar_t sc_div_int(scalar_t a, uint32_t n) { return sc_div(a, (scalar_t)n); }

struct sc_gain {
	scalar_t g;
};

static inline struct sc_gain sc_gain_recip2(scalar_t a, scalar_t b)
{
	struct sc_gain g = {sc_div(SC(1), sc_mul(a, b))};
	return g;
}

static inline scalar_t sc_mul_gain(scalar_t x, const struct sc_gain *g) { return sc_mul(x, g->g); }
#endif

#endif /* OCTO_SCALAR_OPS_H */
