/* ident.c - in-flight identification estimators; see ident.h. */
#include "ident.h"

static bool finite_f(float x) { return isfinite(x); }

static float or_default(float v, float def) { return v > 0.0f ? v : def; }

/* ---------------------------------------------------------------- rotor coefficients */

void ident_rotor_init(struct ident_rotor *r, const struct ident_rotor_cfg *cfg)
{
	r->cfg = *cfg;
	filt_delay_init(&r->delay, cfg->delay_frames, cfg->thr0);
	filt_lag_init(&r->lag, cfg->mot_tau_s, cfg->dt_s, cfg->thr0);
	struct rls_config c;
	rls_default_config(&c);
	c.n_params = 1;
	c.n_outputs = 2;
	c.lambda = 1.0f;
	c.p0 = or_default(cfg->p0, 1e6f);
	c.theta0[0][0] = cfg->kf0;
	c.theta0[1][0] = cfg->ktau0;
	rls_init(&r->lagaware, &c);
	rls_init(&r->plain, &c);
	struct rls_config cs = c;
	cs.n_params = 2;
	cs.n_outputs = 1;
	cs.theta0[0][0] = cfg->kf0;
	cs.theta0[0][1] = 0.0f;
	rls_init(&r->sens, &cs);
	r->dphi_dtau = SC_ZERO;
	float tm = sc_to_float(cfg->mot_tau_s), dt = sc_to_float(cfg->dt_s);
	r->dalpha_dtau = tm > 0.0f && dt > 0.0f ? sc_from_float(-(dt / (tm * tm)) * expf(-dt / tm)) : SC_ZERO;
	r->phi = cfg->thr0;
	r->y_prev[0] = r->y_prev[1] = SC_ZERO;
	r->have_prev = false;
	r->n = 0;
}

/* g(s) = (1 - c) s + c s^2 */
static scalar_t curve_g(scalar_t c, scalar_t s)
{
	return sc_add(sc_mul(sc_sub(SC(1.0), c), s), sc_mul(c, sc_mul(s, s)));
}

/* delay, lag and sensitivity one frame on; returns the lagged throttle s */
static scalar_t rotor_advance(struct ident_rotor *r, scalar_t thr_sent_prev)
{
	scalar_t u = filt_delay_update(&r->delay, thr_sent_prev);
	scalar_t s_prev = r->lag.y;
	scalar_t s = filt_lag_update(&r->lag, u);
	/* sensitivity of s to tau_m (the lag check) */
	r->dphi_dtau = sc_add(sc_mul(sc_sub(SC(1.0), r->lag.alpha), r->dphi_dtau),
			      sc_mul(r->dalpha_dtau, sc_sub(u, s_prev)));
	return s;
}

void ident_rotor_hold(struct ident_rotor *r, scalar_t thr_sent_prev)
{
	rotor_advance(r, thr_sent_prev);
	r->have_prev = false;
}

void ident_rotor_update(struct ident_rotor *r, scalar_t thr_sent_prev, scalar_t f_meas,
			scalar_t tau_meas, bool excited)
{
	/* lag-aware: the previous frame's throttle, delayed and lagged, for this measurement */
	scalar_t s = rotor_advance(r, thr_sent_prev);
	r->phi = curve_g(r->cfg.curve, s);
	scalar_t y[2] = {f_meas, tau_meas};
	rls_update(&r->lagaware, &r->phi, y, excited);

	/* the lag check: g'(s) = 1 - c + 2 c s times the sensitivity of s */
	scalar_t gp = sc_add(sc_sub(SC(1.0), r->cfg.curve), sc_mul(sc_add(r->cfg.curve, r->cfg.curve), s));
	scalar_t phi2[2] = {r->phi, sc_mul(gp, r->dphi_dtau)};
	if (r->dalpha_dtau != SC_ZERO)
		rls_update(&r->sens, phi2, y, excited);

	/* plain (eq. 18-20): the previous measurement against the command of its own frame,
	 * which is the throttle sent on the previous frame */
	if (r->have_prev) {
		scalar_t phi_raw = curve_g(r->cfg.curve, thr_sent_prev);
		rls_update(&r->plain, &phi_raw, r->y_prev, excited);
	}
	r->y_prev[0] = f_meas;
	r->y_prev[1] = tau_meas;
	r->have_prev = true;
	r->n++;
}

