/* kf_track.c - see kf_track.h for the model, the memory and the units. */
#include "kf_track.h"

#include "est_ops.h"
#include "scalar_ops.h"

struct kf_track_params kf_track_params_default(void)
{
	struct kf_track_params p;
	p.drift_per_min = SC(0.02);
	p.t_min_s = SC(0.2);
	p.t_max_s = SC(60.0);
	p.phi_min = SC(0.08);
	p.tau_lag_s = SC(0.03);
	p.curve = SC(0.0);
	for (int j = 0; j < KF_TRACK_ROTORS; j++)
		p.scale[j] = SC(1.0);
	p.s_tau_s = SC(5.0);
	p.s0_pct = SC(1.0);
	p.avg_n = 1u;
	return p;
}

void kf_track_init(struct kf_track *s, const struct kf_track_params *p, scalar_t k0)
{
	s->p = *p;
	if (!(s->p.t_min_s > SC_ZERO))
		s->p.t_min_s = SC(0.2);
	if (!(s->p.t_max_s > s->p.t_min_s))
		s->p.t_max_s = s->p.t_min_s;
	if (s->p.avg_n < 1u)
		s->p.avg_n = 1u;
	s->kr = s->k = k0 > SC_ZERO ? k0 : SC(1.0);
	s->l_slope_pct = SC_ZERO;
	s->P = SC_ZERO;
	s->s2_pct2 = sc_sq(s->p.s0_pct);
	s->s_pct = sc_sqrt(s->s2_pct2);
	s->mem_s = s->p.t_min_s;
	s->lambda = SC(0.98);
	s->p_rt = SC_ZERO;
	s->phi_f = SC_ZERO;
	s->phi_s = SC_ZERO;
	s->blk_phi = s->blk_y = SC_ZERO;
	s->blk_n = 0;
	s->c_ds = SC_ZERO;
	s->w_sum = s->w_t = s->w_kref = s->w_inv = s->w_prev = s->w_var_pct2 = SC_ZERO;
	s->w_n = s->w_count = 0;
	s->l_t = s->l_tn = s->l_kref = s->l_inv = SC_ZERO;
	s->l_su = s->l_suu = s->l_sc = s->l_scc = s->l_suc = s->l_var_pct2 = SC_ZERO;
	s->l_n = s->l_count = 0;
	s->h_ref = s->h_inv = SC_ZERO;
	s->h_s0 = s->h_s00 = s->h_su = s->h_suu = s->h_sc = s->h_scc = s->h_suc = s->h_var_pct2 = SC_ZERO;
	s->e_prev_pct = SC_ZERO;
	s->lag_al = SC(1.0);
	s->c_dt = SC_ZERO;
	s->a_s = SC_ZERO;
	s->dt_tmin = SC_ZERO;
	s->r_drift = sc_recip_of(s->p.drift_per_min);
	s->started = false;
	s->primed = false;
	s->updates = 0;
}

/* sqrt(P / (1 + lambda)) for kf_track_sd, after every change of P or lambda: the quotient and
 * the root from the last ones as guesses (P and lambda change slowly): the same values */
static void set_p_rt(struct kf_track *s)
{
	s->p_rt = est_sqrt_near(est_div_near(s->P, sc_add(SC(1.0), s->lambda), sc_sq(s->p_rt)), s->p_rt);
}

/* x^(1/3) for x > 0 by at most 6 steps of Newton's iteration from a warm start (the last
 * memory). A step that moves r by at most SC_EPS (1 LSB in the fixed build) ends it: the
 * iteration has converged to the resolution, and the warm start of a slowly changing
 * memory needs one step, not a second that would only confirm it. After the first step r is
 * near the root, so x / r^2 is near r: the quotient from that guess (est_div_near, the same
 * quotient). */
