/* ident_setup.c - the identification's work off the 90 Hz path, float in both builds:
 * initialisation (coefficients from exp), the float getters (estimates, standard
 * deviations, validation figures) and the acceptance rules. The per-frame estimators are
 * ident.c; see ident.h. */
#include "ident.h"
#include "fbits.h"

/* x > 0 and x == 0 of a scalar_t (an integer test in the fixed build) */
static bool scalar_pos(scalar_t x)
{
#if OCTO_FIXED
	return x > SC_ZERO;
#else
	return fb_pos(x);
#endif
}
static bool scalar_zero(scalar_t x)
{
#if OCTO_FIXED
	return x == SC_ZERO;
#else
	return fb_zero(x);
#endif
}

static float or_default(float v, float def) { return fb_pos(v) ? v : def; }

/* an ident_sum_t as float */
static float f_of_sum(ident_sum_t s)
{
#if OCTO_FIXED
	return (float)s * sc_pow2f(-QF_PROD_FRAC);
#else
	return s;
#endif
}

/* The frame period from dt_s. Q16.16 cannot hold 1/90 s: SC(1/90) is 2.4e-4 short, which
 * would put the inertia 2.4e-4 low (through 1 / dt) and the lag check 2.4e-4 off (through
 * the lag's coefficient). A dt_s within half an LSB of the period of a whole frame rate n
 * is taken as 1 / n exactly. */
static float frame_period(scalar_t dt_s)
{
	float dt = sc_to_float(sc_max(dt_s, SC(1e-4)));
	const int32_t ni = (int32_t)(1.0f / dt + 0.5f);
	float n = (float)ni;
#if OCTO_FIXED
	float half_lsb = sc_pow2f(-QF_SC_FRAC - 1);
#else
	float half_lsb = dt * sc_pow2f(-24);
#endif
	return ni >= 1 && fabsf(dt - 1.0f / n) <= 1.01f * half_lsb ? 1.0f / n : dt;
}

/* ---------------------------------------------------------------- rotor coefficients */

void ident_rotor_init(struct ident_rotor *r, const struct ident_rotor_cfg *cfg)
{
	r->mot_tau_s = cfg->mot_tau_s;
	r->curve = cfg->curve;
	filt_delay_init(&r->delay, cfg->delay_frames, cfg->thr0);
	filt_lag_init(&r->lag, cfg->mot_tau_s, cfg->dt_s, cfg->thr0);
	struct rls_config c;
	rls_default_config(&c); /* one parameter, lambda 1 */
	c.n_outputs = 2;
	c.p0 = or_default(cfg->p0, 1e6f);
	c.theta0[0][0] = cfg->kf0;
	c.theta0[1][0] = cfg->ktau0;
	rls_init(&r->lagaware, &c);
	rls_init(&r->plain, &c);
	/* the sensitivity's: two parameters, one output (theta0[1] as the others') */
	struct rls_config cs;
	rls_default_config(&cs);
	cs.n_params = 2;
	cs.p0 = c.p0;
	cs.theta0[0][0] = cfg->kf0;
	cs.theta0[1][0] = cfg->ktau0;
	rls_init(&r->sens, &cs);
	r->dphi_dtau = SC_ZERO;
	float tm = sc_to_float(cfg->mot_tau_s), dt = scalar_pos(cfg->dt_s) ? frame_period(cfg->dt_s) : 0.0f;
	/* the lag's coefficient from the exact frame period (filt_lag_init's is from dt_s) */
	r->dalpha_dtau = SC_ZERO;
	if (fb_pos(tm) && fb_pos(dt)) {
		const float ex = expf(-dt / tm);
		r->lag.alpha = sc_from_float(1.0f - ex);
		r->dalpha_dtau = sc_from_float(-(dt / (tm * tm)) * ex);
	}
	r->phi = cfg->thr0;
	r->y_prev[0] = r->y_prev[1] = SC_ZERO;
	r->have_prev = false;
	r->n = 0;
	r->q_pending = false;
}

float ident_rotor_est(struct ident_rotor *r, unsigned which)
{
	ident_rotor_process(r);
	return rls_estimate_f(&r->lagaware, which, 0);
}

