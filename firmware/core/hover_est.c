/* hover_est.c - see hover_est.h for the model, the filter and the units. */
#include "hover_est.h"

#include "est_ops.h"
#include "scalar_ops.h"

#define P_MAX_PCT2 SC(10000.0) /* sd 100 %: what the filter starts from at most */

struct hover_est_params hover_est_params_default(void)
{
	struct hover_est_params p;
	p.u_min = SC(0.02);
	p.u_max = SC(0.95); /* up to a thrust-to-weight of 1.05: the take-off judges it (NAV_TW_MIN) */
	p.sigma_u0 = SC(1.0);
	p.sigma_acc = SC(0.5);
	p.sigma_imu = SC(0.3);
	p.q_rel = SC(0.003);
	p.tau_s = SC(0.1);
	p.tau_m_s = SC_ZERO;
	p.drift_per_s = SC_ZERO;
	p.gate_sigma = SC(4.0);
	p.spool_rate = SC(0.6);
	p.g_mps2 = SC(9.796);
	return p;
}

static scalar_t p0_pct2(const struct hover_est_params *p)
{
	scalar_t sd = sc_mul(SC(100.0), p->sigma_u0);
	return sc_min(sc_sq(sd), P_MAX_PCT2);
}

/* theta within [1/u_max, 1/u_min] */
static scalar_t clamp_theta(const struct hover_est *s, scalar_t th) { return sc_clamp(th, s->theta_lo, s->theta_hi); }

void hover_est_init(struct hover_est *s, const struct hover_est_params *p, scalar_t u0)
{
	s->p = *p;
	if (!(s->p.u_min > SC_ZERO))
		s->p.u_min = SC(0.02);
	if (!(s->p.u_max > s->p.u_min))
		s->p.u_max = sc_max(SC(0.8), s->p.u_min);
	if (!(s->p.tau_s > SC_ZERO))
		s->p.tau_s = SC(0.1);
	s->theta_lo = sc_div(SC(1.0), s->p.u_max);
	s->theta_hi = sc_div(SC(1.0), s->p.u_min);
	s->r_tau = sc_recip_of(s->p.tau_s);
	if (!(s->p.tau_m_s > SC_ZERO))
		s->p.tau_m_s = SC_ZERO;
	s->q2 = sc_sq(sc_mul(SC(100.0), s->p.q_rel));
	s->y_min = sc_mul(SC(0.05), s->p.g_mps2);
	s->r_sd0 = sc_mul(SC(100.0), s->p.sigma_acc);
	s->r_sd0_imu = sc_mul(SC(100.0), s->p.sigma_imu);
	s->gate2 = sc_sq(s->p.gate_sigma);
	s->al_dt = SC_ZERO;
	s->al = SC_ZERO;
	s->am = SC_ZERO;
	s->k_last = SC_ZERO;
	s->th_ref = SC(1.0);
	for (uint32_t i = 0; i < HOVER_EST_BLK_AVG; i++)
		s->w_x[i] = SC_ZERO;
	s->u_m = SC_ZERO;
	u0 = sc_isfinite(u0) ? sc_clamp(u0, s->p.u_min, s->p.u_max) : s->p.u_min;
	s->theta = clamp_theta(s, sc_div(SC(1.0), u0));
	s->p_pct2 = p0_pct2(&s->p);
	s->v_f = SC_ZERO;
	s->uc_f = SC_ZERO;
	s->primed = false;
	s->acc = false;
	s->gated_s = SC_ZERO;
	s->gated_sign = 0;
	s->updates = 0;
	s->rejected = 0;
	s->v_pct2 = s->p_pct2;
	s->r_eff = s->e_mean = s->b_sum = s->b_prev = SC_ZERO;
	s->b_n = s->b_count = 0;
	s->b_settled = false;
}

/* inline in each caller (the per-frame track and update paths): no call around a few tests */
static inline SC_ALWAYS_INLINE bool inputs_ok(scalar_t vz, scalar_t u, scalar_t c, scalar_t dt)
{
	return sc_isfinite(vz) && sc_isfinite(u) && sc_isfinite(c) && sc_isfinite(dt) && dt > SC_ZERO && dt < SC(1.0);
}