float ident_rotor_est(const struct ident_rotor *r, unsigned which)
{
	return rls_estimate_f(&r->lagaware, which, 0);
}

float ident_rotor_sd(const struct ident_rotor *r, unsigned which)
{
	return rls_std(&r->lagaware, which, 0);
}

float ident_rotor_plain(const struct ident_rotor *r, unsigned which)
{
	return rls_estimate_f(&r->plain, which, 0);
}

float ident_rotor_plain_sd(const struct ident_rotor *r, unsigned which)
{
	return rls_std(&r->plain, which, 0);
}

/* estimates of one 1-parameter RLS with two outputs and their std: rls_std's arithmetic
 * with P_00 and the degrees of freedom computed once */
static void read_1x2(const struct rls *q, float est[2], float sd[2])
{
	float p = rls_cov_diag(q, 0);
	for (unsigned o = 0; o < 2u; o++) {
		est[o] = rls_estimate_f(q, o, 0);
		float v = p * rls_residual_var(q, o);
		sd[o] = v > 0.0f ? sqrtf(v) : 0.0f;
	}
}

void ident_rotor_read(const struct ident_rotor *r, float est[4], float sd[4])
{
	read_1x2(&r->lagaware, est, sd);
	read_1x2(&r->plain, est + 2, sd + 2);
}

float ident_rotor_tau_check(const struct ident_rotor *r)
{
	if (r->dalpha_dtau == SC_ZERO || r->sens.n_updates < 2u)
		return -1.0f;
	float k = rls_estimate_f(&r->sens, 0, 0), kd = rls_estimate_f(&r->sens, 0, 1);
	if (!(k > 0.0f) || !finite_f(kd))
		return -1.0f;
	float t = sc_to_float(r->cfg.mot_tau_s) + kd / k;
	return t > 0.0f ? t : 0.0f;
}

float ident_plain_bias(float e_d2, float e_d_dlag, float t_hover)
{
	float den = t_hover * t_hover + e_d2;
	return den > 0.0f ? -(e_d2 - e_d_dlag) / den : 0.0f;
}

/* ---------------------------------------------------------------- body torque */

void ident_body_torque(scalar_t arm_l_m, const scalar_t f[IDENT_ROTORS],
		       const scalar_t tm[IDENT_ROTORS], scalar_t tau_out[3])
{
	/* eq. (14) in units of l: tau_x row [0 -s -1 -s 0 s 1 s], tau_y row [-1 -s 0 s 1 s 0 -s] */
	const scalar_t s = SC(0.70710678118654752);
	scalar_t tx = sc_add(sc_mul(s, sc_sub(sc_add(f[5], f[7]), sc_add(f[1], f[3]))),
			     sc_sub(f[6], f[2]));
	scalar_t ty = sc_add(sc_mul(s, sc_sub(sc_add(f[3], f[5]), sc_add(f[1], f[7]))),
			     sc_sub(f[4], f[0]));
	scalar_t tz = SC_ZERO;
	for (int j = 0; j < IDENT_ROTORS; j += 2)
		tz = sc_add(tz, sc_sub(tm[j], tm[j + 1]));
	tau_out[0] = sc_mul(arm_l_m, tx);
	tau_out[1] = sc_mul(arm_l_m, ty);
	tau_out[2] = tz;
}

void ident_body_torque_mixer(const struct mixer *m, const scalar_t f[IDENT_ROTORS],
			     const scalar_t tm[IDENT_ROTORS], scalar_t tau_out[3])
{
	scalar_t w[MIXER_N_AXES];
	mixer_wrench(m, f, w);
	scalar_t tz = SC_ZERO;
	for (int j = 0; j < IDENT_ROTORS; j++) {
		scalar_t g = m->gn[3][j];   /* row-scaled Gamma: its sign is the yaw sign */
		if (g > SC_ZERO)
			tz = sc_add(tz, tm[j]);
		else if (g < SC_ZERO)
			tz = sc_sub(tz, tm[j]);
	}
	tau_out[0] = w[1];
	tau_out[1] = w[2];
	tau_out[2] = tz;
}

/* ---------------------------------------------------------------- inertia */

static void other_axes(unsigned i, unsigned *j, unsigned *k)
{
	*j = (i + 1u) % 3u;
	*k = (i + 2u) % 3u;
}