static scalar_t cbrt_warm(scalar_t x, scalar_t guess)
{
	scalar_t r = guess > SC_ZERO ? guess : SC(1.0);
	for (int i = 0; i < 6; i++) {
		scalar_t r2 = sc_sq(r);
		scalar_t n = est_div_int(sc_add(sc_add(r, r), i ? est_div_near(x, r2, r) : sc_div(x, r2)), 3u);
		bool done = sc_abs(sc_sub(n, r)) <= SC_EPS;
		r = n;
		if (done)
			break;
	}
	return r;
}

static scalar_t regressor(const struct kf_track *s, const scalar_t *thr, int n)
{
	scalar_t c = s->p.curve, sum = SC_ZERO;
	for (int j = 0; j < n && j < KF_TRACK_ROTORS; j++) {
		scalar_t t = sc_clamp(thr[j], SC_ZERO, SC(1.0));
		/* a straight curve and a nominal rotor skip their products (x 1 and + 0 are exact
		 * in both builds); t and t^2 are in [0, 1]: est_mul_unit */
		scalar_t g = c == SC_ZERO
				     ? t
				     : sc_add(est_mul_unit(sc_sub(SC(1.0), c), t), est_mul_unit(c, est_mul_unit(t, t)));
		sum = sc_add(sum, s->p.scale[j] == SC(1.0) ? g : sc_mul(s->p.scale[j], g));
	}
	return sum;
}

/* A long window starts at the current estimate. */
static void long_start(struct kf_track *s)
{
	s->l_kref = s->kr;
	s->l_inv = sc_div(SC(100.0), s->kr);
	s->l_t = s->l_tn = SC_ZERO;
	s->l_su = s->l_suu = s->l_sc = s->l_scc = s->l_suc = SC_ZERO;
	s->l_n = 0;
}

/* The estimate after a sample into the long window (u: its time in memories T*, bounded by
 * KF_TRACK_L_MEM, c: k in percent from l_kref, clipped); at the window's end the residual
 * variance of c about its least-squares line, and the square of the line's slope per
 * memory (the lag of k behind the drift the line follows). */
static void long_add(struct kf_track *s, scalar_t ds)
{
	scalar_t c = sc_clamp(sc_mul(sc_sub(s->kr, s->l_kref), s->l_inv), SC(-KF_TRACK_W_CLIP), SC(KF_TRACK_W_CLIP));
	scalar_t u = sc_min(s->l_tn, SC(KF_TRACK_L_MEM));
	s->l_su = sc_add(s->l_su, u);
	s->l_suu = sc_add(s->l_suu, sc_sq(u));
	s->l_sc = sc_add(s->l_sc, c);
	s->l_scc = sc_add(s->l_scc, sc_sq(c));
	s->l_suc = sc_add(s->l_suc, sc_mul(u, c));
	/* the time in memories: ds / T* of each sample, 1 - lambda */
	s->l_t = sc_add(s->l_t, ds);
	s->l_tn = sc_add(s->l_tn, sc_sub(SC(1.0), s->lambda));
	if (++s->l_n < KF_TRACK_L_MAX && s->l_tn < SC(KF_TRACK_L_MEM))
		return;
	if (s->l_n >= 8u) {
		/* with means mu, mc: Suu' = Suu / n - mu^2, Suc' = Suc / n - mu mc, Scc' = Scc / n - mc^2;
		 * the residual variance Scc' - Suc'^2 / Suu' */
		uint32_t n = s->l_n;
		scalar_t mu = est_div_int(s->l_su, n), mc = est_div_int(s->l_sc, n);
		scalar_t vuu = sc_sub(est_div_int(s->l_suu, n), sc_sq(mu));
		scalar_t vuc = sc_sub(est_div_int(s->l_suc, n), sc_mul(mu, mc));
		scalar_t vcc = sc_sub(est_div_int(s->l_scc, n), sc_sq(mc));
		scalar_t v = vcc, slope = SC_ZERO;
		if (vuu > SC_ZERO) {
			slope = sc_div(vuc, vuu); /* percent per memory */
			v = sc_sub(vcc, sc_mul(slope, vuc));
		}
		/* The lag behind that drift: kr lags it by about one memory, and k is kr moved
		 * ahead along this slope (lag_correct). A step in k (a rotor's loss, a window over
		 * the tracker's first transient) is no drift: the correction follows at most the
		 * drift bound, drift_per_min T* (percent per memory). What it leaves is lag: of a
		 * faster drift, the excess whole; and the slope's own error and change, half the
		 * squared change from the last window's slope (none to compare after the first). */
		scalar_t bound = est_div_int(sc_mul(SC(100.0), sc_mul(s->p.drift_per_min, s->mem_s)), 60u);
		scalar_t cl = sc_clamp(slope, sc_neg(bound), bound);
		scalar_t lag2 = sc_sq(sc_sub(slope, cl));
		if (s->l_count)
			lag2 = sc_add(lag2, est_mul_unit(sc_sq(sc_sub(cl, s->l_slope_pct)), SC(0.5)));
		v = sc_add(sc_max(v, SC_ZERO), lag2);
		s->l_slope_pct = cl;
		s->l_count++;
		uint32_t m = s->l_count < KF_TRACK_W_AVG ? s->l_count : KF_TRACK_W_AVG;
		s->l_var_pct2 = sc_add(s->l_var_pct2, est_div_int(sc_sub(v, s->l_var_pct2), m));
	}
	long_start(s);
}