/* Advances the state-variable filter; returns the filtered acceleration. acc: vz is the
 * accelerometer's specific force and c is 1 (then the filtered input is returned). Inline in
 * each caller: a track discards the result, and its quotient is then not computed. */
static inline SC_ALWAYS_INLINE scalar_t filters(struct hover_est *s, scalar_t vz, scalar_t u, scalar_t c, scalar_t dt,
						bool acc)
{
	scalar_t uc = acc ? u : est_mul_unit(u, c); /* c = cos(tilt) in [0, 1] (est_mul_unit: exact for any) */
	if (acc != s->acc) {                        /* another kind of input: the filters start again */
		s->acc = acc;
		s->primed = false;
	}
	if (!s->primed) {
		s->v_f = vz;
		s->uc_f = s->u_m = uc;
		s->primed = true;
		return SC_ZERO;
	}
	/* backward Euler of 1 / (tau s + 1): x += dt / (tau + dt) (in - x) */
	if (dt != s->al_dt) {
		s->al_dt = dt;
		s->al = sc_div(dt, sc_add(s->p.tau_s, dt));
		/* the lag over a frame of held throttle, 1 - exp(-dt / tau_m), to second order:
		 * dt / (tau_m + dt / 2) */
		s->am = s->p.tau_m_s > SC_ZERO ? sc_min(sc_div(dt, sc_add(s->p.tau_m_s, sc_mul(dt, SC(0.5)))), SC(1.0))
					       : SC(1.0);
	}
	if (acc) { /* the accelerometer reads the thrust the motors' lag lets through */
		s->u_m = sc_add(s->u_m, est_mul_unit(sc_sub(uc, s->u_m), s->am));
		uc = s->u_m;
	}
	scalar_t al = s->al;
	s->v_f = sc_add(s->v_f, est_mul_unit(sc_sub(vz, s->v_f), al)); /* al in [0, 1] */
	s->uc_f = sc_add(s->uc_f, est_mul_unit(sc_sub(uc, s->uc_f), al));
	return acc ? s->v_f : sc_div_r(sc_sub(vz, s->v_f), s->p.tau_s, &s->r_tau);
}

void hover_est_track(struct hover_est *s, scalar_t vz_mps, scalar_t u, scalar_t cos_tilt, scalar_t dt_s)
{
	if (!inputs_ok(vz_mps, u, cos_tilt, dt_s)) {
		s->primed = false;
		return;
	}
	(void)filters(s, vz_mps, u, cos_tilt, dt_s, false);
}

void hover_est_track_acc(struct hover_est *s, scalar_t a_mps2, scalar_t u, scalar_t dt_s)
{
	if (!inputs_ok(a_mps2, u, SC(1.0), dt_s)) {
		s->primed = false;
		return;
	}
	(void)filters(s, a_mps2, u, SC(1.0), dt_s, true);
}

/* The error's variance as the data show it (hover_est.h), for an innovation e_pct taken
 * with gain k at period dt: the block of innovations, and V through the gain, with the
 * filter's own posterior until two blocks have given the noise. */
