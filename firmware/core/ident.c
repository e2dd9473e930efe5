/* ident.c - in-flight identification estimators, what runs every frame (integer in the fixed
 * build); initialisation, the float getters and the acceptance rules are ident_setup.c.
 * See ident.h. */
#include "ident.h"
#include "est_ops.h"

/* ---------------------------------------------------------------- sums of products
 * ident_sum_t (ident.h): Q31.32 in int64 in the fixed build, float otherwise. */
#if OCTO_FIXED
/* a b, exact (Q16.16 x Q16.16 = Q32.32 product, kept whole in int64) */
static inline ident_sum_t sum_prod(scalar_t a, scalar_t b) { return q_smul32(a, b); }
/* a 1 (a Q16.16 value in Q31.32) */
static inline ident_sum_t sum_of_sc(scalar_t a) { return (ident_sum_t)a * ((int64_t)1 << (QF_PROD_FRAC - QF_SC_FRAC)); }
static inline ident_sum_t sum_add(ident_sum_t a, ident_sum_t b) { return q_add64(a, b); }
#define SUM_ZERO 0
#else
static inline ident_sum_t sum_prod(scalar_t a, scalar_t b) { return a * b; }
static inline ident_sum_t sum_of_sc(scalar_t a) { return a; }
static inline ident_sum_t sum_add(ident_sum_t a, ident_sum_t b) { return a + b; }
#define SUM_ZERO 0.0f
#endif

/* ---------------------------------------------------------------- rotor coefficients */

/* g(s) = (1 - c) s + c s^2 (s a throttle, s and s^2 in [0, 1]: est_mul_unit, exact for any s) */
static scalar_t curve_g(scalar_t c, scalar_t s)
{
	return sc_add(est_mul_unit(sc_sub(SC(1.0), c), s), est_mul_unit(c, est_mul_unit(s, s)));
}

/* delay, lag and sensitivity one frame on; returns the lagged throttle s */
static scalar_t rotor_advance(struct ident_rotor *r, scalar_t thr_sent_prev)
{
	scalar_t u = filt_delay_update(&r->delay, thr_sent_prev);
	scalar_t s_prev = r->lag.y;
	scalar_t s = filt_lag_update(&r->lag, u);
	/* sensitivity of s to tau_m (the lag check) */
	r->dphi_dtau = sc_add(est_mul_unit(r->dphi_dtau, sc_sub(SC(1.0), r->lag.alpha)),
			      sc_mul(r->dalpha_dtau, sc_sub(u, s_prev)));
	return s;
}

void ident_rotor_hold(struct ident_rotor *r, scalar_t thr_sent_prev)
{
	rotor_advance(r, thr_sent_prev);
	r->have_prev = false;
}

void ident_rotor_update(struct ident_rotor *r, scalar_t thr_sent_prev, scalar_t f_meas, scalar_t tau_meas, bool excited)
{
	ident_rotor_process(r); /* a frame still waiting first: nothing lost or reordered */
	/* lag-aware: the previous frame's throttle, delayed and lagged, for this measurement */
	scalar_t s = rotor_advance(r, thr_sent_prev);
	r->phi = curve_g(r->curve, s);
	/* the lag check: g'(s) = 1 - c + 2 c s times the sensitivity of s */
	scalar_t gp = sc_add(sc_sub(SC(1.0), r->curve), est_mul_unit(sc_add(r->curve, r->curve), s));
	r->q_dphi = sc_mul(gp, r->dphi_dtau);
	/* plain (eq. 18-20): the previous measurement against the command of its own frame,
	 * which is the throttle sent on the previous frame */
	r->q_plain = r->have_prev;
	if (r->have_prev) {
		r->q_phi_raw = curve_g(r->curve, thr_sent_prev);
		r->q_y_prev[0] = r->y_prev[0];
		r->q_y_prev[1] = r->y_prev[1];
	}
	r->q_y[0] = f_meas;
	r->q_y[1] = tau_meas;
	r->q_excited = excited;
	r->q_pending = true;
	r->y_prev[0] = f_meas;
	r->y_prev[1] = tau_meas;
	r->have_prev = true;
	r->n++;
}

