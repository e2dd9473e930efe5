/* thrmap.c - see thrmap.h. */
#include "thrmap.h"

void thrmap_init(struct thrmap *m, const struct thrmap_params *params)
{
	m->k_f_n = sc_max(params->k_f_n, SC(1e-3));
	m->curve = sc_clamp(params->curve, SC(THRMAP_CURVE_MIN), SC(THRMAP_CURVE_MAX));
	m->one_minus_a = sc_sub(SC(1), m->curve);
	for (unsigned j = 0; j < THRMAP_ROTORS; j++) {
		scalar_t k = params->scale[j] == SC_ZERO ? SC(1) : sc_clamp(params->scale[j], SC(0.1), SC(4));
		struct sc_gain g = sc_gain_recip2(k, m->k_f_n);
#if OCTO_FIXED
		m->g_y[j] = g.y;
		m->g_sh[j] = (uint8_t)g.sh;
#else
		m->g[j] = g;
#endif
	}
}

/* T of u in [0, 1] through a curve a = m->curve != 0: T = 2u / ((1-a) + sqrt((1-a)^2 + 4 a u)),
 * the root that stays finite as a -> 0; u in [0, 1] gives T in [0, 1], and
 * (1-a)^2 + 4 a u >= (1+a)^2 > 0 for a < 0; sums inline (sca_add): once per rotor and step.
 * A function of its own: the unrolled rotors' copies of throttle_of_u share it. */
static scalar_t throttle_curve(const struct thrmap *m, scalar_t u)
{
	scalar_t b = m->one_minus_a;
	scalar_t disc = sca_add(sc_mul(b, b), sc_mul(sc_mul(SC(4), m->curve), u));
	scalar_t t = sc_div(sca_add(u, u), sca_add(b, sc_sqrt(disc)));
	return sc_clamp(t, SC_ZERO, SC(1));
}

/* T of u = f / k_f: the inverse map, clamped (*clamped set when it was) */
SC_HOT_INLINE scalar_t throttle_of_u(const struct thrmap *m, scalar_t u, bool *clamped)
{
	bool c = false;
	if (!sc_isfinite(u)) { /* float build: NaN gives no thrust, +/-Inf the limits */
		c = true;
		u = u > SC_ZERO ? SC(1) : SC_ZERO;
	} else if (u <= SC_ZERO) {
		c = u < SC_ZERO;
		u = SC_ZERO;
	} else if (u >= SC(1)) {
		c = u > SC(1);
		u = SC(1);
	}
	*clamped = c;
	return m->curve != SC_ZERO ? throttle_curve(m, u) : u;
}

uint32_t thrmap_update(const struct thrmap *m, const scalar_t *f_n, scalar_t *throttle_out, size_t n)
{
	uint32_t mask = 0;
#if SC_HARD_FLOAT
	if (n == THRMAP_ROTORS) { /* the vehicle's rotors: a constant count (SC_HOT_UNROLL) */
		SC_HOT_UNROLL
		for (size_t j = 0; j < THRMAP_ROTORS; j++) {
			bool c;
			scalar_t u = sc_mul_gain(f_n[j], &m->g[j]);
			throttle_out[j] = throttle_of_u(m, u, &c);
			if (c)
				mask |= (uint32_t)1 << j;
		}
		return mask;
	}
#endif
	for (size_t j = 0; j < n; j++) {
		bool c;
		/* u = f / (scale k_f): one product by the prepared factor per rotor */
		scalar_t u;
		if (j >= THRMAP_ROTORS)
			u = sc_div(f_n[j], m->k_f_n);
		else
#if OCTO_FIXED
			u = sc_mul_gain_ysh(f_n[j], m->g_y[j], m->g_sh[j]);
#else
			u = sc_mul_gain(f_n[j], &m->g[j]);
#endif
		throttle_out[j] = throttle_of_u(m, u, &c);
		if (c && j < 32)
			mask |= (uint32_t)1 << j;
	}
	return mask;
}
