/* motor_id_solve.c - joint identification of the rotor model, the work between frames: set-up,
 * the refinement of the lag grids, the freezing of the whiteness model, the solve and the
 * cause texts; see motor_id.h. Float in both builds (a few times per experiment); the
 * per-frame part is motor_id.c. */
#include "motor_id.h"
#include "fbits.h"
#include "motor_id_q.h"
#include "thrmap.h" /* THRMAP_CURVE_*: the curve's range */

#define NR MOTOR_ID_ROTORS
#define ND MOTOR_ID_DELAYS
#define NL MOTOR_ID_LAGS

/* The least-squares arithmetic on the sums (interpolation, solutions, residual sums of
 * squares) is float in both builds: the sums are taken relative to a reference model near
 * the data (motor_id.h), so a residual sum of squares is not a small difference of large
 * products, and float holds the estimates well within 0.02 % of float64 in both builds (the
 * fixed build's 30-bit integer sums are rounded once to float; double there would cost
 * more soft-float work on Cortex-M0 for no change of accuracy that matters). */

/* a rotor's least-squares sums under one hypothesis (SI units): float st[S_N], in the order of
 * struct motor_id_stat's members and of their exponents MID_E_G11..MID_E_RR */
enum { S_G11, S_G12, S_G22, S_B1, S_B2, S_RR, S_N };
_Static_assert(sizeof(struct motor_id_stat) == S_N * sizeof(motor_id_sum_t) && MID_E_RR - MID_E_G11 == S_RR - S_G11,
	       "struct motor_id_stat: S_N sums in the order of their exponents");

/* sum k of a struct motor_id_stat (its members are S_N sums, in order, without padding) */
static motor_id_sum_t stat_sum(const struct motor_id_stat *s, unsigned k)
{
	return *(const motor_id_sum_t *)(const void *)((const char *)s + k * sizeof(motor_id_sum_t));
}

/* rotor j's throttle at the start, as float */
#define SC_J(m, j) mid_u_to_float((m)->s_c[j])

/* NOINLINE: a small function whose inlined copies cost more flash than the calls (the
 * compiler inlines them at -Os; this code runs between frames) */
#define NOINLINE __attribute__((noinline))

/* l[0] a + l[1] b + l[2] c: a value interpolated over the grid */
NOINLINE static float wsum3(const float l[3], float a, float b, float c) { return l[0] * a + l[1] * b + l[2] * c; }

/* Rotor j's statistics of delay d: at grid point gi (< NL), or (gi = NL) interpolated over the
 * grid with the weights l. Sums of kind G (power of thrust 0), B (1), RR (2). */
static void stat_at(const struct motor_id *m, unsigned d, unsigned gi, const float l[3], unsigned j, float o[S_N])
{
	for (unsigned k = 0; k < S_N; k++) {
		/* the kind's scale, a power of two (1 in the float build), applied last: the same
		 * result as scaling each sum first, and a grid point converts its sum alone */
		const float sc = mid_sum_to_float(1, m->e[MID_E_G11 + k], (int)(k > S_G22) + (int)(k > S_B2), m->kexp);
		float v;
		if (gi < NL)
			v = (float)stat_sum(&m->st[d][gi][j], k);
		else
			v = wsum3(l, (float)stat_sum(&m->st[d][0][j], k), (float)stat_sum(&m->st[d][1][j], k),
				  (float)stat_sum(&m->st[d][2][j], k));
		o[k] = v * sc;
	}
}

/* the reference model's k_f and curve (exactly the per-frame part's) */
static float ref_kf(const struct motor_id *m)
{
#if OCTO_FIXED
	return mid_u_to_float(m->kf0n) * sc_pow2f(m->kexp);
#else
	return m->kf0n;
#endif
}
static float ref_c(const struct motor_id *m) { return mid_u_to_float(m->c0); }

/* grid ratio of each stage and where (% of the planned frames) a stage ends. The third
 * (55 %: 1.08) places the last, whose grid narrows to what that placement allows
 * (motor_id_refine): the statistics are interpolated between the grid's lags, quadratically
 * in log lag, which moves the criterion's minimum by a share of the grid's width. On a 1.08
 * grid, with large throttle steps (a sweep) and little noise, that moved the lag by up to
 * 0.5 % and k_f with it (a step's transient ties k_f to the lag), several of k_f's sds; the
 * shift shrinks about as the square of the grid's width. */
static const float stage_ratio[MOTOR_ID_STAGES] = {2.5f, 1.3f, 1.08f, 1.08f};
static const uint32_t stage_end_pct[MOTOR_ID_STAGES - 1] = {30u, 45u, MOTOR_ID_LAST_PCT};
/* The last grid's half-width (log): LAST_SDS of the third stage's lag sds plus LAST_BIAS (that
 * stage's own interpolation shift, up to half a percent, and its lag states' settling), within
 * [log LAST_RATIO_MIN, log 1.08]; a minimum beyond the third grid repeats that stage
 * (REPEAT_PCT), and beyond it again leaves the last at 1.08 or the root of its ratio. A
 * third grid widened by the second stage's walk (to the root of its ratio, 1.26) narrows it
 * too: its minimum, refined on the criterion (lag_newton), lies as close to the truth as a
 * 1.08 grid's, and a last grid kept at 1.08 biased k_f by up to about one of its sds on every
 * flight (docs/identification.md, "Selection by prediction error") */
#define LAST_SDS 4.0f
#define LAST_BIAS 0.01f
#define LAST_RATIO_MIN 1.02f
#define X_MAX 1.5f /* how far beyond the grid the parabola may place the minimum */
#define CURVE_CHI2_SIGMAS 5.0f
#define NE_SIGMAS 5.0f
#define NO_LAG_FRAC 0.15f /* a lag below this fraction of a frame is taken as none (a < 0.0013) */
#define MARGIN_MIN 12.0f  /* log-likelihood ratio of the best delay over the next */