void ident_rotor_process(struct ident_rotor *r)
{
	if (!r->q_pending)
		return;
	r->q_pending = false;
	rls_update(&r->lagaware, &r->phi, r->q_y, r->q_excited);
	scalar_t phi2[2] = {r->phi, r->q_dphi};
	if (r->dalpha_dtau != SC_ZERO)
		rls_update(&r->sens, phi2, r->q_y, r->q_excited);
	if (r->q_plain)
		rls_update(&r->plain, &r->q_phi_raw, r->q_y_prev, r->q_excited);
}

/* ---------------------------------------------------------------- body torque */

void ident_body_torque(scalar_t arm_l_m, const scalar_t f[IDENT_ROTORS], const scalar_t tm[IDENT_ROTORS],
		       scalar_t tau_out[3])
{
	/* eq. (14) in units of l: tau_x row [0 -s -1 -s 0 s 1 s], tau_y row [-1 -s 0 s 1 s 0 -s] */
	const scalar_t s = SC(0.70710678118654752);
	scalar_t tx = sc_add(sc_mul(s, sc_sub(sc_add(f[5], f[7]), sc_add(f[1], f[3]))), sc_sub(f[6], f[2]));
	scalar_t ty = sc_add(sc_mul(s, sc_sub(sc_add(f[3], f[5]), sc_add(f[1], f[7]))), sc_sub(f[4], f[0]));
	scalar_t tz = SC_ZERO;
	for (int j = 0; j < IDENT_ROTORS; j += 2)
		tz = sc_add(tz, sc_sub(tm[j], tm[j + 1]));
	tau_out[0] = sc_mul(arm_l_m, tx);
	tau_out[1] = sc_mul(arm_l_m, ty);
	tau_out[2] = tz;
}

void ident_body_torque_mixer(const struct mixer *m, const scalar_t f[IDENT_ROTORS], const scalar_t tm[IDENT_ROTORS],
			     scalar_t tau_out[3])
{
	/* roll and pitch: rows 1 and 2 of mixer_wrench's wrench, by its operations in its order
	 * (the same values, bit for bit: tests/core/test_ident_inertia_accept.c), without the
	 * thrust and yaw rows it would form too */
	scalar_t u[IDENT_ROTORS];
	SC_HOT_UNROLL
	for (int j = 0; j < IDENT_ROTORS; j++)
		u[j] = m->p.scale[j] == SC(1) ? f[j] : sc_div(f[j], m->p.scale[j]);
	SC_HOT_UNROLL
	for (int i = 1; i <= 2; i++) {
		scalar_t s = SC_ZERO;
		SC_HOT_UNROLL
		for (int j = 0; j < IDENT_ROTORS; j++)
			s = sc_mac(m->gn[i][j], u[j], s);
		tau_out[i - 1] = sc_div(s, m->row_div[i]);
	}
	scalar_t tz = SC_ZERO;
	SC_HOT_UNROLL
	for (int j = 0; j < IDENT_ROTORS; j++) {
		scalar_t g = m->gn[3][j]; /* row-scaled Gamma: its sign is the yaw sign */
		if (g > SC_ZERO)
			tz = sc_add(tz, tm[j]);
		else if (g < SC_ZERO)
			tz = sc_sub(tz, tm[j]);
	}
	tau_out[2] = tz;
}

/* ---------------------------------------------------------------- inertia */

void ident_inertia_instrument(struct ident_inertia *e, scalar_t u)
{
	e->z_in = u;
	e->iv = true;
}

/* alpha x + (1 - alpha) x_prev */
static scalar_t weigh(scalar_t alpha, scalar_t x, scalar_t x_prev)
{
	return sc_add(x_prev, sc_mul(alpha, sc_sub(x, x_prev)));
}

void ident_inertia_sensitivity(struct ident_inertia *e, scalar_t d)
{
	e->d_in = d;
	e->sens = true;
}

/* The filters' step: torque of axis i, the axis' rate, the gyroscopic product w_j w_k (and
 * the torque's sensitivity, held through a gap). */