/* k from kr: an exponential memory's estimate is the weighted mean of its samples, which
 * lags a drift by their mean age, lambda / (1 - lambda) samples, less half a sample for a
 * block mean of avg_n frames (its time is its middle): in memories T*,
 * 1 - (1 - lambda) (avg_n + 1) / (2 avg_n). k is kr moved ahead by that many memories
 * along the last long window's slope (none before the first). */
static void lag_correct(struct kf_track *s)
{
	if (!s->l_count) {
		s->k = s->kr;
		return;
	}
	uint32_t n = s->p.avg_n;
	scalar_t lag = sc_sub(SC(1.0),
			      est_div_int(sc_mul(sc_sub(SC(1.0), s->lambda), sc_from_int((int32_t)(n + 1u))), 2u * n));
	s->k = sc_add(s->kr, est_div_int(sc_mul(s->kr, sc_mul(s->l_slope_pct, lag)), 100u));
}

/* kr at a window's end into the slow part's sums (kf_track.h): every earlier value one window
 * older (u down by 1 / KF_TRACK_H_MEM) and weighed by lambda_h = 1 - 1 / KF_TRACK_H_MEM, the
 * new one at u = 0. Then the weighted residual variance about the weighted line, with n_eff =
 * S0^2 / S00 values of which the line takes two: times n_eff / (n_eff - 2), once n_eff > 4.
 * The values are percent of h_ref, moved to kr when one is beyond 1 % (the sums shifted and
 * scaled to it: the residuals are the same), so that they stay small whatever the drift. */
