/* att_ctrl.c - see att_ctrl.h for the law, units and frames. */
#include "att_ctrl.h"

struct att_ctrl_params att_ctrl_params_default(void)
{
	struct att_ctrl_params p;
	p.wn_rps = vec3_make(SC(ATT_CTRL_DEFAULT_WN_RP_RPS), SC(ATT_CTRL_DEFAULT_WN_RP_RPS),
			     SC(ATT_CTRL_DEFAULT_WN_YAW_RPS));
	p.zeta = vec3_make(SC(ATT_CTRL_DEFAULT_ZETA), SC(ATT_CTRL_DEFAULT_ZETA), SC(ATT_CTRL_DEFAULT_ZETA));
	p.ki_rps = vec3_make(SC(ATT_CTRL_DEFAULT_KI_RPS), SC(ATT_CTRL_DEFAULT_KI_RPS), SC(ATT_CTRL_DEFAULT_KI_RPS));
	p.rate_max_rps = vec3_make(SC(3.0), SC(3.0), SC(1.5));
	p.tau_max_nm = vec3_make(SC(3.0), SC(3.0), SC(0.4));
	p.int_tau_max_nm = vec3_make(SC(0.5), SC(0.5), SC(0.1));
	p.int_err_max_rad = SC(0.2);
	p.gyro_comp = true;
	return p;
}

void att_ctrl_reset(struct att_ctrl *s) { s->int_r_rad = vec3_zero(); }

void att_ctrl_init(struct att_ctrl *s, const struct att_ctrl_params *params)
{
	att_ctrl_set_params(s, params);
	s->int_r_rad = vec3_zero();
	s->flags = 0;
}

/* component i (0 x, 1 y, 2 z) of a vec3 */
static scalar_t *comp(struct vec3 *v, int i) { return i == 0 ? &v->x : (i == 1 ? &v->y : &v->z); }

static scalar_t get(struct vec3 v, int i) { return *comp(&v, i); }

void att_ctrl_shift_integral(struct att_ctrl *s, struct vec3 tau_nm, struct vec3 inertia_kgm2)
{
	for (int i = 0; i < 3; i++) {
		scalar_t kint = sc_mul(sc_mul(get(inertia_kgm2, i), s->kd[i]), s->ki[i]);
		if (!(kint > SC_ZERO))
			continue;
		scalar_t lim = sc_div(s->int_tau_max[i], kint), *int_r = comp(&s->int_r_rad, i);
		*int_r = sc_clamp(sc_add(*int_r, sc_div(get(tau_nm, i), kint)), sc_neg(lim), lim);
	}
}

void att_ctrl_set_params(struct att_ctrl *s, const struct att_ctrl_params *params)
{
	for (int i = 0; i < 3; i++) {
		scalar_t wn = get(params->wn_rps, i), zeta = get(params->zeta, i);
		scalar_t kd = sc_mul(sc_add(zeta, zeta), wn); /* 2 zeta wn */
		s->kd[i] = kd;
		s->kp[i] = sc_div(sc_mul(wn, wn), kd);
		s->ki[i] = get(params->ki_rps, i);
		s->rate_max[i] = get(params->rate_max_rps, i);
		s->tau_max[i] = get(params->tau_max_nm, i);
		s->int_tau_max[i] = get(params->int_tau_max_nm, i);
		/* inertia 0: I kd = 0 (and no limit: kint = 0); the next update's inertia differs */
		s->m_ii[i] = s->m_ikd[i] = s->m_lim[i] = SC_ZERO;
	}
	s->int_err_max_rad = params->int_err_max_rad;
	s->gyro_comp = params->gyro_comp;
}

#if !SC_HARD_FLOAT
static bool vec3_finite(struct vec3 v) { return sc_isfinite(v.x) && sc_isfinite(v.y) && sc_isfinite(v.z); }

static bool quat_finite(struct quat q)
{
	return sc_isfinite(q.w) && sc_isfinite(q.x) && sc_isfinite(q.y) && sc_isfinite(q.z);
}
#endif

/* Every input finite. With an FPU one test of their sum: a NaN or an infinity anywhere makes it
 * non-finite (so does a sum beyond the float range, which no real input reaches); else each
 * by its bits. */