scalar_t ident_torque_weight(scalar_t tau_m_s, scalar_t dt_s)
{
	float tm = sc_to_float(tau_m_s), dt = sc_to_float(dt_s);
	if (!(tm > 0.0f) || !(dt > 0.0f))
		return SC(1.0);
	/* alpha = 1 / (1 - exp(-x)) - 1 / x, x = dt / tau_m; series for small x (cancellation) */
	float x = dt / tm;
	float w = x < 0.1f ? 0.5f + x / 12.0f - x * x * x / 720.0f : 1.0f / (1.0f - expf(-x)) - 1.0f / x;
	return sc_from_float(w);
}

void ident_inertia_init(struct ident_inertia *e, unsigned axis, scalar_t wc_rps, scalar_t zeta,
			scalar_t dt_s, scalar_t alpha, const scalar_t inertia[3], const scalar_t w0[3],
			const scalar_t tau0[3])
{
	unsigned i = axis > 2u ? 2u : axis, j, k;
	other_axes(i, &j, &k);
	e->axis = i;
	/* tau_i = I_i w_dot_i + (I_k - I_j) w_j w_k */
	e->coupling = sc_sub(inertia[k], inertia[j]);
	e->alpha = sc_clamp(alpha, SC(0.0), SC(1.0));
	e->inv_dt = sc_div(SC(1.0), sc_max(dt_s, SC(1e-4)));
	e->tau_prev = tau0[i];
	e->ww_prev = sc_mul(w0[j], w0[k]);
	e->wf_prev = w0[i];
	filt_svf_init(&e->svf_tau, wc_rps, zeta, dt_s, tau0[i]);
	filt_svf_init(&e->svf_w, wc_rps, zeta, dt_s, w0[i]);
	filt_svf_init(&e->svf_ww, wc_rps, zeta, dt_s, e->ww_prev);
	struct rls_config c;
	rls_default_config(&c);
	c.n_params = 1;
	c.n_outputs = 1;
	c.lambda = 1.0f;
	c.p0 = 1e4f;
	c.theta0[0][0] = sc_to_float(inertia[i]);
	rls_init(&e->rls, &c);
	float wdt = sc_to_float(wc_rps) * sc_to_float(dt_s), z4 = 4.0f * sc_to_float(zeta);
	e->sd_scale = wdt > 0.0f && wdt < z4 ? sqrtf(z4 / wdt) : 1.0f;
	e->n = 0;
	filt_svf_init(&e->svf_z, wc_rps, zeta, dt_s, SC_ZERO);
	e->z_in = SC_ZERO;
	e->iv = false;
	e->s_zy = e->s_zp = e->s_n = 0.0f;
	e->b_zy = e->b_zp = e->b_n = 0.0f;
	e->s_aa = e->s_ab = e->s_bb = 0.0f;
	float dt = sc_to_float(dt_s);
	e->b_len = dt > 0.0f ? 0.5f / dt : 45.0f;   /* 0.5 s of updates */
}

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

void ident_inertia_update(struct ident_inertia *e, const scalar_t tau_b[3], const scalar_t w_b[3],
			  bool excited)
{
	unsigned i = e->axis, j, k;
	other_axes(i, &j, &k);
	scalar_t ww = sc_mul(w_b[j], w_b[k]);
	filt_svf_update(&e->svf_tau, weigh(e->alpha, tau_b[i], e->tau_prev));
	/* the gyroscopic product is smooth: its frame mean is the trapezoid's */
	filt_svf_update(&e->svf_ww, weigh(SC(0.5), ww, e->ww_prev));
	filt_svf_update(&e->svf_w, w_b[i]);
	e->tau_prev = tau_b[i];
	e->ww_prev = ww;
	scalar_t y = sc_sub(e->svf_tau.y, sc_mul(e->coupling, e->svf_ww.y));
	scalar_t phi = sc_mul(sc_sub(e->svf_w.y, e->wf_prev), e->inv_dt);
	e->wf_prev = e->svf_w.y;
	rls_update(&e->rls, &phi, &y, excited);
	e->n++;
	if (!e->iv)
		return;
	float z = sc_to_float(filt_svf_update(&e->svf_z, e->z_in));
	if (!excited)
		return;
	float zy = z * sc_to_float(y), zp = z * sc_to_float(phi);
	e->s_zy += zy;
	e->s_zp += zp;
	e->s_n += 1.0f;
	e->b_zy += zy;
	e->b_zp += zp;
	e->b_n += 1.0f;
	if (e->b_n >= e->b_len) {
		e->s_aa += e->b_zy * e->b_zy;
		e->s_ab += e->b_zy * e->b_zp;
		e->s_bb += e->b_zp * e->b_zp;
		e->b_zy = e->b_zp = e->b_n = 0.0f;
	}
}