static void slow_add(struct kf_track *s)
{
	const scalar_t lam = SC(1.0 - 1.0 / KF_TRACK_H_MEM), du = SC(1.0 / KF_TRACK_H_MEM);
	if (!(s->h_s0 > SC_ZERO)) {
		s->h_ref = s->kr;
		s->h_inv = sc_div(SC(100.0), s->kr);
	}
	scalar_t c = sc_mul(sc_sub(s->kr, s->h_ref), s->h_inv);
	if (sc_abs(c) > SC(1.0)) {
		/* every earlier value from the new reference, in its percent: (c_i - c) rho with
		 * rho = h_ref / kr = 100 / (100 + c) */
		scalar_t rho = sc_div(SC(100.0), sc_add(SC(100.0), c));
		s->h_scc = sc_mul(sc_sq(rho),
				  sc_add(sc_sub(s->h_scc, sc_mul(sc_add(c, c), s->h_sc)), sc_mul(sc_sq(c), s->h_s0)));
		s->h_suc = sc_mul(rho, sc_sub(s->h_suc, sc_mul(c, s->h_su)));
		s->h_sc = sc_mul(rho, sc_sub(s->h_sc, sc_mul(c, s->h_s0)));
		s->h_ref = s->kr;
		s->h_inv = sc_mul(s->h_inv, rho);
		c = SC_ZERO;
		/* a drift of percents per window (k_f drifting many times faster than T* was
		 * sized for) would take the sum of squares out of the fixed build's range: the
		 * sums start again, the line then over the windows since */
		if (s->h_scc > SC(8192.0))
			s->h_s0 = s->h_s00 = s->h_su = s->h_suu = s->h_sc = s->h_scc = s->h_suc = SC_ZERO;
	}
	scalar_t s0 = s->h_s0, su = s->h_su;
	s->h_suu = est_mul_unit(sc_add(sc_sub(s->h_suu, est_mul_unit(su, sc_add(du, du))), est_mul_unit(s0, sc_sq(du))),
				lam);
	s->h_su = est_mul_unit(sc_sub(su, est_mul_unit(s0, du)), lam);
	s->h_suc = est_mul_unit(sc_sub(s->h_suc, est_mul_unit(s->h_sc, du)), lam);
	s->h_s0 = sc_add(est_mul_unit(s0, lam), SC(1.0));
	s->h_s00 = sc_add(est_mul_unit(s->h_s00, sc_sq(lam)), SC(1.0));
	s->h_sc = sc_add(est_mul_unit(s->h_sc, lam), c);
	s->h_scc = sc_add(est_mul_unit(s->h_scc, lam), sc_sq(c));
	s0 = s->h_s0;
	scalar_t n2 = sc_sq(s0), dof = sc_sub(n2, sc_add(s->h_s00, s->h_s00)); /* S0^2 - 2 S00 */
	if (!(dof > sc_add(s->h_s00, s->h_s00)))                               /* n_eff <= 4 */
		return;
	scalar_t r0 = sc_div(SC(1.0), s0);
	scalar_t mu = sc_mul(s->h_su, r0), mc = sc_mul(s->h_sc, r0);
	scalar_t vuu = sc_sub(sc_mul(s->h_suu, r0), sc_sq(mu));
	scalar_t vuc = sc_sub(sc_mul(s->h_suc, r0), sc_mul(mu, mc));
	scalar_t v = sc_sub(sc_mul(s->h_scc, r0), sc_sq(mc));
	if (vuu > SC_ZERO)
		v = sc_sub(v, sc_div(sc_sq(vuc), vuu));
	s->h_var_pct2 = sc_div(sc_mul(sc_max(v, SC_ZERO), n2), dof);
}

/* A window starts at the current estimate. */
static void window_start(struct kf_track *s)
{
	s->w_kref = s->kr;
	s->w_inv = sc_div(SC(100.0), s->kr);
	s->w_sum = s->w_t = SC_ZERO;
	s->w_n = 0;
}

/* One sample into the window: m_pct, the sample's y / phi in percent from w_kref. A window of
 * T* ends with its mean compared with the last one's: half the squared change is the
 * variance of a T* mean, half that the variance of a 2 T* mean (kf_track.h). */