static bool inputs_finite(const struct att_ctrl_input *in)
{
#if SC_HARD_FLOAT
	const struct quat a = in->q_sp_b2i, b = in->q_b2i;
	const struct vec3 f = in->rate_ff_b, w = in->rate_b_rps, j = in->inertia_kgm2;
	scalar_t sum = ((a.w + a.x) + (a.y + a.z)) + ((b.w + b.x) + (b.y + b.z));
	sum += ((f.x + f.y) + (f.z + w.x)) + ((w.y + w.z) + (j.x + j.y)) + (j.z + in->dt_s);
	return sc_isfinite(sum);
#else
	return quat_finite(in->q_sp_b2i) && quat_finite(in->q_b2i) && vec3_finite(in->rate_ff_b) &&
	       vec3_finite(in->rate_b_rps) && vec3_finite(in->inertia_kgm2) && sc_isfinite(in->dt_s);
#endif
}

uint32_t att_ctrl_update(struct att_ctrl *s, const struct att_ctrl_input *in, struct vec3 *tau_b_nm)
{
	if (!inputs_finite(in)) {
		*tau_b_nm = vec3_zero();
		s->flags = ATT_CTRL_BAD_INPUT;
		return s->flags;
	}
	struct vec3 e = quat_error_b(in->q_sp_b2i, in->q_b2i);
	struct vec3 w = in->rate_b_rps;
	struct vec3 inertia = in->inertia_kgm2;
	struct vec3 gyro = vec3_zero();
	if (s->gyro_comp)
		gyro = vec3_cross(w, vec3_mul(inertia, w));
	scalar_t dt = sc_max(in->dt_s, SC_ZERO);
	uint32_t flags = 0;
	struct vec3 tau_out = vec3_zero();

	SC_HOT_UNROLL
	for (int i = 0; i < 3; i++) {
		scalar_t ei = get(e, i), rate_max = s->rate_max[i], tau_max = s->tau_max[i];
		scalar_t int_tau_max = s->int_tau_max[i];
		scalar_t ii = get(inertia, i);
		scalar_t *int_r = comp(&s->int_r_rad, i);

		if (ii != s->m_ii[i]) { /* the inertia changed: its products and the limit */
			s->m_ii[i] = ii;
			s->m_ikd[i] = sc_mul(ii, s->kd[i]);
			scalar_t k = sc_mul(s->m_ikd[i], s->ki[i]);
			s->m_lim[i] = k > SC_ZERO ? sc_div(int_tau_max, k) : SC_ZERO;
		}
		scalar_t rc = sc_mul(s->kp[i], ei);
		if (rc > rate_max || rc < sc_neg(rate_max)) {
			rc = sc_clamp(rc, sc_neg(rate_max), rate_max);
			flags |= ATT_CTRL_RATE_LIM_X << i;
		}
		rc = sc_add(rc, get(in->rate_ff_b, i));

		/* integral torque I 2 zeta wn ki int(r), clamped */
		scalar_t ikd = s->m_ikd[i];            /* N m / (rad/s) */
		scalar_t kint = sc_mul(ikd, s->ki[i]); /* N m / rad */
		scalar_t tau_i = sc_clamp(sc_mul(kint, *int_r), sc_neg(int_tau_max), int_tau_max);
		scalar_t r = sc_sub(rc, get(w, i));

		scalar_t tau = sc_add(sc_add(sc_mul(ikd, r), tau_i), get(gyro, i));
		bool sat = tau > tau_max || tau < sc_neg(tau_max);
		if (sat) {
			flags |= ATT_CTRL_SAT_X << i;
			tau = sc_clamp(tau, sc_neg(tau_max), tau_max);
		}
		*comp(&tau_out, i) = tau;

		/* conditional integration: small error, or a large one the axis does not turn
		 * towards (a torque the integral must take: a slew turns at its rate limit),
		 * torque not saturated here or in the allocation in the direction the integral
		 * would grow */
		bool cut = (r > SC_ZERO && (in->alloc_short_pos >> i & 1u)) ||
			   (r < SC_ZERO && (in->alloc_short_neg >> i & 1u));
		bool held = sc_abs(ei) < s->int_err_max_rad || sc_abs(get(w, i)) < SC(ATT_CTRL_STUCK_RPS);
		if (kint > SC_ZERO && !sat && !cut && held) {
			scalar_t lim = s->m_lim[i]; /* int_tau_max / kint: keeps the state bounded too */
			*int_r = sc_clamp(sc_add(*int_r, sc_mul(r, dt)), sc_neg(lim), lim);
		} else if (kint <= SC_ZERO) {
			*int_r = SC_ZERO;
		}
	}
	*tau_b_nm = tau_out;
	s->flags = flags;
	return flags;
}