NOINLINE static float clampf(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* 1 - a of a lag; below NO_LAG_FRAC of a frame the lag is none (a = 0) */
static float lag_k1(float tau, float dt) { return tau > NO_LAG_FRAC * dt ? 1.0f - expf(-dt / tau) : 1.0f; }

/* the whiteness model is frozen this share of the planned frames into the last stage */
#define WHITE_AFTER_PCT 20u
/* A third stage whose minimum lies beyond its grid (a stale lag prior: the grids walked at
 * every stage) runs once more, re-centred, for this share of the planned frames, and the last
 * stage starts that much later. Its grid would otherwise be left wide (the root of the third's
 * ratio, up to 1.12), and the statistics' interpolation across it moved k_f by two of its sds;
 * the shorter last stage widens the sds instead (by about a tenth) */
#define REPEAT_PCT 10u

/* the least n >= pct % of the planned frames, pct <= 100 (integers: the same in every
 * precision; N = 100 q + r gives q pct + ceil(r pct / 100), in 32 bits) */
static uint32_t frames_at(const struct motor_id *m, uint32_t pct)
{
	const uint32_t n = m->cfg.n_frames;
	return n / 100u * pct + (n % 100u * pct + 99u) / 100u;
}

/* n_exc at which the current stage ends, or (last stage) the whiteness model freezes */
static uint32_t next_due(const struct motor_id *m)
{
	const uint32_t later = m->repeated ? REPEAT_PCT : 0u;
	if (m->stage < MOTOR_ID_STAGES - 2)
		return frames_at(m, stage_end_pct[m->stage]);
	if (m->stage == MOTOR_ID_STAGES - 2)
		return frames_at(m, stage_end_pct[m->stage] + later);
	return frames_at(m, stage_end_pct[MOTOR_ID_STAGES - 2] + later + WHITE_AFTER_PCT);
}

/* a lag within the grids' range */
NOINLINE static float clamp_tau(float tau) { return clampf(tau, MOTOR_ID_TAU_MIN, MOTOR_ID_TAU_MAX); }

/* the lag at delay d's grid position x (x = -1, 0, 1: the grid's three) */
NOINLINE static float grid_tau(const struct motor_id *m, unsigned d, float x)
{
	return m->lag_c[d] * powf(m->lag_r[d], x);
}

static void set_grid(struct motor_id *m, unsigned d, float centre, float ratio)
{
	float dt = sc_to_float(m->cfg.dt_s);
	m->lag_c[d] = clamp_tau(centre);
	m->lag_r[d] = ratio;
	m->k1[d][0] = mid_u_of_float(lag_k1(m->lag_c[d] / ratio, dt));
	m->k1[d][1] = mid_u_of_float(lag_k1(m->lag_c[d], dt));
	m->k1[d][2] = mid_u_of_float(lag_k1(m->lag_c[d] * ratio, dt));
}

void motor_id_init(struct motor_id *m, const struct motor_id_cfg *cfg, const scalar_t thr0[NR])
{
	*m = (struct motor_id){0};
	m->cfg = *cfg;
	if (!fb_pos(m->cfg.tau0_s))
		m->cfg.tau0_s = 0.03f;
	if (!fb_pos(m->cfg.kf0))
		m->cfg.kf0 = 1.0f;
	m->cfg.curve0 = clampf(m->cfg.curve0, THRMAP_CURVE_MIN, THRMAP_CURVE_MAX);
	/* the reference model; the fixed build takes thrusts and torques as value 2^-kexp, with
	 * k_f0 2^-kexp in [0.5, 1) */
	float kf0n = m->cfg.kf0;
#if OCTO_FIXED
	while (kf0n >= 1.0f && m->kexp < 60) {
		kf0n *= 0.5f;
		m->kexp++;
	}
	while (kf0n < 0.5f && m->kexp > -60) {
		kf0n *= 2.0f;
		m->kexp--;
	}
	m->kf0n = mid_u_of_float(kf0n);
#else
	m->kf0n = kf0n;
#endif
	m->c0 = mid_u_of_float(m->cfg.curve0);
	for (unsigned k = 0; k < MID_E_N; k++)
		m->e[k] = MOTOR_ID_E0;
	m->n_next = next_due(m);
	for (unsigned j = 0; j < NR; j++) {
		float t0 = sc_to_float(thr0[j]);
		m->s_c[j] = mid_u_of_float(clampf(t0, 0.02f, 1.0f));
		for (unsigned d = 0; d < ND; d++) {
			m->hist[d][j] = mid_u_of_float(t0);
			for (unsigned i = 0; i < NL; i++)
				m->s[d][i][j] = mid_u_of_float(t0);
		}
	}
	for (unsigned d = 0; d < ND; d++)
		set_grid(m, d, m->cfg.tau0_s, stage_ratio[0]);
}

/* the prior curve's regressor on the basis: g0 = w1 x1 + w2 x2 */
static void curve_w(float c, float s_c, float w[2])
{
	w[0] = (1.0f - c) + 2.0f * c * s_c;
	w[1] = c;
}

/* det G of a rotor's statistics */
NOINLINE static float stat_det(const float st[S_N]) { return st[S_G11] * st[S_G22] - st[S_G12] * st[S_G12]; }

/* w^T G w of a rotor's statistics (sum g^2 of the regressor g = w^T x) */
static float stat_gww(const float st[S_N], float w0, float w1)
{
	return w0 * w0 * st[S_G11] + 2.0f * w0 * w1 * st[S_G12] + w1 * w1 * st[S_G22];
}

/* The one-parameter fit of y (the 2 values sum x f) on the regressor g = w^T x, w the curve
 * c's weights at s_c (curve_w): the coefficient (w^T y) / (sum g^2), 0 if sum g^2 is not
 * positive; also w, *wy = w^T y and *gw = sum g^2. */
NOINLINE static float fit_w(const float st[S_N], float c, float s_c, float y1, float y2, float w[2], float *wy,
			    float *gw)
{
	curve_w(c, s_c, w);
	*gw = stat_gww(st, w[0], w[1]);
	*wy = w[0] * y1 + w[1] * y2;
	return fb_pos(*gw) ? *wy / *gw : 0.0f;
}

/* residual sum of squares of one rotor's statistics: 2 parameters (curve estimated) or the
 * prior curve's 1; delta = the fitted change of theta from the reference (2 values) */
static float rotor_ssr(const float st[S_N], bool est_curve, float c0, float s_c, float delta[2])
{
	float d0, d1, ssr;
	if (est_curve) {
		float det = stat_det(st);
		if (!(det > 1e-30f * st[S_G11] * st[S_G22]) || !fb_pos(st[S_G11])) {
			delta[0] = delta[1] = 0.0f;
			return st[S_RR];
		}
		d0 = (st[S_G22] * st[S_B1] - st[S_G12] * st[S_B2]) / det;
		d1 = (st[S_G11] * st[S_B2] - st[S_G12] * st[S_B1]) / det;
		ssr = st[S_RR] - d0 * st[S_B1] - d1 * st[S_B2];
	} else {
		float w[2], bw, gw;
		float mu = fit_w(st, c0, s_c, st[S_B1], st[S_B2], w, &bw, &gw);
		d0 = mu * w[0];
		d1 = mu * w[1];
		ssr = st[S_RR] - mu * bw;
	}
	delta[0] = d0;
	delta[1] = d1;
	return fb_pos(ssr) ? ssr : 0.0f;
}

/* rotor j's statistics of delay d (st; gi, l: see stat_at) and its residual sum of squares
 * under the configured model */
NOINLINE static float ssr_at(const struct motor_id *m, unsigned d, unsigned gi, const float l[3], unsigned j,
			     float st[S_N], float delta[2])
{
	stat_at(m, d, gi, l, j, st);
	return rotor_ssr(st, m->cfg.est_curve, m->cfg.curve0, SC_J(m, j), delta);
}

/* parabola through (-1, s0), (0, s1), (1, s2): minimum x (clamped to +/-X_MAX) and the
 * curvature k (S = S_min + k (x - x*)^2; 0 when not convex) */
static float parabola(const float sv[3], float *k)
{
	float den = sv[0] - 2.0f * sv[1] + sv[2];
	float x;
	if (fb_pos(den))
		x = clampf((sv[0] - sv[2]) / (2.0f * den), -X_MAX, X_MAX);
	else
		x = sv[0] < sv[2] ? -X_MAX : X_MAX;
	*k = fb_pos(den) ? 0.5f * den : 0.0f;
	return x;
}

/* Lagrange weights of the three grid points at x */
static void lagrange3(float x, float l[3])
{
	l[0] = 0.5f * x * (x - 1.0f);
	l[1] = 1.0f - x * x;
	l[2] = 0.5f * x * (x + 1.0f);
}

/* the lag filters' states interpolated over a grid's three (s, weights l) into out */
NOINLINE static void lag_states(const motor_id_u_t s[NL][NR], const float l[3], motor_id_u_t out[NR])
{
	for (unsigned j = 0; j < NR; j++)
		out[j] = mid_u_of_float(
			wsum3(l, mid_u_to_float(s[0][j]), mid_u_to_float(s[1][j]), mid_u_to_float(s[2][j])));
}

/* The selection criterion of delay d at each lag. The likelihood with each rotor's noise
 * variance unknown is -(n/2) sum_j log SSR_j (a rotor that no lag explains, another motor,
 * then pulls the common lag little); log SSR is far from a parabola in the lag, so its
 * Gauss-Newton form is used: J = sum_j SSR_j / SSR_j(best grid point), quadratic in the
 * statistics like SSR itself; -(n/2) log-likelihood = (n/2) J + const near the minimum. */
static void delay_crit(const struct motor_id *m, unsigned d, float jv[3])
{
	float dl[2], e[NL][NR], tot[NL];
	unsigned ib = 0;
	for (unsigned i = 0; i < NL; i++) {
		tot[i] = 0.0f;
		for (unsigned j = 0; j < NR; j++) {
			float o[S_N];
			e[i][j] = ssr_at(m, d, i, 0, j, o, dl);
			tot[i] += e[i][j];
		}
		if (tot[i] < tot[ib])
			ib = i;
	}
	for (unsigned i = 0; i < NL; i++) {
		jv[i] = 0.0f;
		for (unsigned j = 0; j < NR; j++)
			jv[i] += e[i][j] / fmaxf(e[ib][j], 1e-30f);
	}
}

/* sum over rotors of log SSR_j of delay d at grid position x (statistics interpolated).
 * Beyond the grid (|x| > 1) the quadratic extrapolation of the sums can leave an SSR at or
 * below zero, whose log would make any hypothesis look best: there the grid's edge stands in. */
static float delay_logssr(const struct motor_id *m, unsigned d, float x)
{
	float sum = 0.0f;
	for (int pass = 0; pass < 2; pass++) { /* the second at the edge, if the first failed */
		float dl[2], l[3];
		bool ok = true;
		lagrange3(x, l);
		sum = 0.0f;
		for (unsigned j = 0; j < NR && ok; j++) {
			float o[S_N];
			float ssr = ssr_at(m, d, NL, l, j, o, dl);
			ok = ssr > 1e-30f || fabsf(x) <= 1.0f;
			sum += logf(fmaxf(ssr, 1e-30f));
		}
		if (ok)
			break;
		x = x > 0.0f ? 1.0f : -1.0f;
	}
	return sum;
}

/* Every delay hypothesis at its criterion's minimum: grid position xs, curvature ks (see
 * parabola), interpolated sum of log SSR smin. Returns the delay of least smin (the first
 * of equals). */
NOINLINE static unsigned delay_scan(const struct motor_id *m, float xs[ND], float ks[ND], float smin[ND])
{
	unsigned best = 0;
	for (unsigned d = 0; d < ND; d++) {
		float sv[3];
		delay_crit(m, d, sv);
		xs[d] = parabola(sv, &ks[d]);
		smin[d] = delay_logssr(m, d, xs[d]);
		if (smin[d] < smin[best])
			best = d;
	}
	return best;
}

/* the delay taken: the given one (fix_delay; the largest hypothesis beyond the bank), else
 * the one the scan preferred */
static unsigned chosen_delay(const struct motor_id *m, unsigned scanned)
{
	if (!m->cfg.fix_delay)
		return scanned;
	return m->cfg.delay_fr < ND ? m->cfg.delay_fr : ND - 1u;
}

/* the hypothesis the data so far prefer (or the given delay) and its lag's grid position */
static void best_hyp(const struct motor_id *m, unsigned *d_best, float *x_best)
{
	float xs[ND], ks[ND], smin[ND];
	unsigned d = chosen_delay(m, delay_scan(m, xs, ks, smin));
	*d_best = d;
	*x_best = xs[d];
}

/* rotor's m at curve c from its statistics: sum g f / sum g^2 with g = w^T x and
 * sum x f = b + G theta_ref; *gw = sum g^2 */
static float rotor_m(const float st[S_N], float c, float s_c, const float th_ref[2], float *gw)
{
	float w[2], wy;
	const float t0 = th_ref[0], t1 = th_ref[1];
	return fit_w(st, c, s_c, st[S_B1] + st[S_G11] * t0 + st[S_G12] * t1, st[S_B2] + st[S_G12] * t0 + st[S_G22] * t1,
		     w, &wy, gw);
}

/* median of 8 (mean of the 4th and 5th); their indices in *a, *b */
static float median8(const float v[NR], unsigned *a, unsigned *b)
{
	unsigned idx[NR];
	for (unsigned j = 0; j < NR; j++)
		idx[j] = j;
	for (unsigned i = 1; i < NR; i++)
		for (unsigned k = i; k > 0 && v[idx[k - 1]] > v[idx[k]]; k--) {
			unsigned t = idx[k];
			idx[k] = idx[k - 1];
			idx[k - 1] = t;
		}
	*a = idx[NR / 2 - 1];
	*b = idx[NR / 2];
	return 0.5f * (v[*a] + v[*b]);
}

static float sqrt0(float v) { return fb_pos(v) ? sqrtf(v) : 0.0f; }

/* a / b for b > 0, else 0 */
NOINLINE static float div_pos(float a, float b) { return fb_pos(b) ? a / b : 0.0f; }

/* The sampling variance of the median of 8 rotors' estimates (the mean of the 4th and 5th),
 * in units of one rotor's variance: 0.168 for 8 alike, 0.190 with one rotor far off (a weak
 * one; Monte Carlo of normal errors, 4e5 draws). The larger is taken. */
#define MEDIAN8_VAR 0.19f

/* rotor j's reference parameters: the prior (k_f0, curve0) on its basis */
NOINLINE static void ref_theta(const struct motor_id *m, unsigned j, float th[2])
{
	float w[2];
	curve_w(ref_c(m), SC_J(m, j), w);
	float kf = ref_kf(m);
	th[0] = kf * w[0];
	th[1] = kf * w[1];
}

/* Rotor j's own curve c_j = B / m_j from its 2-parameter fit about the prior's reference th
 * (d2: the fit's change of theta, ssr2: its residual sum of squares), with its variance (0:
 * not determined). */
static float rotor_curve(const struct motor_id *m, const float st[S_N], unsigned j, const float th[2],
			 const float d2[2], float ssr2, float *var)
{
	float a = th[0] + d2[0], bq = th[1] + d2[1];
	float mj = a + bq * (1.0f - 2.0f * SC_J(m, j));
	float det = stat_det(st);
	*var = 0.0f;
	if (!(fb_pos(mj) && fb_pos(det)))
		return 0.0f;
	const float ga = (-bq / (mj * mj)), gb = (a / (mj * mj));
	/* g^T G^-1 g */
	float q = (float)((ga * ga * st[S_G22] - 2.0f * ga * gb * st[S_G12] + gb * gb * st[S_G11]) / det);
	*var = ssr2 / ((float)m->n_stat - 2.0f) * q;
	return bq / mj;
}

/* the model of delay d's statistics at grid position x (see fit_at) */
struct fit {
	float s2[NR];         /* residual variance under the configured model */
	float mj[NR], vm[NR]; /* each rotor's m at the common curve, its variance */
	float mj_e[NR];       /* m at the common curve + FIT_EPS */
	float ssr_sum, chi2;  /* residual sum of squares; less the rotors' own curves' SSRs */
	float curve, curve_sd, kf;
	unsigned ia, ib; /* the rotors whose mean is the median */
};
#define FIT_EPS 1e-3f

/* Every rotor's fit at delay d's grid position x: its residual sum of squares, its own curve
 * (2-parameter fit); the common curve (with est_curve: the inverse-variance mean of the
 * rotors', unclamped: a linear rotor's estimate scatters on both sides of 0, and a boundary
 * there would bias the curve, and with it k_f, high; the caller's range check names the
 * bounds); each rotor's m at that curve, k_f = their median, the scales (m_j / k_f). */
static void fit_at(const struct motor_id *m, unsigned d, float x, struct fit *f, float scale[NR])
{
	const bool ec = m->cfg.est_curve;
	const float np = ec ? 2.0f : 1.0f;
	float cj[NR], vcj[NR], th[2];
	/* one rotor's statistics and reference theta at a time (computed again below): stack on M0 */
	float l[3], st[S_N];
	lagrange3(x, l);
	f->ssr_sum = f->chi2 = 0.0f;
	for (unsigned j = 0; j < NR; j++) {
		float dl[2];
		const float ssr = ssr_at(m, d, NL, l, j, st, dl);
		/* the rotor's own curve's fit: the configured model's when the curve is estimated
		 * (the prior curve and throttle are the 1-parameter fit's only) */
		const float ssr2 = ec ? ssr : rotor_ssr(st, true, 0.0f, 0.0f, dl);
		ref_theta(m, j, th);
		f->ssr_sum += ssr;
		f->s2[j] = ssr / ((float)m->n_stat - np);
		cj[j] = rotor_curve(m, st, j, th, dl, ssr2, &vcj[j]);
		f->chi2 += ssr - ssr2;
	}
	float sw = 0.0f, swc = 0.0f;
	for (unsigned j = 0; j < NR; j++)
		if (fb_pos(vcj[j])) {
			sw += 1.0f / vcj[j];
			swc += cj[j] / vcj[j];
		}
	const bool have_c = ec && fb_pos(sw);
	f->curve = have_c ? swc / sw : m->cfg.curve0;
	f->curve_sd = have_c ? sqrt0(1.0f / sw) : 0.0f;
	for (unsigned j = 0; j < NR; j++) {
		float gw, gw2;
		stat_at(m, d, NL, l, j, st);
		ref_theta(m, j, th);
		f->mj[j] = rotor_m(st, f->curve, SC_J(m, j), th, &gw);
		f->mj_e[j] = rotor_m(st, f->curve + FIT_EPS, SC_J(m, j), th, &gw2);
		f->vm[j] = div_pos(f->s2[j], gw);
	}
	f->kf = median8(f->mj, &f->ia, &f->ib);
	for (unsigned j = 0; j < NR; j++)
		scale[j] = div_pos(f->mj[j], f->kf);
}

/* A new reference model: common k_f and curve (the curve only when estimated); kept within
 * a quarter to four times the prior and the throttle map's curve range (and, fixed build,
 * what Q1.30 holds of k_f 2^-kexp), else unchanged. */
static void set_reference(struct motor_id *m, float kf, float c)
{
	if (!m->cfg.est_curve)
		c = m->cfg.curve0;
	if (!(kf >= 0.25f * m->cfg.kf0 && kf <= 4.0f * m->cfg.kf0 && c >= THRMAP_CURVE_MIN && c <= THRMAP_CURVE_MAX))
		return;
#if OCTO_FIXED
	float kn = kf * sc_pow2f(-m->kexp);
	if (!(kn < 1.9f))
		return;
	m->kf0n = mid_u_of_float(kn);
#else
	m->kf0n = kf;
#endif
	m->c0 = mid_u_of_float(c);
}

/* the statistics restart (the lag filters run on) */
static void stats_restart(struct motor_id *m)
{
	for (unsigned d = 0; d < ND; d++)
		for (unsigned i = 0; i < NL; i++)
			for (unsigned j = 0; j < NR; j++)
				m->st[d][i][j] = (struct motor_id_stat){0};
	for (unsigned k = MID_E_G11; k <= MID_E_RR; k++)
		m->e[k] = MOTOR_ID_E0;
	m->n_stat = 0;
}

/* the data so far's fit for a reference: the preferred hypothesis' k_f and curve (false:
 * too few frames) */
static bool reference_fit(const struct motor_id *m, float *kf, float *c)
{
	if (m->n_stat < 10u)
		return false;
	unsigned d;
	float x, sc[NR];
	struct fit f;
	best_hyp(m, &d, &x);
	fit_at(m, d, x, &f, sc);
	*kf = f.kf;
	*c = f.curve;
	return true;
}

/* Freezes the model the whiteness test follows, from the last stage's data so far: the delay
 * the bank prefers (or the given one), its lag at the criterion's minimum (a filter of its own,
 * started from the grid's states interpolated there), every rotor's fit at that lag. */
static void white_begin(struct motor_id *m)
{
	struct motor_id_white *w = &m->wh;
	*w = (struct motor_id_white){0};
	m->e[MID_E_WSE] = m->e[MID_E_WSEE] = MOTOR_ID_E0;
	unsigned d;
	float x;
	best_hyp(m, &d, &x);
	float l[3], dl[2];
	lagrange3(x, l);
	for (unsigned j = 0; j < NR; j++) {
		float o[S_N];
		ssr_at(m, d, NL, l, j, o, dl);
		w->dl[j][0] = mid_f_of_float(dl[0], m->kexp);
		w->dl[j][1] = mid_f_of_float(dl[1], m->kexp);
	}
	lag_states(m->s[d], l, w->s);
	w->k1 = mid_u_of_float(lag_k1(clamp_tau(grid_tau(m, d, x)), sc_to_float(m->cfg.dt_s)));
	w->delay = (uint8_t)d;
	w->on = true;
}

static void lag_newton(const struct motor_id *m, unsigned d, float *x, float *k);

void motor_id_refine(struct motor_id *m)
{
	motor_id_process(m);
	if (m->white_due) {
		m->white_due = false;
		white_begin(m);
	}
	if (m->reref_due) { /* early in the first stage: re-fit the reference, restart */
		m->reref_due = false;
		m->reref_done = true;
		float kf, c;
		if (!m->refine_due && reference_fit(m, &kf, &c)) {
			stats_restart(m);
			set_reference(m, kf, c);
		}
	}
	if (!m->refine_due)
		return;
	m->refine_due = false;
	unsigned next = m->stage + 1u;
	if (next >= MOTOR_ID_STAGES)
		return;
	float dt = sc_to_float(m->cfg.dt_s), tau_hi = 0.0f;
	/* the next stage's reference: this one's fit (relative to this reference) */
	float kf_ref = 0.0f, c_ref = 0.0f;
	bool have_ref = reference_fit(m, &kf_ref, &c_ref);
	float xs[ND], ks[ND], smin[ND]; /* each delay's criterion's minimum */
	unsigned bd = chosen_delay(m, delay_scan(m, xs, ks, smin));
	if (next == MOTOR_ID_STAGES - 1u && !m->repeated && m->n_stat > 0u && fabsf(xs[bd]) > 1.0f &&
	    m->lag_c[bd] * m->lag_r[bd] > NO_LAG_FRAC * dt) {
		m->repeated = true; /* the third stage once more (REPEAT_PCT) */
		next = m->stage;
	}
	const bool last = next == MOTOR_ID_STAGES - 1u;
	for (unsigned d = 0; d < ND; d++) {
		float r = m->lag_r[d];
		/* a grid whose every lag is none has three equal filters: nothing to walk by */
		float x = m->n_stat > 0u && m->lag_c[d] * r > NO_LAG_FRAC * dt ? xs[d] : 0.0f;
		/* the last grid's centre: the chosen delay's lag refined as the solve refines it */
		float kx = ks[d];
		if (last && d == bd && m->n_stat > 0u)
			lag_newton(m, d, &x, &kx);
		/* a minimum below the first grid walks twice as far (towards no lag at all); later
		 * grids walk to the edge's extrapolation only: their minimum is near (the first
		 * stage's coarse parabola overshoots a long lag by up to a step, and a second double
		 * walk from there left the lag out of the last grid's reach) */
		float centre = grid_tau(m, d, x <= -X_MAX + 1e-3f && next == 1u ? 2.0f * x : x);
		/* the lag states at the new taus: quadratic interpolation in log tau of the old.
		 * A minimum outside the grid narrows it less (the grid walks towards it) */
		float nr = stage_ratio[next];
		if (last && d == bd && fabsf(x) <= 1.0f && fb_pos(kx) && m->n_stat > 0u) {
			float sd_ln = logf(r) * sqrtf(1.0f / ((float)m->n_stat * kx));
			nr = expf(clampf(LAST_BIAS + LAST_SDS * sd_ln, logf(LAST_RATIO_MIN), logf(nr)));
		}
		if (fabsf(x) > 1.0f)
			nr = fmaxf(nr, sqrtf(r));
		motor_id_u_t old[NL][NR];
		for (unsigned i = 0; i < NL; i++)
			for (unsigned j = 0; j < NR; j++)
				old[i][j] = m->s[d][i][j];
		const float lr = logf(r);
		for (int i = 0; i < (int)NL; i++) {
			/* nr^(i - 1) */
			float tau_i = clamp_tau(centre) * (i == 0 ? 1.0f / nr : (i == 1 ? 1.0f : nr)), l[3];
			lagrange3(clampf(logf(tau_i / m->lag_c[d]) / lr, -X_MAX, X_MAX), l);
			lag_states(old, l, m->s[d][i]);
		}
		set_grid(m, d, centre, nr);
		tau_hi = fmaxf(tau_hi, m->lag_c[d] * nr);
	}
	stats_restart(m);
	if (have_ref)
		set_reference(m, kf_ref, c_ref);
	m->stage = (uint8_t)next;
	m->n_next = next_due(m);
	/* what the interpolation left decays with the lag: wait two time constants */
	float fr = div_pos(2.0f * tau_hi, dt);
	m->skip = (uint8_t)clampf(fr + 1.0f, 1.0f, 30.0f);
}

/* The lag's grid position x refined from the parabola's by Newton steps on the profile
 * criterion itself, sum over rotors of log SSR_j with the statistics interpolated at x (the
 * parabola through three criterion values is coarser than the statistics' interpolation: its
 * error moved x by a part of a standard deviation that depended on where the truth fell in the
 * grid); *k becomes that criterion's curvature / 2 (in the units of delay_crit's, so that
 * var x = 1 / (n k) still holds). Kept within +/- X_MAX; unchanged if not convex there. */
static void lag_newton(const struct motor_id *m, unsigned d, float *x, float *k)
{
	const float h = 0.2f; /* wide enough that float rounding of the SSRs stays out of d2 */
	float xi = *x, kk = *k;
	if (!fb_pos(kk) || fabsf(xi) >= X_MAX - 1e-3f)
		return;
	for (int it = 0; it < 3; it++) {
		float fv[3], c; /* at xi - h, xi, xi + h */
		for (int i = 0; i < 3; i++)
			fv[i] = delay_logssr(m, d, xi + (float)(i - 1) * h);
		/* the Newton step -f'/f'' of the central differences: the minimum of the parabola
		 * through the three values (in units of h, at most X_MAX of them) */
		float step = h * parabola(fv, &c);
		if (!fb_pos(c))
			return;
		xi = clampf(xi + step, -X_MAX + 2e-3f, X_MAX - 2e-3f);
		kk = c / (h * h);
		if (fabsf(step) < 1e-3f)
			break;
	}
	*x = xi;
	*k = kk;
}

/* chi-square quantile with k degrees of freedom at z standard normal deviates above the mean
 * (Wilson-Hilferty; within 1 % of the exact one from k = 3 on at these z) */
NOINLINE static float chi2_quant(float k, float z)
{
	float a = 2.0f / (9.0f * k), t = 1.0f - a + z * sqrtf(a);
	return k * t * t * t;
}

/* deviates of the whiteness limits: the sum over everything, each rotor's (8 tests), each
 * level's (3 tests); about 2e-4 + 8 x 5e-5 + 3 x 1e-4 = 1e-3 false rejections in all */
#define WZ_ALL 3.5f
#define WZ_ROTOR 3.9f
#define WZ_LEVEL 3.7f
#define WMIN_N 20u /* fewest frames of a (rotor, level) series that enters the test */

/* The whiteness test from its sums (see motor_id.h). Returns the cause of coloured prediction
 * errors: one rotor alone (the others white) is that rotor (*rotor); colour at one throttle
 * level, not the others, is the thrust curve; else the dynamics. Out of line: less flash on
 * Cortex-M0 (its caller holds many floats). */
NOINLINE static enum motor_id_cause white_eval(const struct motor_id *m, struct motor_id_result *res, int *rotor)
{
	const struct motor_id_white *w = &m->wh;
	res->white_ok = true;
	res->white_have = false;
	if (!w->on)
		return MOTOR_ID_OK;
	/* the tests' statistics and degrees of freedom: g = 0 everything, 1..NR one rotor's levels,
	 * NR + 1.. one level's rotors. Each (rotor, level) series in the test adds to its three
	 * (every sum taken over its series in the order of the series) */
	float qg[1 + NR + MOTOR_ID_WBINS] = {0};
	unsigned ng[1 + NR + MOTOR_ID_WBINS] = {0}; /* series in each test */
	for (unsigned j = 0; j < NR; j++)
		for (unsigned b = 0; b < MOTOR_ID_WBINS; b++) {
			float n = (float)w->n[j][b];
			if (w->n[j][b] < WMIN_N)
				continue;
			float mu = mid_sum_to_float(w->se[j][b], m->e[MID_E_WSE], 1, m->kexp) / n,
			      c0 = mid_sum_to_float(w->see[j][b], m->e[MID_E_WSEE], 2, m->kexp) - n * mu * mu,
			      qq = 0.0f;
			if (!fb_pos(c0))
				continue;
			for (unsigned l = 0; l < MOTOR_ID_WLAGS; l++) {
				float rho =
					(mid_sum_to_float(w->sl[j][b][l], m->e[MID_E_WSEE], 2, m->kexp) - n * mu * mu) /
					c0;
				qq += rho * rho;
			}
			qq *= n;
			for (unsigned g = 0; g < 1u + NR + MOTOR_ID_WBINS; g++)
				if (g == 0u || g == 1u + j || g == 1u + NR + b) {
					qg[g] += qq;
					ng[g]++;
				}
		}
	/* n_bad: how many rotors, how many levels fail */
	bool ok = true;
	unsigned n_bad[2] = {0, 0};
	for (unsigned g = 0; g < 1u + NR + MOTOR_ID_WBINS; g++) {
		const float q = qg[g], dof = (float)(ng[g] * MOTOR_ID_WLAGS);
		if (g == 0u) {
			if (!fb_pos(dof))
				return MOTOR_ID_OK;
			res->white_have = true;
			res->white_q = q;
			res->white_dof = dof;
			res->white_lim = chi2_quant(dof, WZ_ALL);
			ok = q <= res->white_lim;
			continue;
		}
		/* a rotor's or a level's statistic over its limit */
		const bool is_rotor = g <= NR;
		float *ratio = is_rotor ? &res->white_rotor[g - 1u] : &res->white_level[g - 1u - NR];
		*ratio = fb_pos(dof) ? q / chi2_quant(dof, is_rotor ? WZ_ROTOR : WZ_LEVEL) : 0.0f;
		ok = ok && *ratio <= 1.0f;
		if (*ratio > 1.0f) {
			n_bad[is_rotor]++;
			if (is_rotor)
				*rotor = (int)g - 1;
		}
	}
	res->white_ok = ok;
	return n_bad[1] == 1u ? MOTOR_ID_ROTOR : n_bad[0] == 1u ? MOTOR_ID_LEVEL : MOTOR_ID_COLOURED;
}

/* the lag's share of a variance: the value at x +/- LAG_H (vp, vm), its derivative in x (central
 * difference) squared times var x */
#define LAG_H 0.25f
NOINLINE static float lag_var(float vp, float vm, float var_x)
{
	float dv = (vp - vm) / (2.0f * LAG_H);
	return dv * dv * var_x;
}

/* a standard deviation sd with the lag's share added (see lag_var) */
NOINLINE static float sd_with_lag(float sd, float vp, float vm, float var_x)
{
	return sqrt0(sd * sd + lag_var(vp, vm, var_x));
}

/* the normalised errors' limit: ne_max, or NE_SIGMAS standard deviations of the ratio of two
 * variance estimates (the fit's, dof degrees of freedom; the noise's, relative variance v_nz)
 * when the data are few */
NOINLINE static float ne_limit(float ne_max, float dof, float v_nz)
{
	return fmaxf(ne_max, 1.0f + NE_SIGMAS * sqrtf(2.0f / fmaxf(dof, 1.0f) + v_nz));
}

/* the delay and the lag chosen (pick_lag) */
struct lag_pick {
	unsigned best;       /* the delay */
	float x, var_x;      /* the lag on the grid's log scale, and its variance */
	bool have_k, no_lag; /* the criterion is convex there; the lag is below a frame's reach */
};

/* The delay hypothesis of least criterion at its best lag (or the given one), its margin over
 * the next best, its lag refined by Newton steps with the lag's sd, and whether that is no lag. */
static void pick_lag(const struct motor_id *m, struct motor_id_result *res, struct lag_pick *lp)
{
	float smin[ND], xs[ND], ks[ND];
	unsigned best = delay_scan(m, xs, ks, smin);
	res->free_delay = best;
	best = chosen_delay(m, best);
	/* the next best (smin is a sum of logs: any sign) */
	float second = 0.0f;
	bool have2 = false;
	for (unsigned d = 0; d < ND; d++)
		if (d != best && (!have2 || smin[d] < second)) {
			second = smin[d];
			have2 = true;
		}
	res->delay = best;
	float nf = (float)m->n_stat;
	res->delay_margin = 0.5f * nf * (second - smin[best]);

	/* sd of the lag: -log-likelihood = (n / 2) J, J = J_min + k (x - x*)^2, so var x = 1 / (n k) */
	float x = xs[best], r = m->lag_r[best];
	float kx = ks[best]; /* the criterion's curvature in x there */
	lag_newton(m, best, &x, &kx);
	const bool have_k = fb_pos(kx);
	res->tau = grid_tau(m, best, x);
	const float var_x = have_k ? 1.0f / (nf * kx) : 0.0f;
	res->tau_sd = have_k ? res->tau * logf(r) * sqrt0(var_x) : res->tau;
	/* the grid's low end without lag and the minimum there: no lag (sd: that bound) */
	float dtf = sc_to_float(m->cfg.dt_s);
	bool no_lag = res->tau <= 1.2f * NO_LAG_FRAC * dtf ||
		      (x <= -X_MAX + 1e-3f && grid_tau(m, best, -X_MAX) <= NO_LAG_FRAC * dtf);
	if (no_lag) {
		res->tau = 0.0f;
		res->tau_sd = NO_LAG_FRAC * dtf;
	}
	*lp = (struct lag_pick){.best = best, .x = x, .var_x = var_x, .have_k = have_k, .no_lag = no_lag};
}

/* the normalised errors (residual over noise variance) of the rotors */
struct ne_stats {
	float hi, mid;  /* the largest, the median */
	unsigned worst; /* the rotor of the largest */
};

static void normalised_errors(const struct fit *f, float nz, float dof, struct motor_id_result *res,
			      struct ne_stats *ne)
{
	ne->hi = 0.0f;
	ne->worst = 0;
	for (unsigned j = 0; j < NR; j++) {
		res->ne[j] = div_pos(f->s2[j], nz);
		if (res->ne[j] > ne->hi) {
			ne->hi = res->ne[j];
			ne->worst = j;
		}
	}
	res->ne_all = div_pos(f->ssr_sum / dof, nz);
	unsigned ma, mb;
	ne->mid = median8(res->ne, &ma, &mb);
	res->curve_chi2 = div_pos(f->chi2, nz);
}

/* The lag's share: k_f, curve and scales move with the lag (central differences; the lag's
 * error is uncorrelated with theirs at a fixed lag, to first order: the profile's gradient is
 * orthogonal to their regressors). f is the caller's scratch (stack on M0). */
static void add_lag_share(const struct motor_id *m, const struct lag_pick *lp, struct fit *f,
			  struct motor_id_result *res, float *vkf)
{
	float kp, cp, sp[NR], sm[NR];
	fit_at(m, lp->best, lp->x + LAG_H, f, sp);
	kp = f->kf;
	cp = f->curve;
	fit_at(m, lp->best, lp->x - LAG_H, f, sm);
	*vkf += lag_var(kp, f->kf, lp->var_x);
	res->curve_sd = sd_with_lag(res->curve_sd, cp, f->curve, lp->var_x);
	for (unsigned j = 0; j < NR; j++)
		res->scale_sd[j] = sd_with_lag(res->scale_sd[j], sp[j], sm[j], lp->var_x);
}

/* k_tau = rho k_f, rho from torque on thrust over every rotor (noise-corrected: sf2 is the
 * thrust noise's variance); vkf: k_f's variance. */
static void solve_ktau(const struct motor_id *m, float vkf, float sf2, struct motor_id_result *res)
{
	float ff = mid_sum_to_float(m->ff, m->e[MID_E_FF], 2, m->kexp),
	      tf = mid_sum_to_float(m->tf, m->e[MID_E_TF], 2, m->kexp),
	      tt = mid_sum_to_float(m->tt, m->e[MID_E_TT], 2, m->kexp);
	float nall = (float)(m->n_exc * NR);
	float rho = div_pos(tf, ff);
	float ss_t = tt - 2.0f * rho * tf + rho * rho * ff;
	float vrho = fb_pos(ff) && m->n_exc * NR > 1u ? ss_t / (nall - 1.0f) / ff : 0.0f;
	if (ff > nall * sf2)
		rho *= ff / (ff - nall * sf2);
	res->ktau = rho * res->kf;
	res->ktau_sd = sqrt0(rho * rho * vkf + res->kf * res->kf * vrho);
}

/* The acceptance: res->cause (and cause_rotor), the most specific cause first. np: the
 * parameters per rotor; dof: the fit's degrees of freedom over all rotors. */
static void verdict(const struct motor_id *m, float ne_max, unsigned np, float dof, const struct lag_pick *lp,
		    const struct ne_stats *ne, struct motor_id_result *res)
{
	const bool ec = m->cfg.est_curve;
	const unsigned best = lp->best;
	const bool no_lag = lp->no_lag;
	float dof_j = (float)m->n_stat - (float)np;
	float chi2_lim = (float)NR + CURVE_CHI2_SIGMAS * sqrtf(2.0f * (float)NR);
	/* the normalised errors' limits (the noise's variance from first differences: about a
	 * third of its count effective) */
	float v_nz = m->nz_n > 0u ? 6.0f / (float)m->nz_n : 1.0f;
	float lim_j = ne_limit(ne_max, dof_j, v_nz);
	float lim_all = ne_limit(ne_max, dof, v_nz);
	const bool fixd = m->cfg.fix_delay;
	int white_rotor = -1;
	const enum motor_id_cause white_c = white_eval(m, res, &white_rotor);
	if (m->nz_n < 16u)
		res->cause = MOTOR_ID_NOISE_UNKNOWN;
	else if (fixd && res->free_delay != best && -res->delay_margin >= MARGIN_MIN)
		res->cause = MOTOR_ID_DELAY_GIVEN;
	else if (!ec && res->curve_chi2 > chi2_lim)
		res->cause = MOTOR_ID_CURVE;
	else if (!no_lag && (res->tau <= MOTOR_ID_TAU_MIN * 1.01f || res->tau >= MOTOR_ID_TAU_MAX * 0.99f))
		res->cause = MOTOR_ID_LAG_RANGE;
	/* outside the last grid the statistics are extrapolated: a lag there (a prior far from
	 * the truth left the grids short of it) came out 7 % off with a sd of 0.3 %, so it is
	 * not accepted, whether the criterion is convex there or not */
	else if (!no_lag && fabsf(lp->x) > 1.0f)
		res->cause = MOTOR_ID_LAG_REACH;
	else if (!no_lag && !lp->have_k)
		res->cause = MOTOR_ID_LAG_RANGE;
	else if (!fixd && best == ND - 1u)
		res->cause = MOTOR_ID_DELAY_RANGE;
	else if (!fixd && res->delay_margin < MARGIN_MIN)
		res->cause = MOTOR_ID_DELAY_AMBIGUOUS;
	else if (!res->white_ok) {
		res->cause = white_c == MOTOR_ID_LEVEL && !ec ? MOTOR_ID_CURVE : white_c;
		if (white_c == MOTOR_ID_ROTOR)
			res->cause_rotor = white_rotor;
	} else if (ne->hi > lim_j && ne->mid <= lim_j && fb_pos(dof_j)) {
		res->cause = MOTOR_ID_ROTOR;
		res->cause_rotor = (int)ne->worst;
	} else if (res->ne_all > lim_all)
		res->cause = MOTOR_ID_MODEL;
	else
		res->cause = MOTOR_ID_OK;
}

void motor_id_solve(const struct motor_id *m, float ne_max, struct motor_id_result *res)
{
	*res = (struct motor_id_result){0};
	res->cause_rotor = -1;
	const unsigned np = m->cfg.est_curve ? 2u : 1u;
	res->n = m->n_stat;
	/* the thrust noise (still frames): reported even when the excitation's data are too few */
	float nz = div_pos(mid_sum_to_float(m->nz_ss, m->e[MID_E_NZ], 2, m->kexp), (float)m->nz_n);
	res->noise_sd = sqrt0(nz);
	if (m->n_stat < 30u) {
		res->cause = MOTOR_ID_NO_DATA;
		return;
	}
	float dof = (float)(m->n_stat * NR) - (float)(np * NR) - 1.0f;
	struct lag_pick lp;
	pick_lag(m, res, &lp);

	/* every rotor at that lag: the common curve, each rotor's m, k_f = their median, scales */
	struct fit f;
	fit_at(m, lp.best, lp.x, &f, res->scale);
	res->curve = f.curve;
	res->curve_sd = f.curve_sd;
	res->kf = f.kf;
	float dkdc = (0.5f * (f.mj_e[f.ia] + f.mj_e[f.ib]) - res->kf) / FIT_EPS;
	float vkf = MEDIAN8_VAR * 0.5f * (f.vm[f.ia] + f.vm[f.ib]) + dkdc * dkdc * res->curve_sd * res->curve_sd;
	for (unsigned j = 0; j < NR; j++)
		res->scale_sd[j] = div_pos(sqrt0(f.vm[j]), res->kf);
	struct ne_stats ne;
	normalised_errors(&f, nz, dof, res, &ne);
	const float sf2 = fb_pos(nz) ? nz : f.ssr_sum / dof; /* the thrust noise's variance for k_tau */
	if (!lp.no_lag && lp.have_k)
		add_lag_share(m, &lp, &f, res, &vkf); /* f's fit at x is no longer needed */
	res->kf_sd = sqrt0(vkf);

	solve_ktau(m, vkf, sf2, res);
	verdict(m, ne_max, np, dof, &lp, &ne, res);
}

/* The causes' texts and remedies, in the order of enum motor_id_cause, each ended by a NUL
 * (one string, no table of pointers). */
static const char cause_texts[] = "accepted\0"
				  "too few frames\0"
				  "noise not measured\0"
				  "motor lag out of range\0"
				  "delay out of range\0"
				  "delay ambiguous\0"
				  "thrust curve not modelled\0"
				  "a rotor unexplained\0"
				  "residuals above noise\0"
				  "given delay contradicted\0"
				  "residuals coloured at one throttle level\0"
				  "residuals not white\0"
				  "motor lag past the prior's reach";
static const char cause_remedies[] = "\0"
				     "longer ID_EXC_TIME\0"
				     "hover still before the run\0"
				     "lag 0.5-500 ms only; check motors\0"
				     "delay > 3 frames: fix the link\0"
				     "raise ID_EXC_AMP or ID_EXC_TIME\0"
				     "set ID_CRV_EST 1\0"
				     "inspect that rotor\0"
				     "check link timing and rotors\0"
				     "let the delay be found\0"
				     "thrust curve not quadratic: lower ID_EXC_OFS\0"
				     "motor not first-order or link jitter: check both\0"
				     "ID_MOT_TAU to the lag found, fly again";

/* the string number c of list (c < MOTOR_ID_LAG_REACH + 1), else dflt */
NOINLINE static const char *nth_text(const char *list, enum motor_id_cause c, const char *dflt)
{
	if ((unsigned)c > (unsigned)MOTOR_ID_LAG_REACH)
		return dflt;
	for (unsigned k = (unsigned)c; k > 0u; k--)
		while (*list++ != '\0')
			;
	return list;
}

const char *motor_id_cause_text(enum motor_id_cause c) { return nth_text(cause_texts, c, "?"); }

const char *motor_id_cause_remedy(enum motor_id_cause c) { return nth_text(cause_remedies, c, ""); }