/* the IV estimate once a first block is complete (before, least squares: a live value) */
static bool iv_ready(const struct ident_inertia *e) { return e->iv && e->s_bb > 0.0f && e->s_zp != 0.0f; }

float ident_inertia_est(const struct ident_inertia *e)
{
	if (!iv_ready(e))
		return rls_estimate_f(&e->rls, 0, 0);
	return e->s_zy / e->s_zp;
}

float ident_inertia_sd(const struct ident_inertia *e)
{
	if (!iv_ready(e))
		return e->sd_scale * rls_std(&e->rls, 0, 0);
	float est = ident_inertia_est(e);
	if (!finite_f(est))
		return NAN;
	/* sum over the blocks of (A_b - I B_b)^2, A_b = sum_b z y, B_b = sum_b z phi */
	float v = e->s_aa - 2.0f * est * e->s_ab + est * est * e->s_bb;
	return sqrtf(v > 0.0f ? v : 0.0f) / fabsf(e->s_zp);
}

enum ident_verdict ident_inertia_accept(float est, float sd, float mass_kg, float arm_l_m, float rsd_max,
					float *lo, float *hi, float *raise)
{
	float ml2 = mass_kg * arm_l_m * arm_l_m;
	*lo = IDENT_INR_LO * ml2;
	*hi = IDENT_INR_HI * ml2;
	*raise = 1.0f;
	if (!finite_f(est) || !finite_f(sd))
		return IDENT_NOT_FINITE;
	if (!(est >= *lo && est <= *hi))
		return IDENT_OUT_OF_RANGE;
	float rsd = sd / est;
	if (sd < 0.0f || !(rsd < rsd_max)) {
		*raise = rsd_max > 0.0f && finite_f(rsd) ? rsd / rsd_max : 0.0f;
		return IDENT_UNCERTAIN;
	}
	return IDENT_ACCEPT;
}

/* ---------------------------------------------------------------- validation */

void ident_fit_init(struct ident_fit *v)
{
	v->n = v->mean = v->m2 = v->sse = v->syy = 0.0f;
}

void ident_fit_add(struct ident_fit *v, scalar_t y_s, scalar_t y_hat_s)
{
	float y = sc_to_float(y_s), yh = sc_to_float(y_hat_s);
	if (!finite_f(y) || !finite_f(yh))
		return;
	v->n += 1.0f;
	float d = y - v->mean;
	v->mean += d / v->n;
	v->m2 += d * (y - v->mean);
	v->sse += (y - yh) * (y - yh);
	v->syy += y * y;
}

float ident_fit_ne(const struct ident_fit *v)
{
	return v->syy > 0.0f ? sqrtf(v->sse / v->syy) : 0.0f;
}

float ident_fit_pct(const struct ident_fit *v)
{
	return v->m2 > 0.0f ? 100.0f * (1.0f - sqrtf(v->sse / v->m2)) : 0.0f;
}

/* ---------------------------------------------------------------- acceptance */

enum ident_verdict ident_accept(float est, float sd, float nominal, float rsd_max)
{
	if (!finite_f(est) || !finite_f(sd))
		return IDENT_NOT_FINITE;
	float lo = IDENT_RANGE_LO * nominal, hi = IDENT_RANGE_HI * nominal;
	if (lo > hi) {
		float t = lo;
		lo = hi;
		hi = t;
	}
	if (!(est >= lo && est <= hi) || est == 0.0f)
		return IDENT_OUT_OF_RANGE;
	float rsd = sd / (est > 0.0f ? est : -est);
	if (sd < 0.0f || !(rsd < rsd_max))
		return IDENT_UNCERTAIN;
	return IDENT_ACCEPT;
}

const char *ident_verdict_text(enum ident_verdict v)
{
	switch (v) {
	case IDENT_ACCEPT:
		return "accepted";
	case IDENT_NOT_FINITE:
		return "not finite";
	case IDENT_OUT_OF_RANGE:
		return "out of range";
	case IDENT_UNCERTAIN:
		return "std too large";
	}
	return "?";
}