static void window_add(struct kf_track *s, scalar_t m_pct, scalar_t ds)
{
	s->w_sum = sc_add(s->w_sum, sc_clamp(m_pct, SC(-KF_TRACK_W_CLIP), SC(KF_TRACK_W_CLIP)));
	s->w_t = sc_add(s->w_t, ds);
	if (++s->w_n < KF_TRACK_W_MAX && s->w_t < s->mem_s)
		return;
	/* the mean in newtons: w_kref (1 + mean / 100) */
	scalar_t mean = sc_add(s->w_kref, sc_mul(s->w_kref, est_div_int(est_div_int(s->w_sum, s->w_n), 100u)));
	if (s->w_count > 0u || s->w_prev > SC_ZERO) {
		scalar_t d = sc_div(sc_mul(SC(100.0), sc_sub(mean, s->w_prev)), mean);
		scalar_t v = est_mul_unit(sc_sq(d), SC(0.25));
		/* the mean of the first KF_TRACK_W_AVG comparisons, then an average over about as many */
		s->w_count++;
		uint32_t n = s->w_count < KF_TRACK_W_AVG ? s->w_count : KF_TRACK_W_AVG;
		s->w_var_pct2 = sc_add(s->w_var_pct2, est_div_int(sc_sub(v, s->w_var_pct2), n));
	}
	s->w_prev = mean;
	slow_add(s);
	window_start(s);
}

