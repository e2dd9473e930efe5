/* thrmap.c - see thrmap.h. */
#include "thrmap.h"

void thrmap_init(struct thrmap *m, const struct thrmap_params *params)
{
	m->p = *params;
	m->p.k_f_n = sc_max(m->p.k_f_n, SC(1e-3));
	m->p.curve = sc_clamp(m->p.curve, SC(THRMAP_CURVE_MIN), SC(THRMAP_CURVE_MAX));
	m->one_minus_a = sc_sub(SC(1), m->p.curve);
	m->r_kf = sc_recip_of(m->p.k_f_n);
	for (unsigned j = 0; j < THRMAP_ROTORS; j++) {
		scalar_t k = m->p.scale[j] == SC_ZERO ? SC(1) : sc_clamp(m->p.scale[j], SC(0.1), SC(4));
		m->p.scale[j] = k;
		m->g[j] = sc_gain_recip2(k, m->p.k_f_n);
	}
}

/* T of u = f / k_f (the rest of thrmap_throttle) */
static scalar_t throttle_of_u(const struct thrmap *m, scalar_t u, bool *clamped)
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
	scalar_t t = u;
	if (m->p.curve != SC_ZERO) {
		/* T = 2u / ((1-a) + sqrt((1-a)^2 + 4 a u)), the root that stays finite as a -> 0;
		 * u in [0, 1] gives T in [0, 1], and (1-a)^2 + 4 a u >= (1+a)^2 > 0 for a < 0 */
		scalar_t b = m->one_minus_a;
		scalar_t disc = sc_add(sc_mul(b, b), sc_mul(sc_mul(SC(4), m->p.curve), u));
		t = sc_div(sc_add(u, u), sc_add(b, sc_sqrt(disc)));
		t = sc_clamp(t, SC_ZERO, SC(1));
	}
	if (clamped)
		*clamped = c;
	return t;
}

scalar_t thrmap_throttle(const struct thrmap *m, scalar_t f_n, bool *clamped)
{
	return throttle_of_u(m, sc_div_r(f_n, &m->r_kf), clamped);
}

scalar_t thrmap_thrust(const struct thrmap *m, scalar_t throttle)
{
	scalar_t t = sc_clamp(throttle, SC_ZERO, SC(1));
	/* k_f T ((1 - a) + a T) */
	return sc_mul(m->p.k_f_n, sc_mul(t, sc_add(m->one_minus_a, sc_mul(m->p.curve, t))));
}

uint32_t thrmap_update(const struct thrmap *m, const scalar_t *f_n, scalar_t *throttle_out, size_t n)
{
	uint32_t mask = 0;
	for (size_t j = 0; j < n; j++) {
		bool c = false;
		/* u = f / (scale k_f): one product by the prepared factor per rotor */
		scalar_t u = j < THRMAP_ROTORS ? sc_mul_gain(f_n[j], &m->g[j]) : sc_div_r(f_n[j], &m->r_kf);
		throttle_out[j] = throttle_of_u(m, u, &c);
		if (c && j < 32)
			mask |= (uint32_t)1 << j;
	}
	return mask;
}
