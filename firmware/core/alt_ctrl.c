/* alt_ctrl.c - see alt_ctrl.h for the law, units and frames. */
#include "alt_ctrl.h"

struct alt_ctrl_params alt_ctrl_params_default(void)
{
	struct alt_ctrl_params p;
	p.wn_rps = SC(ALT_CTRL_DEFAULT_WN_RPS);
	p.zeta = SC(ALT_CTRL_DEFAULT_ZETA);
	p.ki_rps = SC(ALT_CTRL_DEFAULT_KI_RPS);
	p.vz_max_up_mps = SC(2.0);
	p.vz_max_down_mps = SC(1.5);
	p.a_int_max_mps2 = SC(4.0);
	p.cos_tilt_min = SC(0.5);
	p.f_min_n = SC(2.0);
	p.f_max_n = SC(200.0);
	p.g_mps2 = SC(9.796);
	return p;
}

void alt_ctrl_set_params(struct alt_ctrl *s, const struct alt_ctrl_params *params)
{
	s->p = *params;
	s->p.cos_tilt_min = sc_clamp(s->p.cos_tilt_min, SC(0.05), SC(1));
	s->m_kv = sc_mul(sc_add(s->p.zeta, s->p.zeta), s->p.wn_rps); /* 2 zeta wn */
	s->m_kz = sc_div(sc_mul(s->p.wn_rps, s->p.wn_rps), s->m_kv);
	s->r_g = sc_recip_of(s->p.g_mps2);
}

void alt_ctrl_init(struct alt_ctrl *s, const struct alt_ctrl_params *params)
{
	alt_ctrl_set_params(s, params);
	s->a_int_mps2 = SC_ZERO;
	s->f_n = SC_ZERO;
	s->flags = 0;
}

void alt_ctrl_reset(struct alt_ctrl *s, scalar_t a_int_mps2)
{
	s->a_int_mps2 = sc_clamp(a_int_mps2, sc_neg(s->p.a_int_max_mps2), s->p.a_int_max_mps2);
}

scalar_t alt_ctrl_update(struct alt_ctrl *s, const struct alt_ctrl_input *in)
{
	const struct alt_ctrl_params *p = &s->p;
	uint32_t flags = 0;
#if SC_HARD_FLOAT
	/* every input finite: with an FPU one test of their sum (a NaN or an infinity anywhere
	 * makes it non-finite; so does a sum beyond the float range, which no real input reaches) */
	const bool finite =
		sc_isfinite(((in->z_sp_m + in->vz_ff_mps) + (in->z_m + in->vz_mps)) +
			    ((in->mass_kg + in->dt_s) + (in->q_b2i.w + in->q_b2i.x)) + (in->q_b2i.y + in->q_b2i.z));
#else
	const bool finite = sc_isfinite(in->z_sp_m) && sc_isfinite(in->vz_ff_mps) && sc_isfinite(in->z_m) &&
			    sc_isfinite(in->vz_mps) && sc_isfinite(in->mass_kg) && sc_isfinite(in->dt_s) &&
			    sc_isfinite(in->q_b2i.w) && sc_isfinite(in->q_b2i.x) && sc_isfinite(in->q_b2i.y) &&
			    sc_isfinite(in->q_b2i.z);
#endif
	if (!finite) {
		s->flags = ALT_CTRL_BAD_INPUT;
		return s->f_n;
	}
	scalar_t kv = s->m_kv; /* 2 zeta wn */
	scalar_t kz = s->m_kz; /* wn / (2 zeta) */

	scalar_t vz_cmd = sc_mul(kz, sc_sub(in->z_sp_m, in->z_m));
	if (vz_cmd > p->vz_max_up_mps || vz_cmd < sc_neg(p->vz_max_down_mps)) {
		vz_cmd = sc_clamp(vz_cmd, sc_neg(p->vz_max_down_mps), p->vz_max_up_mps);
		flags |= ALT_CTRL_VZ_LIM;
	}
	vz_cmd = sc_add(vz_cmd, in->vz_ff_mps);
	scalar_t ev = sc_sub(vz_cmd, in->vz_mps);
	scalar_t a_cmd = sc_add(sc_mul(kv, ev), s->a_int_mps2);

	scalar_t cz = quat_body_z_up(in->q_b2i);
	if (cz < p->cos_tilt_min) {
		cz = p->cos_tilt_min;
		flags |= ALT_CTRL_TILT_LIM;
	}
	scalar_t f;
	if (sc_isfinite(in->hover_f_n) && in->hover_f_n > SC_ZERO && p->g_mps2 > SC_ZERO) {
		f = sc_div(sc_mul(sc_div_r(in->hover_f_n, p->g_mps2, &s->r_g), sc_add(p->g_mps2, a_cmd)), cz);
	} else {
		f = sc_div(sc_mul(in->mass_kg, sc_add(p->g_mps2, a_cmd)), cz);
	}
	if (f > p->f_max_n) {
		f = p->f_max_n;
		flags |= ALT_CTRL_SAT_HIGH;
	} else if (f < p->f_min_n) {
		f = p->f_min_n;
		flags |= ALT_CTRL_SAT_LOW;
	}

	/* integral with anti-windup: frozen while saturated here or in the allocation in the
	 * direction of ev */
	bool up = (flags & ALT_CTRL_SAT_HIGH) || in->alloc_short_up;
	bool down = (flags & ALT_CTRL_SAT_LOW) || in->alloc_short_down;
	bool frozen = (up && ev > SC_ZERO) || (down && ev < SC_ZERO);
	if (!frozen && p->ki_rps > SC_ZERO) {
		scalar_t dt = sc_max(in->dt_s, SC_ZERO);
		s->a_int_mps2 = sc_add(s->a_int_mps2, sc_mul(sc_mul(sc_mul(kv, p->ki_rps), ev), dt));
	}
	if (s->a_int_mps2 >= p->a_int_max_mps2 || s->a_int_mps2 <= sc_neg(p->a_int_max_mps2)) {
		s->a_int_mps2 = sc_clamp(s->a_int_mps2, sc_neg(p->a_int_max_mps2), p->a_int_max_mps2);
		flags |= ALT_CTRL_INT_LIM;
	}
	s->f_n = f;
	s->flags = flags;
	return f;
}