float ident_rotor_sd(struct ident_rotor *r, unsigned which)
{
	ident_rotor_process(r);
	return rls_std(&r->lagaware, which, 0);
}

float ident_rotor_plain(struct ident_rotor *r, unsigned which)
{
	ident_rotor_process(r);
	return rls_estimate_f(&r->plain, which, 0);
}

/* estimates of one 1-parameter RLS with two outputs and their std: rls_std's arithmetic
 * with P_00 and the degrees of freedom computed once */
static void read_1x2(const struct rls *q, float est[2], float sd[2])
{
	float p = rls_cov_diag(q, 0);
	for (unsigned o = 0; o < 2u; o++) {
		est[o] = rls_estimate_f(q, o, 0);
		float v = p * rls_residual_var(q, o);
		sd[o] = fb_pos(v) ? sqrtf(v) : 0.0f;
	}
}

void ident_rotor_read(struct ident_rotor *r, float est[4], float sd[4])
{
	ident_rotor_process(r);
	read_1x2(&r->lagaware, est, sd);
	read_1x2(&r->plain, est + 2, sd + 2);
}

float ident_rotor_tau_check(struct ident_rotor *r)
{
	ident_rotor_process(r);
	if (scalar_zero(r->dalpha_dtau) || r->sens.n_updates < 2u)
		return -1.0f;
	float k = rls_estimate_f(&r->sens, 0, 0), kd = rls_estimate_f(&r->sens, 0, 1);
	if (!fb_pos(k) || !fb_finite(kd))
		return -1.0f;
	float t = sc_to_float(r->mot_tau_s) + kd / k;
	return fb_pos(t) ? t : 0.0f;
}

/* ---------------------------------------------------------------- inertia */

scalar_t ident_torque_weight(scalar_t tau_m_s, scalar_t dt_s)
{
	float tm = sc_to_float(tau_m_s), dt = sc_to_float(dt_s);
	if (!fb_pos(tm) || !fb_pos(dt))
		return SC(1.0);
	/* alpha = 1 / (1 - exp(-x)) - 1 / x, x = dt / tau_m; series for small x (cancellation) */
	float x = dt / tm;
	/* x < 0.1 by its bits (x is positive, not NaN) */
	float w = fb_bits(x) < fb_bits(0.1f) ? 0.5f + x / 12.0f - x * x * x / 720.0f
					     : 1.0f / (1.0f - expf(-x)) - 1.0f / x;
	return sc_from_float(w);
}