static void err_var(struct hover_est *s, scalar_t e_pct, scalar_t k, scalar_t dt_s)
{
	scalar_t omk = sc_sub(SC(1.0), k);
	if (s->b_count >= 2u) /* k r_eff first: k^2 alone has few bits in the fixed build */
		s->v_pct2 = sc_add(est_mul_unit(est_mul_unit(s->v_pct2, omk), omk),
				   est_mul_unit(est_mul_unit(s->r_eff, k), k));
	else
		s->v_pct2 = est_mul_unit(s->p_pct2, omk); /* the filter's P r / (P + r) */
	s->b_sum = sc_add(s->b_sum, sc_clamp(e_pct, SC(-100.0), SC(100.0)));
	if (++s->b_n < HOVER_EST_BLK)
		return;
	scalar_t m = est_div_int(s->b_sum, HOVER_EST_BLK);
	if (s->b_settled) {
		if (s->b_count > 0u) {
			/* B times half the squared change of the block means; the mean of the
			 * first HOVER_EST_BLK_AVG, then an average over about as many */
			scalar_t r = sc_mul(sc_from_int((int32_t)HOVER_EST_BLK),
					    est_mul_unit(sc_sq(sc_sub(m, s->b_prev)), SC(0.5)));
			uint32_t n = s->b_count < HOVER_EST_BLK_AVG ? s->b_count : HOVER_EST_BLK_AVG;
			s->r_eff = sc_add(s->r_eff, est_div_int(sc_sub(r, s->r_eff), n));
		}
		/* the error now as the innovations show it: their block means averaged with
		 * weight 1/2 a block, about the filter's own memory (1 / k updates, about two
		 * blocks), so that a convergence under way shows as it is now */
		s->e_mean = s->b_count > 0u ? est_mul_unit(sc_add(s->e_mean, m), SC(0.5)) : m;
		/* the estimate at the blocks' ends, percent of the first settled one (its wander) */
		if (s->b_count == 0u)
			s->th_ref = s->theta;
		s->w_x[s->b_count % HOVER_EST_BLK_AVG] =
			sc_clamp(sc_mul(SC(100.0), sc_sub(sc_div(s->theta, s->th_ref), SC(1.0))), SC(-50.0), SC(50.0));
		s->b_count++;
	} else {
		/* the block began while the filter converged: its innovations are that
		 * convergence, not the noise; the statistics start with the next one */
		s->b_count = 0;
		s->r_eff = s->e_mean = SC_ZERO;
	}
	s->b_prev = m;
	/* settled once P's decrease per update, k P, is within twice the process noise's
	 * increase (the two are equal in the steady state) */
	s->b_settled = est_mul_unit(s->p_pct2, k) < sc_mul(SC(2.0), est_mul_unit(s->q2, dt_s));
	s->b_sum = SC_ZERO;
	s->b_n = 0;
}

/* The measurement y against the prediction y^ (m/s^2) with the noise level r_sd0 (percent
 * of 1 m/s^2): the gate, the relative innovation of theta and its variance. */
static bool innovate(struct hover_est *s, scalar_t y, scalar_t y_hat, scalar_t r_sd0, scalar_t dt_s)
{
	/* two quotients by y^: its reciprocal prepared once (scalar_ops.h) */
	struct sc_gain inv_y_hat = sc_gain_recip2(y_hat, SC(1.0));
	scalar_t e_pct = sc_mul(SC(100.0), sc_sub(sc_mul_gain(y, &inv_y_hat), SC(1.0)));
	scalar_t r_sd = sc_mul_gain(r_sd0, &inv_y_hat);
	scalar_t r = sc_sq(r_sd);
	scalar_t pr = sc_add(s->p_pct2, r);
	if (sc_sq(e_pct) > sc_mul(s->gate2, pr)) {
		s->rejected++;
		int8_t sign = e_pct > SC_ZERO ? 1 : -1;
		s->gated_s = sign == s->gated_sign ? sc_add(s->gated_s, dt_s) : dt_s;
		s->gated_sign = sign;
		if (s->gated_s < SC(HOVER_EST_GATED_S))
			return false;
		/* persistently contradicted: let the innovation in */
		s->p_pct2 = sc_min(sc_max(s->p_pct2, sc_sq(e_pct)), P_MAX_PCT2);
		s->v_pct2 = sc_max(s->v_pct2, s->p_pct2);
		s->gated_s = SC_ZERO;
		pr = sc_add(s->p_pct2, r);
	} else {
		s->gated_s = SC_ZERO;
	}
	/* two quotients by P + r: its reciprocal prepared once */
	struct sc_gain inv_pr = sc_gain_recip2(pr, SC(1.0));
	scalar_t k = sc_mul_gain(s->p_pct2, &inv_pr);
	s->k_last = k;
	err_var(s, e_pct, k, dt_s);
	/* k = P / (P + r) in [0, 1] */
	scalar_t th = sc_mul(s->theta, sc_add(SC(1.0), est_mul_unit(est_div_int(e_pct, 100u), k)));
	s->theta = clamp_theta(s, th);
	s->p_pct2 = sc_max(sc_mul_gain(sc_mul(s->p_pct2, r), &inv_pr), SC_EPS);
	s->updates++;
	return true;
}