static void inertia_filters(struct ident_inertia *e, scalar_t tau, scalar_t w, scalar_t ww)
{
	filt_svf_update(&e->svf_tau, weigh(e->alpha, tau, e->tau_prev));
	/* the gyroscopic product is smooth: its frame mean is the trapezoid's */
	filt_svf_update(&e->svf_ww, weigh(SC(0.5), ww, e->ww_prev));
	filt_svf_update(&e->svf_w, w);
	e->tau_prev = tau;
	e->ww_prev = ww;
	e->w_prev = w;
	if (e->sens) {
		filt_svf_update(&e->svf_d, weigh(e->alpha, e->d_in, e->d_prev));
		e->d_prev = e->d_in;
	}
}

/* No lag pairs across what follows (a gap, a restart, an update without excitation). */
static void lag_break(struct ident_inertia *e) { e->z_n = e->r_n = 0; }

/* One excited update's lag products with the updates before it in the ring: z z' from the
 * first on, and once the residual's sums run, r r', r phi' + phi r' and phi phi' of
 * r = y - i0 phi (R(h) follows for any estimate I as rr - (I - i0) rp + (I - i0)^2 pp). */
static void lag_sums(struct ident_inertia *e, scalar_t z, scalar_t y, scalar_t phi)
{
	bool r_on = e->r_on;
	scalar_t r = r_on ? sc_sub(y, sc_mul(e->i0, phi)) : SC_ZERO;
	uint32_t nz = e->z_n < e->lags ? e->z_n : e->lags, nr = e->r_n < nz ? e->r_n : nz;
	e->c_zz[0] = sum_add(e->c_zz[0], sum_prod(z, z));
	if (r_on) {
		ident_sum_t rp = sum_prod(r, phi);
		e->c_rr[0] = sum_add(e->c_rr[0], sum_prod(r, r));
		e->c_rp[0] = sum_add(e->c_rp[0], sum_add(rp, rp));
		e->c_pp[0] = sum_add(e->c_pp[0], sum_prod(phi, phi));
		e->c_rn[0]++;
	}
	uint32_t m = e->ring_pos;
	for (uint32_t h = 1u; h <= nz; h++) {
		m = m == 0u ? IDENT_INR_LAGS - 1u : m - 1u; /* h updates back */
		e->c_zz[h] = sum_add(e->c_zz[h], sum_prod(z, e->ring_z[m]));
		if (h <= nr) {
			e->c_rr[h] = sum_add(e->c_rr[h], sum_prod(r, e->ring_r[m]));
			e->c_rp[h] =
				sum_add(e->c_rp[h], sum_add(sum_prod(r, e->ring_p[m]), sum_prod(phi, e->ring_r[m])));
			e->c_pp[h] = sum_add(e->c_pp[h], sum_prod(phi, e->ring_p[m]));
			e->c_rn[h]++;
		}
	}
	m = e->ring_pos;
	e->ring_z[m] = z;
	e->ring_r[m] = r;
	e->ring_p[m] = phi;
	e->ring_pos = m + 1u >= IDENT_INR_LAGS ? 0u : m + 1u;
	if (e->z_n < IDENT_INR_LAGS)
		e->z_n++;
	if (r_on && e->r_n < IDENT_INR_LAGS)
		e->r_n++;
}

void ident_inertia_gap(struct ident_inertia *e, const scalar_t tau_b[3], const scalar_t w_b[3], unsigned k)
{
	ident_inertia_process(e);
	lag_break(e);
	unsigned i = e->axis, j, l;
	ident_other_axes(i, &j, &l);
	scalar_t t0 = e->tau_prev, w0 = e->w_prev, p0 = e->ww_prev;
	scalar_t dtau = sc_sub(tau_b[i], t0), dw = sc_sub(w_b[i], w0);
	scalar_t dww = sc_sub(sc_mul(w_b[j], w_b[l]), p0);
	for (unsigned m = 1; m <= k; m++) {
		scalar_t f = sc_div(sc_from_int((int32_t)m), sc_from_int((int32_t)(k + 1u))); /* m / (k + 1) */
		inertia_filters(e, sc_add(t0, sc_mul(f, dtau)), sc_add(w0, sc_mul(f, dw)), sc_add(p0, sc_mul(f, dww)));
		e->wf_prev = e->svf_w.y;
		if (e->iv)
			filt_svf_update(&e->svf_z, e->z_in);
	}
}