void ident_inertia_init(struct ident_inertia *e, unsigned axis, scalar_t wc_rps, scalar_t zeta, scalar_t dt_s,
			scalar_t alpha, const scalar_t inertia[3], const scalar_t w0[3], const scalar_t tau0[3])
{
	unsigned i = axis > 2u ? 2u : axis, j, k;
	ident_other_axes(i, &j, &k);
	e->axis = i;
	/* tau_i = I_i w_dot_i + (I_k - I_j) w_j w_k */
	e->coupling = sc_sub(inertia[k], inertia[j]);
	e->alpha = sc_clamp(alpha, SC(0.0), SC(1.0));
	e->inv_dt = sc_from_float(1.0f / frame_period(dt_s));
	e->tau_prev = tau0[i];
	e->ww_prev = sc_mul(w0[j], w0[k]);
	e->wf_prev = w0[i];
	e->w_prev = w0[i];
	filt_svf_init(&e->svf_tau, wc_rps, zeta, dt_s, tau0[i]);
	filt_svf_init(&e->svf_w, wc_rps, zeta, dt_s, w0[i]);
	filt_svf_init(&e->svf_ww, wc_rps, zeta, dt_s, e->ww_prev);
	struct rls_config c;
	rls_default_config(&c); /* one parameter, one output, lambda 1, p0 1e4 */
	c.theta0[0][0] = sc_to_float(inertia[i]);
	rls_init(&e->rls, &c);
	float wdt = sc_to_float(wc_rps) * sc_to_float(dt_s), z4 = 4.0f * sc_to_float(zeta);
	e->sd_scale = fb_pos(wdt) && wdt < z4 ? sqrtf(z4 / wdt) : 1.0f;
	e->n = 0;
	e->q_pending = false;
	filt_svf_init(&e->svf_z, wc_rps, zeta, dt_s, SC_ZERO);
	e->z_in = SC_ZERO;
	e->iv = false;
	e->s_zy = e->s_zp = (ident_sum_t)0;
	e->s_n = 0;
	filt_svf_init(&e->svf_d, wc_rps, zeta, dt_s, SC_ZERO);
	e->d_in = e->d_prev = SC_ZERO;
	e->s_zd = (ident_sum_t)0;
	e->sens = false;
	float dt = sc_to_float(dt_s);
	float len = fb_pos(dt) ? 0.5f / dt + 0.5f : 45.0f; /* 0.5 s of updates */
	/* len is positive, not NaN: compared by its bits */
	const uint32_t lb = fb_bits(len);
	e->b_len = lb < fb_bits(1.0f) ? 1u : (lb > fb_bits(1e6f) ? 1000000u : (uint32_t)len);
	/* the residual's correlation: the SVF's 5 time constants 1 / (zeta wc), in frames */
	float zw = sc_to_float(zeta) * sc_to_float(wc_rps) * dt, nl = fb_pos(zw) ? 5.0f / zw + 1.0f : 0.0f;
	e->lags = fb_pos(nl) && fb_bits(nl) < fb_bits((float)IDENT_INR_LAGS) ? (uint32_t)nl : IDENT_INR_LAGS;
	e->i0 = SC_ZERO;
	e->r_on = false;
	e->ring_pos = e->z_n = e->r_n = 0;
	for (uint32_t h = 0; h <= IDENT_INR_LAGS; h++) {
		e->c_zz[h] = e->c_rr[h] = e->c_rp[h] = e->c_pp[h] = (ident_sum_t)0;
		e->c_rn[h] = 0;
	}
	e->q_iv = false;
}

/* the IV estimate once its first 0.5 s are in (before, least squares: a live value); out of
 * line: its copies (two 64-bit tests) cost more flash than the calls */
__attribute__((noinline)) static bool iv_ready(const struct ident_inertia *e)
{
#if OCTO_FIXED
	return e->iv && e->r_on && e->s_zp != 0;
#else
	return e->iv && e->r_on && !fb_zero(e->s_zp);
#endif
}

bool ident_inertia_ratio_sc(const struct ident_inertia *e, scalar_t *i0)
{
	float zp = f_of_sum(e->s_zp), r = fb_zero(zp) ? NAN : f_of_sum(e->s_zy) / zp;
	if (!fb_finite(r))
		return false;
	*i0 = sc_from_float(r);
	return true;
}

float ident_inertia_est(struct ident_inertia *e)
{
	ident_inertia_process(e);
	if (!iv_ready(e))
		return rls_estimate_f(&e->rls, 0, 0);
	return f_of_sum(e->s_zy) / f_of_sum(e->s_zp);
}

float ident_inertia_sens_rel(struct ident_inertia *e)
{
	ident_inertia_process(e);
	if (!e->sens || !iv_ready(e))
		return 0.0f;
	float zy = f_of_sum(e->s_zy), r = fb_zero(zy) ? 0.0f : f_of_sum(e->s_zd) / zy;
	return fb_finite(r) ? r : 0.0f;
}

/* var(I) (sum z phi)^2 = sum_h w_h Z(h) R(h) (ident.h), R(h) the residual's mean lag product
 * about est: r = r0 - d phi with r0 = y - i0 phi, d = est - i0. The sums are about i0, the
 * ratio after the first 0.5 s, so d is small and rr - d rp + d^2 pp keeps its digits. */
static float iv_var_sum(const struct ident_inertia *e, float est)
{
	float d = est - sc_to_float(e->i0), v = 0.0f;
	for (uint32_t h = 0; h <= e->lags; h++) {
		if (e->c_rn[h] == 0u)
			break;
		float rr = f_of_sum(e->c_rr[h]) - d * f_of_sum(e->c_rp[h]) + d * d * f_of_sum(e->c_pp[h]);
		v += (h == 0u ? 1.0f : 2.0f) * f_of_sum(e->c_zz[h]) * rr / (float)e->c_rn[h];
	}
	return v;
}