/* One update from either kind of input (acc: the accelerometer, c = 1). */
static bool update(struct hover_est *s, scalar_t x, scalar_t u, scalar_t cos_tilt, scalar_t dt_s, bool acc)
{
	if (!inputs_ok(x, u, cos_tilt, dt_s)) {
		s->primed = false;
		return false;
	}
	bool was_primed = s->primed && s->acc == acc;
	scalar_t a_f = filters(s, x, u, cos_tilt, dt_s, acc);
	/* process noise: a random walk of the relative error (dt < 1) */
	s->p_pct2 = sc_min(sc_add(s->p_pct2, est_mul_unit(s->q2, dt_s)), P_MAX_PCT2);
	if (!was_primed)
		return false;
	scalar_t y_hat = sc_mul(sc_mul(s->p.g_mps2, s->uc_f), s->theta);
	if (!(y_hat > s->y_min))
		return false; /* (almost) no thrust: nothing to learn */
	/* the accelerometer's filtered reading is the thrust per mass; the speed's derivative
	 * plus gravity is its vertical part */
	scalar_t y = acc ? a_f : sc_add(a_f, s->p.g_mps2);
	return innovate(s, y, y_hat, acc ? s->r_sd0_imu : s->r_sd0, dt_s);
}

bool hover_est_update(struct hover_est *s, scalar_t vz_mps, scalar_t u, scalar_t cos_tilt, scalar_t dt_s)
{
	return update(s, vz_mps, u, cos_tilt, dt_s, false);
}

bool hover_est_update_acc(struct hover_est *s, scalar_t a_mps2, scalar_t u, scalar_t dt_s)
{
	return update(s, a_mps2, u, SC(1.0), dt_s, true);
}

void hover_est_spool(struct hover_est *s, scalar_t dt_s)
{
	if (!sc_isfinite(dt_s) || !(dt_s > SC_ZERO))
		return;
	/* u_h *= 1 + rate dt  <=>  theta /= 1 + rate dt */
	scalar_t f = sc_add(SC(1.0), sc_mul(s->p.spool_rate, sc_min(dt_s, SC(1.0))));
	s->theta = clamp_theta(s, sc_div(s->theta, f));
	s->p_pct2 = sc_max(s->p_pct2, p0_pct2(&s->p));
	s->v_pct2 = sc_max(s->v_pct2, s->p_pct2);
}

scalar_t hover_est_u(const struct hover_est *s) { return sc_div(SC(1.0), s->theta); }

scalar_t hover_est_sd(const struct hover_est *s)
{
	/* relative sd of theta = relative sd of u_h (first order) */
	return sc_mul(hover_est_u(s), est_div_int(sc_sqrt(s->p_pct2), 100u));
}

/* The estimate's wander, percent^2: the variance of its last (up to HOVER_EST_BLK_AVG)
 * values at the settled blocks' ends about their straight line (the residuals' sum of
 * squares over n - 2), plus the square of the line's change beyond a drift's (zero before
 * four blocks; at most P_MAX_PCT2). */
