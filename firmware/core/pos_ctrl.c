/* pos_ctrl.c - see pos_ctrl.h for the law, units and frames. */
#include "pos_ctrl.h"

struct pos_ctrl_params pos_ctrl_params_default(void)
{
	struct pos_ctrl_params p;
	p.pos_gain_rps = SC(POS_CTRL_DEFAULT_POS_GAIN_RPS);
	p.vel_gain_rad_mps = SC(POS_CTRL_DEFAULT_VEL_GAIN_RAD_MPS);
	p.vel_max_mps = SC(POS_CTRL_DEFAULT_VEL_MAX_MPS);
	p.tilt_max_rad = SC(POS_CTRL_DEFAULT_TILT_MAX_DEG * 0.017453292519943295f);
	return p;
}

void pos_ctrl_heading(struct quat q, scalar_t *c, scalar_t *s)
{
	/* body X axis in S_I: [1 - 2 (y^2 + z^2), 2 (x y + w z), ...] */
	/* the factors 2 as sums: the same values as the products */
	scalar_t yz = sc_add(sc_sq(q.y), sc_sq(q.z)), xy = sc_add(sc_mul(q.x, q.y), sc_mul(q.w, q.z));
	scalar_t hx = sc_sub(SC(1), sc_add(yz, yz));
	scalar_t hy = sc_add(xy, xy);
	scalar_t n = sc_sqrt(sc_add(sc_sq(hx), sc_sq(hy)));
	if (!(n > SC(1e-3))) {
		*c = SC(1);
		*s = SC_ZERO;
		return;
	}
	scalar_t inv = sc_div(SC(1), n);
	*c = sc_mul(hx, inv);
	*s = sc_mul(hy, inv);
}

/* a NaN or an infinity anywhere makes the sum non-finite (so does a sum beyond the float
 * range, which no real input reaches); one test instead of ten */
static bool finite_in(const struct pos_ctrl_input *in)
{
	scalar_t sum = sc_add(sc_add(in->q_b2i.w, in->q_b2i.x), sc_add(in->q_b2i.y, in->q_b2i.z));
	for (int i = 0; i < 2; i++)
		sum = sc_add(sum, sc_add(sc_add(in->pos_sp_m[i], in->pos_m[i]), in->vel_mps[i]));
	return sc_isfinite(sum);
}

SC_HOT_INLINE scalar_t clamp_flag(scalar_t x, scalar_t lim, uint32_t flag, uint32_t *flags)
{
	if (x > lim || x < sc_neg(lim)) {
		*flags |= flag;
		return sc_clamp(x, sc_neg(lim), lim);
	}
	return x;
}

struct pos_ctrl_output pos_ctrl_update(const struct pos_ctrl_params *p, const struct pos_ctrl_input *in)
{
	struct pos_ctrl_output o = {SC_ZERO, SC_ZERO, 0};
	if (!finite_in(in)) {
		o.flags = POS_CTRL_BAD_INPUT;
		return o;
	}
	scalar_t a[2];
	SC_HOT_UNROLL
	for (int i = 0; i < 2; i++) {
		scalar_t v = sc_mul(p->pos_gain_rps, sc_sub(in->pos_sp_m[i], in->pos_m[i]));
		v = clamp_flag(v, p->vel_max_mps, POS_CTRL_VEL_LIM, &o.flags);
		a[i] = sc_mul(p->vel_gain_rad_mps, sc_sub(v, in->vel_mps[i]));
	}
	scalar_t c, s;
	pos_ctrl_heading(in->q_b2i, &c, &s);
	scalar_t fwd = sc_add(sc_mul(c, a[0]), sc_mul(s, a[1]));
	scalar_t left = sc_sub(sc_mul(c, a[1]), sc_mul(s, a[0]));
	o.pitch_rad = clamp_flag(fwd, p->tilt_max_rad, POS_CTRL_TILT_LIM, &o.flags);
	o.roll_rad = clamp_flag(sc_neg(left), p->tilt_max_rad, POS_CTRL_TILT_LIM, &o.flags);
	return o;
}