float ident_inertia_sd(struct ident_inertia *e)
{
	ident_inertia_process(e);
	if (!iv_ready(e))
		return e->sd_scale * rls_std(&e->rls, 0, 0);
	float est = ident_inertia_est(e);
	if (!fb_finite(est))
		return NAN;
	float v = iv_var_sum(e, est);
	return sqrtf(fb_pos(v) ? v : 0.0f) / fabsf(f_of_sum(e->s_zp));
}

/* The verdict on est +/- sd within [lo, hi]: not finite, out of range, relative std sd / |est|
 * not below rsd_max (negative sd: uncertain), else accepted; shared by both acceptance rules */
__attribute__((noinline)) static enum ident_verdict verdict(float est, float sd, float lo, float hi, float rsd_max)
{
	if (!fb_finite(est) || !fb_finite(sd))
		return IDENT_NOT_FINITE;
	if (!(est >= lo && est <= hi))
		return IDENT_OUT_OF_RANGE;
	/* |est| with -0 kept (the inertia rule divides by est): est >= 0, finite, by its bits */
	float rsd = sd / (fb_bits(est) <= 0x80000000u ? est : -est);
	if (fb_neg(sd) || !(rsd < rsd_max))
		return IDENT_UNCERTAIN;
	return IDENT_ACCEPT;
}

enum ident_verdict ident_inertia_accept(float est, float sd, float mass_kg, float arm_l_m, float rsd_max, float *lo,
					float *hi, float *raise)
{
	float ml2 = mass_kg * arm_l_m * arm_l_m;
	*lo = IDENT_INR_LO * ml2;
	*hi = IDENT_INR_HI * ml2;
	*raise = 1.0f;
	const enum ident_verdict v = verdict(est, sd, *lo, *hi, rsd_max);
	if (v == IDENT_UNCERTAIN) {
		float rsd = sd / est;
		*raise = fb_pos(rsd_max) && fb_finite(rsd) ? rsd / rsd_max : 0.0f;
	}
	return v;
}

/* ---------------------------------------------------------------- validation */

void ident_fit_init(struct ident_fit *v)
{
	v->n = 0;
	v->y0 = SC_ZERO;
	v->s1 = v->s2 = v->sse = (ident_sum_t)0;
}

/* sum (y - mean)^2 = s2 - s1^2 / n and sum y^2 = s2 + 2 y0 s1 + n y0^2 (y - y0 summed) */
static float fit_m2(const struct ident_fit *v)
{
	float s1 = f_of_sum(v->s1);
	return v->n > 0u ? f_of_sum(v->s2) - s1 * s1 / (float)v->n : 0.0f;
}

float ident_fit_ne(const struct ident_fit *v)
{
	float y0 = sc_to_float(v->y0);
	float syy = f_of_sum(v->s2) + 2.0f * y0 * f_of_sum(v->s1) + (float)v->n * y0 * y0;
	return fb_pos(syy) ? sqrtf(f_of_sum(v->sse) / syy) : 0.0f;
}

float ident_fit_pct(const struct ident_fit *v)
{
	float m2 = fit_m2(v);
	return fb_pos(m2) ? 100.0f * (1.0f - sqrtf(f_of_sum(v->sse) / m2)) : 0.0f;
}

/* ---------------------------------------------------------------- acceptance */

enum ident_verdict ident_accept(float est, float sd, float nominal, float rsd_max)
{
	float lo = IDENT_RANGE_LO * nominal, hi = IDENT_RANGE_HI * nominal;
	if (lo > hi) {
		float t = lo;
		lo = hi;
		hi = t;
	}
	const enum ident_verdict v = verdict(est, sd, lo, hi, rsd_max);
	return v != IDENT_NOT_FINITE && fb_zero(est) ? IDENT_OUT_OF_RANGE : v;
}

const char *ident_verdict_text(enum ident_verdict v)
{
	switch (v) {
	case IDENT_ACCEPT: return "accepted";
	case IDENT_NOT_FINITE: return "not finite";
	case IDENT_OUT_OF_RANGE: return "out of range";
	case IDENT_UNCERTAIN: return "std too large";
	}
	return "?";
}