static scalar_t wander(const struct hover_est *s)
{
	uint32_t n = s->b_count < HOVER_EST_BLK_AVG ? s->b_count : HOVER_EST_BLK_AVG;
	if (n < 4u)
		return SC_ZERO;
	uint32_t first = s->b_count - n;
	scalar_t sx = SC_ZERO, sxt = SC_ZERO;
	int32_t st = 0, stt = 0;
	for (uint32_t i = 0; i < n; i++) {
		scalar_t x = s->w_x[(first + i) % HOVER_EST_BLK_AVG];
		sx = sc_add(sx, x);
		sxt = sc_add(sxt, sc_mul(x, sc_from_int((int32_t)i)));
		st += (int32_t)i;
		stt += (int32_t)(i * i);
	}
	/* x = a + b t: b = (n sxt - st sx) / (n stt - st^2), a = (sx - b st) / n */
	int32_t den = (int32_t)n * stt - st * st;
	scalar_t b =
		est_div_int(sc_sub(sc_mul(sc_from_int((int32_t)n), sxt), sc_mul(sc_from_int(st), sx)), (uint32_t)den);
	scalar_t a = est_div_int(sc_sub(sx, sc_mul(b, sc_from_int(st))), n);
	scalar_t rss = SC_ZERO;
	for (uint32_t i = 0; i < n; i++) {
		scalar_t r =
			sc_sub(s->w_x[(first + i) % HOVER_EST_BLK_AVG], sc_add(a, sc_mul(b, sc_from_int((int32_t)i))));
		rss = sc_min(sc_add(rss, sc_sq(sc_clamp(r, SC(-100.0), SC(100.0)))), P_MAX_PCT2);
	}
	scalar_t var = est_div_int(rss, n - 2u);
	/* the line's change over the window beyond what a drift of drift_per_s makes: no
	 * battery moves k_f so fast, so it is an error (a vibration folding slower than the
	 * window, which the innovations do not show): its change over half the window */
	scalar_t blk_s = sc_mul(s->al_dt, sc_from_int((int32_t)HOVER_EST_BLK));
	scalar_t lim = sc_mul(sc_mul(SC(100.0), s->p.drift_per_s), blk_s);
	scalar_t ex =
		est_mul_unit(sc_mul(sc_max(sc_sub(sc_abs(b), lim), SC_ZERO), sc_from_int((int32_t)(n - 1u))), SC(0.5));
	return sc_min(sc_add(var, sc_sq(sc_min(ex, SC(100.0)))), P_MAX_PCT2);
}

/* The factor from the innovations' mean to the estimate's lag (hover_est.h): the mean shows
 * the lag of (1 - k) / k updates, the filters add tau_s, so 1 + tau_s k / (dt (1 - k)). */
static scalar_t ahead_gain(const struct hover_est *s)
{
	scalar_t k = s->k_last;
	if (!(k < SC(0.5)) || !(s->al_dt > SC_ZERO))
		return SC(1.0);
	return sc_add(SC(1.0), sc_div(sc_mul(k, sc_div(s->p.tau_s, s->al_dt)), sc_sub(SC(1.0), k)));
}

/* The move ahead, percent of theta: the innovations' mean times ahead_gain; none before two
 * settled blocks, or with drift_per_s 0. */
static scalar_t ahead_pct(const struct hover_est *s)
{
	if (s->b_count < 2u || !(s->p.drift_per_s > SC_ZERO))
		return SC_ZERO;
	return sc_clamp(sc_mul(s->e_mean, ahead_gain(s)), SC(-50.0), SC(50.0));
}

scalar_t hover_est_u_ahead(const struct hover_est *s)
{
	return sc_div(SC(1.0), sc_mul(s->theta, sc_add(SC(1.0), est_div_int(ahead_pct(s), 100u))));
}

scalar_t hover_est_sd_err(const struct hover_est *s)
{
	scalar_t v = s->p_pct2;
	if (s->b_count >= 2u) {
		/* the innovations' mean's own noise: the average of white block means of variance
		 * r_eff / B with weight 1/2, (r_eff / B) / 3 */
		scalar_t vm = est_div_int(s->r_eff, 3u * HOVER_EST_BLK);
		v = sc_max(s->v_pct2, wander(s));
		if (s->p.drift_per_s > SC_ZERO) {
			/* moved ahead by the mean (ahead_pct): the move's noise */
			scalar_t g = ahead_gain(s);
			v = sc_add(v, sc_mul(vm, sc_sq(g)));
		} else {
			/* not moved: the mean's square counted beyond twice its noise's variance (a
			 * mean within its noise is no evidence of a bias) */
			v = sc_add(v, sc_max(sc_sub(sc_sq(s->e_mean), sc_mul(SC(2.0), vm)), SC_ZERO));
		}
	}
	return sc_mul(hover_est_u_ahead(s), est_div_int(sc_sqrt(v), 100u));
}

bool hover_est_converged(const struct hover_est *s, scalar_t rel_sd)
{
	scalar_t lim = sc_mul(SC(100.0), rel_sd);
	return s->p_pct2 < sc_sq(lim);
}