bool kf_track_update(struct kf_track *s, const scalar_t *thr, int n, scalar_t y_n, scalar_t dt_s, bool gate)
{
	if (!sc_isfinite(y_n) || !sc_isfinite(dt_s) || !(dt_s > SC_ZERO) || dt_s > SC(1.0))
		return false;
	for (int j = 0; j < n; j++)
		if (!sc_isfinite(thr[j]))
			return false;
	if (dt_s != s->c_dt) { /* the step changed: the exact discrete lag, the averages */
		s->c_dt = dt_s;
		if (s->p.tau_lag_s > SC_ZERO)
			s->lag_al = sc_sub(SC(1.0), sc_exp(sc_neg(sc_div(dt_s, s->p.tau_lag_s))));
		/* the sample period: avg_n frames (one frame: dt itself) */
		s->c_ds = s->p.avg_n > 1u ? sc_mul(dt_s, sc_from_int((int32_t)s->p.avg_n)) : dt_s;
		s->a_s = sc_div(s->c_ds, sc_add(s->p.s_tau_s, s->c_ds));
		s->dt_tmin = sc_div(s->c_ds, s->p.t_min_s);
	}
	/* the thrust a throttle produces, as the motor lag delivers it */
	scalar_t phi = regressor(s, thr, n);
	if (!s->primed || !(s->p.tau_lag_s > SC_ZERO)) {
		s->phi_f = phi;
		s->primed = true;
	} else {
		scalar_t al = s->lag_al;
		s->phi_f = sc_add(s->phi_f, est_mul_unit(sc_sub(phi, s->phi_f), al)); /* al in [0, 1] */
	}
	phi = s->phi_f;
	if (!gate || phi < s->p.phi_min || !(y_n > SC_ZERO)) {
		s->blk_n = 0; /* a block is whole or not taken */
		s->blk_phi = s->blk_y = SC_ZERO;
		return false;
	}
	if (s->p.avg_n > 1u) { /* a sample: the block's means */
		s->blk_phi = sc_add(s->blk_phi, phi);
		s->blk_y = sc_add(s->blk_y, y_n);
		if (++s->blk_n < s->p.avg_n)
			return false;
		phi = est_div_int(s->blk_phi, s->p.avg_n);
		y_n = est_div_int(s->blk_y, s->p.avg_n);
		s->blk_n = 0;
		s->blk_phi = s->blk_y = SC_ZERO;
	}
	dt_s = s->c_ds;
	s->phi_s = phi;
	if (!s->started) {
		s->k = s->kr = sc_div(y_n, phi);
		s->e_prev_pct = SC_ZERO;
		s->P = sc_div(s->dt_tmin, sc_sq(phi));
		set_p_rt(s);
		s->started = true;
		s->updates++;
		window_start(s);
		long_start(s);
		return true;
	}
	scalar_t e = sc_sub(y_n, sc_mul(s->kr, phi));
	/* relative noise, percent^2, averaged over s_tau_s, from the change of the residual
	 * between samples (var = 2 s^2 for white noise): a slow tracking error or a step does
	 * not pass for noise, which would lengthen the memory and slow the tracking further */
	scalar_t e_pct = sc_div(sc_mul(SC(100.0), e), y_n);
	/* y / phi from the window's reference, percent: the residual and where k stands */
	window_add(s, sc_add(e_pct, sc_mul(sc_sub(s->kr, s->w_kref), s->w_inv)), dt_s);
	scalar_t de = sc_sub(e_pct, s->e_prev_pct);
	s->e_prev_pct = e_pct;
	/* half the square: x 0.5 is x / 2 exactly in both builds (factors in [0, 1]: est_mul_unit) */
	scalar_t s2 = sc_min(est_mul_unit(sc_sq(de), SC(0.5)), SC(10000.0));
	s->s2_pct2 = sc_add(s->s2_pct2, est_mul_unit(sc_sub(s2, s->s2_pct2), s->a_s));
	s->s_pct = sc_sqrt(s->s2_pct2);
	/* memory T* = (s^2 / (4 r^2 f_s))^(1/3) with s and r as fractions: s / (2 r) in seconds is
	 * (s_pct / 100) / (2 drift_per_min / 60) = 0.3 s_pct / drift_per_min */
	if (s->p.drift_per_min > SC_ZERO) {
		scalar_t q = sc_div_r(est_mul_unit(s->s_pct, SC(0.3)), s->p.drift_per_min, &s->r_drift);
		scalar_t x =
			dt_s <= SC(1.0) ? est_mul_unit(sc_sq(q), dt_s) : sc_mul(sc_sq(q), dt_s); /* (s / 2r)^2 / f_s */
		s->mem_s = sc_clamp(cbrt_warm(x, s->mem_s), s->p.t_min_s, s->p.t_max_s);
	} else {
		s->mem_s = s->p.t_max_s;
	}
	/* dt / T* from the last frame's as the guess (the memory changes slowly) */
	s->lambda = sc_sub(SC(1.0), est_div_near(dt_s, s->mem_s, sc_sub(SC(1.0), s->lambda)));
	/* RLS with forgetting, scalar: with den = lambda + phi^2 P, the update
	 * P' = (P - K phi P) / lambda, K = P phi / den is P' = P / den and K = P' phi (one
	 * quotient) */
	scalar_t phi2 = sc_sq(phi);
	scalar_t den = sc_add(s->lambda, sc_mul(phi2, s->P));
	s->P = est_div_near(s->P, den, s->P); /* den is about 1 once P has settled */
	scalar_t K = sc_mul(s->P, phi);
	s->kr = sc_add(s->kr, sc_mul(K, e));
	long_add(s, dt_s);
	lag_correct(s);
	/* no wind-up: P at most its steady state for the shortest memory and this regressor,
	 * dt_tmin / phi^2 (its quotient only when the bound is reached) */
	if (sc_mul(s->P, phi2) > s->dt_tmin)
		s->P = sc_div(s->dt_tmin, phi2);
	s->P = sc_max(s->P, SC_EPS);
	set_p_rt(s);
	s->updates++;
	return true;
}

scalar_t kf_track_sd(const struct kf_track *s)
{
	if (!s->started)
		return SC_ZERO;
	/* sigma (N) = s y ~ s k phi (the last sample's); var(k) = sigma^2 P / (1 + lambda) */
	scalar_t sigma = sc_mul(est_div_int(s->s_pct, 100u), sc_mul(s->k, s->phi_s));
	scalar_t sd = sc_mul(sigma, s->p_rt);
	scalar_t v = sc_max(s->w_count ? s->w_var_pct2 : SC_ZERO, s->l_count ? s->l_var_pct2 : SC_ZERO);
	v = sc_max(v, s->h_var_pct2);
	if (!(v > SC_ZERO))
		return sd;
	return sc_max(sd, sc_mul(s->k, est_div_int(sc_sqrt(v), 100u)));
}