/* a filter at rest at y0 (its state as filt_svf_init leaves it) */
static void svf_rest(struct filt_svf *f, scalar_t y0)
{
	f->y = y0;
	f->ydot = SC_ZERO;
	f->u_prev = y0;
}

void ident_inertia_restart(struct ident_inertia *e, const scalar_t tau_b[3], const scalar_t w_b[3])
{
	ident_inertia_process(e);
	lag_break(e);
	unsigned i = e->axis, j, k;
	ident_other_axes(i, &j, &k);
	e->tau_prev = tau_b[i];
	e->ww_prev = sc_mul(w_b[j], w_b[k]);
	e->w_prev = e->wf_prev = w_b[i];
	svf_rest(&e->svf_tau, e->tau_prev);
	svf_rest(&e->svf_ww, e->ww_prev);
	svf_rest(&e->svf_w, e->w_prev);
	svf_rest(&e->svf_z, e->z_in);
	svf_rest(&e->svf_d, e->d_in);
	e->d_prev = e->d_in;
}

void ident_inertia_update(struct ident_inertia *e, const scalar_t tau_b[3], const scalar_t w_b[3], bool excited)
{
	ident_inertia_process(e); /* a frame still waiting first: nothing lost or reordered */
	unsigned i = e->axis, j, k;
	ident_other_axes(i, &j, &k);
	inertia_filters(e, tau_b[i], w_b[i], sc_mul(w_b[j], w_b[k]));
	scalar_t y = sc_sub(e->svf_tau.y, sc_mul(e->coupling, e->svf_ww.y));
	scalar_t phi = sc_mul(sc_sub(e->svf_w.y, e->wf_prev), e->inv_dt);
	e->wf_prev = e->svf_w.y;
	e->q_phi = phi;
	e->q_y = y;
	e->q_excited = excited;
	e->q_iv = false;
	e->q_pending = true;
	e->n++;
	if (!e->iv)
		return;
	scalar_t z = filt_svf_update(&e->svf_z, e->z_in);
	e->q_z = z;
	e->q_iv = true;
	if (!excited)
		return;
	e->s_zy = sum_add(e->s_zy, sum_prod(z, y));
	e->s_zp = sum_add(e->s_zp, sum_prod(z, phi));
	if (e->sens)
		e->s_zd = sum_add(e->s_zd, sum_prod(z, e->svf_d.y));
	if (e->s_n < UINT32_MAX)
		e->s_n++;
	/* the residual about the IV ratio from here on (once the instrument has moved) */
	if (!e->r_on && e->s_n >= e->b_len)
		e->r_on = ident_inertia_ratio_sc(e, &e->i0);
}

/* Between frames: the RLS update and the IV std's lag products of the frame taken. */
void ident_inertia_process(struct ident_inertia *e)
{
	if (!e->q_pending)
		return;
	e->q_pending = false;
	rls_update(&e->rls, &e->q_phi, &e->q_y, e->q_excited);
	if (e->q_iv && e->q_excited)
		lag_sums(e, e->q_z, e->q_y, e->q_phi);
	else
		lag_break(e);
}

/* ---------------------------------------------------------------- validation */

void ident_fit_add(struct ident_fit *v, scalar_t y, scalar_t y_hat)
{
	if (!sc_isfinite(y) || !sc_isfinite(y_hat))
		return;
	if (v->n == 0u)
		v->y0 = y;
	if (v->n < UINT32_MAX)
		v->n++;
	scalar_t dy = sc_sub(y, v->y0), e = sc_sub(y, y_hat);
	v->s1 = sum_add(v->s1, sum_of_sc(dy));
	v->s2 = sum_add(v->s2, sum_prod(dy, dy));
	v->sse = sum_add(v->sse, sum_prod(e, e));
}
