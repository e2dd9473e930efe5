/*
 * The identification estimators (ident.c) against their own algorithm in float64, in whichever
 * build this is (float, or integer Q formats in the fixed build). The reference runs the whole
 * estimator in double (delay line, motor lag, lag sensitivity, thrust curve, the three RLS;
 * the SVFs, torque weighting, gyroscopic term, the RLS and the instrumental-variable sums)
 * with its coefficients computed in double from the exact frame period, and is fed exactly
 * the inputs the firmware gets (the scalar_t throttles, measurements and parameters). The
 * truth is drawn per run: k_f and k_tau +/-30 %, thrust curve, motor lag 10-100 ms, transport
 * delay 0-3 frames, inertias +/-30 %, torque and gyro noise, excitation.
 * Bound: k_f, k_tau (lag-aware and plain) and the inertia within 0.02 % of float64.
 * Then the long runs (hours of hover, an hour-long inertia experiment) and saturating inputs:
 * no overflow, wrap or stall.
 */
#include "ident.h"
#include "rls.h"
#include "unit.h"
#include "unit_scalar.h"
#include "bierman64.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define REL_BOUND 2e-4 /* 0.02 % */
/* The inertia's std (the residual's lag products about the ratio after 0.5 s, ident.h)
 * follows the residual, a small difference of large signals: 2 % (the fixed build's Q16.16
 * filter states round it; float build: 5 %, from its float32 sums over an hour, 1e-4 over a
 * run of 10-30 s), against the std's own sampling error of a few %. */
#define SD_BOUND (OCTO_FIXED ? 2e-2 : 5e-2)
#define DT (1.0 / 90.0)
#define FPS 90L
/* Long runs: hours on the host; on emulated Cortex-M (make arm), where an emulated minute
 * of the estimators and their double-precision references costs seconds on M0, a 60th
 * (the same integer code: the host covers the sums' headroom, QEMU the target's arithmetic). */
#if defined(__arm__)
#define LONG_S(s) ((s) / 60L)
#else
#define LONG_S(s) (s)
#endif

/* ---------------------------------------------------------------- rotor reference */
static double g_curve(double c, double s) { return (1.0 - c) * s + c * s * s; }

struct rotor_ref {
	int delay;
	double hist[FILT_DELAY_MAX]; /* hist[0]: the latest throttle pushed */
	double tau, c, alpha, dalpha, s, sig;
	struct ref lag, plain, sens;
	double y_prev[2];
	bool have_prev;
};

static void rotor_ref_init(struct rotor_ref *r, const struct ident_rotor_cfg *cfg)
{
	memset(r, 0, sizeof *r);
	r->delay = (int)cfg->delay_frames;
	r->tau = d(cfg->mot_tau_s);
	r->c = d(cfg->curve);
	r->s = d(cfg->thr0);
	for (int i = 0; i < FILT_DELAY_MAX; i++)
		r->hist[i] = r->s;
	r->alpha = r->tau > 0 ? 1.0 - exp(-DT / r->tau) : 1.0;
	r->dalpha = r->tau > 0 ? -(DT / (r->tau * r->tau)) * exp(-DT / r->tau) : 0.0;
	const double th0[2][4] = {{(double)cfg->kf0}, {(double)cfg->ktau0}};
	const double th0s[1][4] = {{(double)cfg->kf0, 0.0}};
	ref_init(&r->lag, 1, 2, 1e6, 1.0, th0);
	ref_init(&r->plain, 1, 2, 1e6, 1.0, th0);
	ref_init(&r->sens, 2, 1, 1e6, 1.0, th0s);
}

static void rotor_ref_advance(struct rotor_ref *r, double thr_prev)
{
	double u = thr_prev;
	if (r->delay > 0) {
		u = r->hist[r->delay - 1];
		memmove(&r->hist[1], &r->hist[0], (FILT_DELAY_MAX - 1) * sizeof r->hist[0]);
		r->hist[0] = thr_prev;
	}
	double s_prev = r->s;
	r->s += r->alpha * (u - r->s);
	r->sig = (1.0 - r->alpha) * r->sig + r->dalpha * (u - s_prev);
}

static void rotor_ref_update(struct rotor_ref *r, double thr_prev, double f, double tq)
{
	rotor_ref_advance(r, thr_prev);
	double phi = g_curve(r->c, r->s), y[2] = {f, tq};
	ref_update(&r->lag, &phi, y);
	if (r->dalpha != 0.0) {
		double phi2[2] = {phi, (1.0 - r->c + 2.0 * r->c * r->s) * r->sig};
		ref_update(&r->sens, phi2, y);
	}
	if (r->have_prev) {
		double praw = g_curve(r->c, thr_prev);
		ref_update(&r->plain, &praw, r->y_prev);
	}
	r->y_prev[0] = f;
	r->y_prev[1] = tq;
	r->have_prev = true;
}

static double rotor_ref_tau(const struct rotor_ref *r) { return r->tau + r->sens.th[0][1] / r->sens.th[0][0]; }

/* max and rms of relative differences */
struct stat {
	double max, ss;
	long n;
};

static void stat_add(struct stat *s, double est, double ref)
{
	double e = fabs(est / ref - 1.0);
	s->max = e > s->max || e != e ? e : s->max;
	s->ss += e * e;
	s->n++;
}

static double stat_rms(const struct stat *s) { return s->n > 0 ? sqrt(s->ss / (double)s->n) : 0.0; }

/* A rotor experiment: the plant of ident.h (one frame of loop delay, `delay` more, a
 * first-order lag, the thrust curve) under PRBS dither around hover, with measurement noise;
 * about 1 % of the frames are lost (ident_rotor_hold). Compares the firmware's estimators
 * with the float64 reference at the end (stat[0..4]: k_f, k_tau, plain k_f, plain k_tau,
 * the lag check); returns false when the reference misses the truth by more than 1 %. */
struct rotor_run {
	double kf, kt, c, tau, hover, amp, noise;
	int delay, clock;
	long frames;
};

static void rotor_draw(struct unit_rng *g, struct rotor_run *p)
{
	p->kf = 28.0269 * unit_rand_uniform(g, 0.7, 1.3);
	p->kt = 0.3869 * unit_rand_uniform(g, 0.7, 1.3);
	p->c = unit_rand_uniform(g, 0.0, 0.5);
	p->tau = unit_rand_uniform(g, 0.01, 0.1);
	p->delay = (int)unit_rand_uniform(g, 0.0, 4.0);
	p->delay = p->delay > 3 ? 3 : p->delay;
	p->hover = unit_rand_uniform(g, 0.35, 0.6);
	p->amp = unit_rand_uniform(g, 0.03, 0.09);
	p->noise = unit_rand_uniform(g, 0.002, 0.02);
	p->clock = (int)unit_rand_uniform(g, 5.0, 15.0);
	p->frames = 1800;
}

static bool rotor_run(struct unit_rng *g, const struct rotor_run *p, struct stat st[5], bool hold_frames)
{
	struct ident_rotor_cfg cfg;
	memset(&cfg, 0, sizeof cfg);
	cfg.dt_s = SC(1.0 / 90.0);
	cfg.mot_tau_s = sc_from_float((float)p->tau);
	cfg.delay_frames = (uint32_t)p->delay;
	cfg.curve = sc_from_float((float)p->c);
	cfg.thr0 = sc_from_float((float)p->hover);
	cfg.kf0 = (float)(p->kf * unit_rand_uniform(g, 0.7, 1.43));
	cfg.ktau0 = (float)(p->kt * unit_rand_uniform(g, 0.7, 1.43));
	struct ident_rotor rot; /* on the stack: M0's 16 KB of RAM have no room for statics */
	ident_rotor_init(&rot, &cfg);
	struct rotor_ref rr;
	rotor_ref_init(&rr, &cfg);
	double hist[5], s_true = d(cfg.thr0), thr = s_true, a_true = 1.0 - exp(-DT / p->tau);
	for (int i = 0; i < 5; i++)
		hist[i] = s_true;
	for (long k = 0; k < p->frames; k++) {
		if (p->amp > 0 && k % p->clock == 0)
			thr = p->hover + (unit_rand_uniform(g, 0, 1) < 0.5 ? -p->amp : p->amp);
		scalar_t sent = sc_from_float((float)thr);
		memmove(&hist[1], &hist[0], 4 * sizeof hist[0]);
		hist[0] = d(sent);
		s_true += a_true * (hist[1 + p->delay] - s_true);
		double f = p->kf * g_curve(p->c, s_true) + p->noise * p->kf * p->hover * unit_rand_normal(g);
		double tq = p->kt * g_curve(p->c, s_true) + p->noise * p->kt * p->hover * unit_rand_normal(g);
		scalar_t fm = sc_from_float((float)f), tm = sc_from_float((float)tq);
		scalar_t prev = sc_from_float((float)hist[1]);
		if (hold_frames && unit_rand_uniform(g, 0, 1) < 0.01) {
			ident_rotor_hold(&rot, prev);
			rotor_ref_advance(&rr, d(prev));
			rr.have_prev = false;
			continue;
		}
		ident_rotor_update(&rot, prev, fm, tm, true);
		rotor_ref_update(&rr, d(prev), d(fm), d(tm));
	}
	stat_add(&st[0], (double)ident_rotor_est(&rot, 0), rr.lag.th[0][0]);
	stat_add(&st[1], (double)ident_rotor_est(&rot, 1), rr.lag.th[1][0]);
	stat_add(&st[2], (double)ident_rotor_plain(&rot, 0), rr.plain.th[0][0]);
	stat_add(&st[3], (double)ident_rotor_plain(&rot, 1), rr.plain.th[1][0]);
	if (p->amp > 0)
		stat_add(&st[4], (double)ident_rotor_tau_check(&rot), rotor_ref_tau(&rr));
	return rot.lagaware.n_resets == 0 && rot.plain.n_resets == 0 && fabs(rr.lag.th[0][0] / p->kf - 1.0) < 0.01 &&
	       fabs(rr.lag.th[1][0] / p->kt - 1.0) < 0.01;
}

UNIT_TEST(ident_ref_rotor_monte_carlo)
{
	struct unit_rng g = {0x1de7f00dULL};
	struct stat st[5];
	memset(st, 0, sizeof st);
	int runs = TRIALS(40), bad = 0;
	for (int run = 0; run < runs; run++) {
		struct rotor_run p;
		rotor_draw(&g, &p);
		bad += !rotor_run(&g, &p, st, true);
	}
	printf("ident_ref rotor, %d runs: vs float64 max/rms: k_f %.2e/%.2e k_tau %.2e/%.2e plain k_f %.2e/%.2e "
	       "plain k_tau %.2e/%.2e lag check %.2e/%.2e\n",
	       runs, st[0].max, stat_rms(&st[0]), st[1].max, stat_rms(&st[1]), st[2].max, stat_rms(&st[2]), st[3].max,
	       stat_rms(&st[3]), st[4].max, stat_rms(&st[4]));
	CHECK(bad == 0); /* the reference found the truth, the firmware never reset */
	for (int i = 0; i < 4; i++)
		if (!(st[i].max < REL_BOUND))
			unit_fail(u, __FILE__, __LINE__, "estimate %d: %.3g from float64 (bound %.3g)", i, st[i].max,
				  REL_BOUND);
	CHECK(st[4].max < REL_BOUND); /* the lag check's tau_m */
}

/* Two hours of hover without dither (the regressor constant but for the noise): P shrinks by
 * ten decades; nothing overflows, resets or stalls, and the estimates stay on float64 */
UNIT_TEST(ident_ref_rotor_long_hover)
{
	struct unit_rng g = {0x40e7b0a7ULL};
	struct stat st[5];
	memset(st, 0, sizeof st);
	struct rotor_run p;
	rotor_draw(&g, &p);
	p.amp = 0.0;
	p.frames = LONG_S(2L * 3600L) * FPS;
	CHECK(rotor_run(&g, &p, st, false));
	printf("ident_ref rotor hover %ld frames: vs float64 k_f %.2e k_tau %.2e plain %.2e %.2e\n", p.frames,
	       st[0].max, st[1].max, st[2].max, st[3].max);
	for (int i = 0; i < 4; i++)
		CHECK(st[i].max < REL_BOUND);
}

/* ---------------------------------------------------------------- inertia reference */
struct svf_ref {
	double a12, a22, b1, b2, y, ydot, u_prev;
};

static void svf_ref_init(struct svf_ref *f, double wc, double zeta, double y0)
{
	double w = fmin(fmax(wc, 1e-3 / DT), 2.0 / DT), z = fmax(zeta, 0.05), h = DT / 2;
	double wh = w * h, det = 1.0 + 2.0 * z * wh + wh * wh;
	f->b1 = wh * wh / det;
	f->b2 = wh * w / det;
	f->a12 = 2.0 * h / det;
	f->a22 = (1.0 - 2.0 * z * wh - wh * wh) / det;
	f->y = f->u_prev = y0;
	f->ydot = 0.0;
}

static double svf_ref_update(struct svf_ref *f, double u)
{
	double err = u + f->u_prev - 2.0 * f->y;
	double y1 = f->y + f->a12 * f->ydot + f->b1 * err;
	f->ydot = f->a22 * f->ydot + f->b2 * err;
	f->y = y1;
	f->u_prev = u;
	return y1;
}

struct inertia_ref {
	int ax, s_n, b_len, lags, n_ring, r_ring, r_on;
	double coupling, alpha, tau_prev, ww_prev, wf_prev, z_in, i0;
	struct svf_ref tau, w, ww, z;
	struct ref rls;
	double s_zy, s_zp;
	/* the std's lag products (ident.h), newest first in the ring */
	double rz[IDENT_INR_LAGS], rr[IDENT_INR_LAGS], rp[IDENT_INR_LAGS];
	double c_zz[IDENT_INR_LAGS + 1], c_rr[IDENT_INR_LAGS + 1], c_rp[IDENT_INR_LAGS + 1], c_pp[IDENT_INR_LAGS + 1];
	double c_rn[IDENT_INR_LAGS + 1];
};

static void inertia_ref_init(struct inertia_ref *r, int ax, double wc, double zeta, double alpha,
			     const scalar_t inertia[3])
{
	memset(r, 0, sizeof *r);
	int j = (ax + 1) % 3, k = (ax + 2) % 3;
	r->ax = ax;
	r->coupling = d(inertia[k]) - d(inertia[j]);
	r->alpha = alpha;
	r->b_len = (int)(0.5 / DT + 0.5);
	r->lags = (int)fmin(5.0 / (zeta * wc * DT) + 1.0, IDENT_INR_LAGS);
	svf_ref_init(&r->tau, wc, zeta, 0.0);
	svf_ref_init(&r->w, wc, zeta, 0.0);
	svf_ref_init(&r->ww, wc, zeta, 0.0);
	svf_ref_init(&r->z, wc, zeta, 0.0);
	const double th0[1][4] = {{d(inertia[ax])}};
	ref_init(&r->rls, 1, 1, 1e4, 1.0, th0);
}

static void inertia_ref_update(struct inertia_ref *r, const double tau[3], const double w[3])
{
	int i = r->ax, j = (i + 1) % 3, k = (i + 2) % 3;
	double ww = w[j] * w[k];
	svf_ref_update(&r->tau, r->tau_prev + r->alpha * (tau[i] - r->tau_prev));
	svf_ref_update(&r->ww, 0.5 * (ww + r->ww_prev));
	svf_ref_update(&r->w, w[i]);
	r->tau_prev = tau[i];
	r->ww_prev = ww;
	double y = r->tau.y - r->coupling * r->ww.y, phi = (r->w.y - r->wf_prev) / DT;
	r->wf_prev = r->w.y;
	ref_update(&r->rls, &phi, &y);
	double z = svf_ref_update(&r->z, r->z_in);
	r->s_zy += z * y;
	r->s_zp += z * phi;
	if (!r->r_on && ++r->s_n >= r->b_len && r->s_zp != 0.0) {
		r->i0 = d(sc_from_float((float)(r->s_zy / r->s_zp))); /* as the firmware keeps it */
		r->r_on = 1;
	}
	double res = r->r_on ? y - r->i0 * phi : 0.0;
	int nz = r->n_ring < r->lags ? r->n_ring : r->lags, nr = r->r_ring < nz ? r->r_ring : nz;
	r->c_zz[0] += z * z;
	if (r->r_on) {
		r->c_rr[0] += res * res;
		r->c_rp[0] += 2.0 * res * phi;
		r->c_pp[0] += phi * phi;
		r->c_rn[0] += 1.0;
	}
	for (int h = 1; h <= nz; h++) {
		r->c_zz[h] += z * r->rz[h - 1];
		if (h <= nr) {
			r->c_rr[h] += res * r->rr[h - 1];
			r->c_rp[h] += res * r->rp[h - 1] + phi * r->rr[h - 1];
			r->c_pp[h] += phi * r->rp[h - 1];
			r->c_rn[h] += 1.0;
		}
	}
	memmove(r->rz + 1, r->rz, (IDENT_INR_LAGS - 1) * sizeof r->rz[0]);
	memmove(r->rr + 1, r->rr, (IDENT_INR_LAGS - 1) * sizeof r->rr[0]);
	memmove(r->rp + 1, r->rp, (IDENT_INR_LAGS - 1) * sizeof r->rp[0]);
	r->rz[0] = z;
	r->rr[0] = res;
	r->rp[0] = phi;
	r->n_ring += r->n_ring < (int)IDENT_INR_LAGS;
	r->r_ring += r->r_on && r->r_ring < (int)IDENT_INR_LAGS;
}

static double inertia_ref_est(const struct inertia_ref *r) { return r->s_zy / r->s_zp; }

/* var(I) (sum z phi)^2 = sum_h w_h Z(h) R(h), R(h) about the estimate (ident.h) */
static double inertia_ref_sd(const struct inertia_ref *r)
{
	double dd = inertia_ref_est(r) - r->i0, v = 0.0;
	for (int h = 0; h <= r->lags && r->c_rn[h] > 0.0; h++)
		v += (h ? 2.0 : 1.0) * r->c_zz[h] * (r->c_rr[h] - dd * r->c_rp[h] + dd * dd * r->c_pp[h]) / r->c_rn[h];
	return sqrt(fmax(v, 0.0)) / fabs(r->s_zp);
}

/* The vehicle's rotation about its three axes (Euler's equations, diagonal inertia) under a
 * rate damper on the measured (noisy) gyro plus the experiment's PRBS torque on one axis and
 * a smaller one on the others; the rotor torque follows the commanded one through the motor
 * lag tau_m. Integrated in sub-steps (the lag exactly, the rates by the midpoint rule). */
struct inertia_run {
	int ax, clock;
	double in[3], tau_m, wc, amp, sig_t, sig_g;
	long frames, quiet; /* frames of the experiment, then of hover without excitation first */
};

static void inertia_draw(struct unit_rng *g, int ax, struct inertia_run *p)
{
	static const double nominal[3] = {0.0628, 0.0762, 0.1014};
	p->ax = ax;
	for (int i = 0; i < 3; i++)
		p->in[i] = nominal[i] * unit_rand_uniform(g, 0.7, 1.3);
	p->tau_m = unit_rand_uniform(g, 0.01, 0.1);
	p->wc = unit_rand_uniform(g, 8.0, 30.0);
	p->amp = p->in[ax] * unit_rand_uniform(g, 3.0, 10.0); /* N m: 3-10 rad/s^2 */
	p->sig_t = unit_rand_uniform(g, 0.001, 0.005);
	p->sig_g = unit_rand_uniform(g, 0.001, 0.02);
	p->clock = (int)unit_rand_uniform(g, 4.0, 12.0);
	p->frames = (long)unit_rand_uniform(g, 900.0, 2700.0);
	p->quiet = 0;
}

/* returns false when the reference misses the truth by more than 3 %; stat[0]: IV estimate,
 * [1]: the least-squares (RLS) estimate, [2]: the IV std */
static bool inertia_run(struct unit_rng *g, const struct inertia_run *p, struct stat st[3], int sub)
{
	int ax = p->ax;
	scalar_t inertia[3], zero[3] = {0, 0, 0};
	for (int i = 0; i < 3; i++) /* the two others near the truth (they enter the gyroscopic term) */
		inertia[i] = sc_from_float((float)(p->in[i] * (i == ax ? unit_rand_uniform(g, 0.7, 1.43)
								       : unit_rand_uniform(g, 0.99, 1.01))));
	scalar_t alpha = ident_torque_weight(sc_from_float((float)p->tau_m), SC(1.0 / 90.0));
	scalar_t wc = sc_from_float((float)p->wc), zeta = SC(0.7);
	struct ident_inertia e;
	ident_inertia_init(&e, (unsigned)ax, wc, zeta, SC(1.0 / 90.0), alpha, inertia, zero, zero);
	struct inertia_ref r;
	inertia_ref_init(&r, ax, d(wc), d(zeta), d(alpha), inertia);
	double w[3] = {0, 0, 0}, tq[3] = {0, 0, 0}, wm[3] = {0, 0, 0}, uex[3] = {0, 0, 0}, cmd[3];
	double h = DT / sub, el = exp(-h / p->tau_m), elh = exp(-0.5 * h / p->tau_m);
	for (long k = 0; k < p->quiet + p->frames; k++) {
		bool exc = k >= p->quiet;
		/* the command held over this frame: damper on the measured rates plus excitation */
		for (int i = 0; i < 3; i++) {
			if (k % p->clock == 0)
				uex[i] = !exc ? 0.0
					      : (unit_rand_uniform(g, 0, 1) < 0.5 ? -1.0 : 1.0) * p->amp *
							 (i == ax ? 1.0 : 0.2);
			cmd[i] = uex[i] - 4.0 * p->in[i] * wm[i];
		}
		for (int s = 0; s < sub; s++) {
			double tm[3], wmid[3];
			for (int i = 0; i < 3; i++)
				tm[i] = cmd[i] + (tq[i] - cmd[i]) * elh;
			for (int i = 0; i < 3; i++) {
				int j = (i + 1) % 3, kk = (i + 2) % 3;
				wmid[i] = w[i] + 0.5 * h * (tq[i] - (p->in[kk] - p->in[j]) * w[j] * w[kk]) / p->in[i];
			}
			for (int i = 0; i < 3; i++) {
				int j = (i + 1) % 3, kk = (i + 2) % 3;
				w[i] += h * (tm[i] - (p->in[kk] - p->in[j]) * wmid[j] * wmid[kk]) / p->in[i];
			}
			for (int i = 0; i < 3; i++)
				tq[i] = cmd[i] + (tq[i] - cmd[i]) * el;
		}
		/* the frame's measurements and the excitation that acted over it */
		scalar_t tb[3], wb[3];
		double tbd[3], wbd[3];
		for (int i = 0; i < 3; i++) {
			tb[i] = sc_from_float((float)(tq[i] + p->sig_t * unit_rand_normal(g)));
			wb[i] = sc_from_float((float)(w[i] + p->sig_g * unit_rand_normal(g)));
			tbd[i] = d(tb[i]);
			wbd[i] = d(wb[i]);
			wm[i] = wbd[i];
		}
		scalar_t z = sc_from_float((float)uex[ax]);
		ident_inertia_instrument(&e, z);
		ident_inertia_update(&e, tb, wb, true);
		r.z_in = d(z);
		inertia_ref_update(&r, tbd, wbd);
	}
	stat_add(&st[0], (double)ident_inertia_est(&e), inertia_ref_est(&r));
	stat_add(&st[1], (double)rls_estimate_f(&e.rls, 0, 0), r.rls.th[0][0]);
	stat_add(&st[2], (double)ident_inertia_sd(&e), inertia_ref_sd(&r));
	return e.rls.n_resets == 0 && fabs(inertia_ref_est(&r) / p->in[ax] - 1.0) < 0.03;
}

UNIT_TEST(ident_ref_inertia_monte_carlo)
{
	struct unit_rng g = {0x1e271a5eULL};
	struct stat st[3];
	memset(st, 0, sizeof st);
	int runs = TRIALS(30), bad = 0;
	for (int run = 0; run < runs; run++) {
		struct inertia_run p;
		inertia_draw(&g, run % 3, &p);
		bad += !inertia_run(&g, &p, st, 8);
	}
	printf("ident_ref inertia, %d runs: vs float64 max/rms: IV %.2e/%.2e LS %.2e/%.2e IV sd %.2e/%.2e\n", runs,
	       st[0].max, stat_rms(&st[0]), st[1].max, stat_rms(&st[1]), st[2].max, stat_rms(&st[2]));
	CHECK(bad == 0);
	if (!(st[0].max < REL_BOUND && st[1].max < REL_BOUND))
		unit_fail(u, __FILE__, __LINE__, "inertia: IV %.3g, LS %.3g from float64 (bound %.3g)", st[0].max,
			  st[1].max, REL_BOUND);
	CHECK(st[2].max < SD_BOUND);
}

/* An hour of hover without excitation (the instrument zero, the estimator running), then an
 * hour-long experiment (ID_INR_TIME = 3600 s: 324,000 frames in the sums): no overflow, wrap
 * or stall, and the estimate on float64 */
UNIT_TEST(ident_ref_inertia_long)
{
	struct unit_rng g = {0x1e2704ULL};
	struct stat st[3];
	memset(st, 0, sizeof st);
	struct inertia_run p;
	inertia_draw(&g, 1, &p);
	p.quiet = LONG_S(3600L) * FPS;
	p.frames = LONG_S(3600L) * FPS;
	CHECK(inertia_run(&g, &p, st, 2));
	printf("ident_ref inertia %ld + %ld frames: vs float64 IV %.2e LS %.2e IV sd %.2e\n", p.quiet, p.frames,
	       st[0].max, st[1].max, st[2].max);
	CHECK(st[0].max < REL_BOUND);
	CHECK(st[1].max < REL_BOUND);
	CHECK(st[2].max < SD_BOUND);
}

/* ---------------------------------------------------------------- validation statistics */
UNIT_TEST(ident_ref_fit)
{
	struct unit_rng g = {0xf17ULL};
	double worst_ne = 0, worst_pct = 0;
	for (int run = 0; run < TRIALS(10); run++) {
		double mean = unit_rand_uniform(&g, 5.0, 60.0), amp = mean * unit_rand_uniform(&g, 0.005, 0.1);
		double err = amp * unit_rand_uniform(&g, 0.01, 0.5);
		struct ident_fit v;
		ident_fit_init(&v);
		double n = 0, sy = 0, syy = 0, sse = 0;
		long frames = run == 0 ? LONG_S(3600L) * FPS : 900;
		for (long k = 0; k < frames; k++) {
			double y = mean + amp * sin(0.05 * (double)k) + err * unit_rand_normal(&g);
			scalar_t ys = sc_from_float((float)y),
				 yh = sc_from_float((float)(mean + amp * sin(0.05 * (double)k)));
			ident_fit_add(&v, ys, yh);
			double a = d(ys), b = d(yh);
			n += 1;
			sy += a;
			syy += a * a;
			sse += (a - b) * (a - b);
		}
		double m2 = syy - sy * sy / n, ne = sqrt(sse / syy), pct = 100.0 * (1.0 - sqrt(sse / m2));
		worst_ne = fmax(worst_ne, fabs((double)ident_fit_ne(&v) / ne - 1.0));
		worst_pct = fmax(worst_pct, fabs((double)ident_fit_pct(&v) - pct));
	}
	printf("ident_ref fit: NE %.2e relative, fit %.2e %% from float64\n", worst_ne, worst_pct);
	CHECK(worst_ne < 1e-4);
	CHECK(worst_pct < 1e-2);
}

/* ---------------------------------------------------------------- saturation */

/* q_mul64_64 against exact products */
UNIT_TEST(ident_ref_q_mul64_64)
{
	struct unit_rng g = {0x64646464ULL};
	for (int t = 0; t < 2000; t++) {
		/* magnitudes from 2^0 to 2^62, either sign */
		int ea = (int)unit_rand_uniform(&g, 0, 62), eb = (int)unit_rand_uniform(&g, 0, 62);
		int64_t a = (int64_t)(unit_rand_uniform(&g, -1, 1) * ldexp(1.0, ea));
		int64_t b = (int64_t)(unit_rand_uniform(&g, -1, 1) * ldexp(1.0, eb));
		unsigned s = (unsigned)unit_rand_uniform(&g, 32, 62.99);
		int64_t r = q_mul64_64(a, b, s);
		double exact = (double)a * (double)b * ldexp(1.0, -(int)s);
		if (fabs(exact) >= ldexp(1.0, 63))
			CHECK(r == (exact > 0 ? INT64_MAX : -INT64_MAX)); /* saturates, never wraps */
		else
			CHECK(fabs((double)r - exact) <= 1.5 + fabs(exact) * 4e-16);
	}
	CHECK(q_mul64_64(INT64_MAX, INT64_MAX, 32) == INT64_MAX);
	CHECK(q_mul64_64(-INT64_MAX, INT64_MAX, 62) == -INT64_MAX);
	CHECK(q_mul64_64((int64_t)1 << 40, (int64_t)1 << 40, 32) == (int64_t)1 << 48);
	CHECK(q_mul64_64(-((int64_t)3 << 31), (int64_t)1 << 32, 32) == -((int64_t)3 << 31));
}

/* The largest inputs every frame: the sums saturate and stay there (never wrap to the other
 * sign), the read-outs stay finite, and the estimators still run */
UNIT_TEST(ident_saturating_inputs)
{
	/* the top of Q16.16 (in the float build, merely large) */
	const scalar_t big_p = SC(32767.0), big_n = SC(-32767.0);
	/* inertia: torque, rates and the instrument at the top of the range */
	scalar_t inertia[3] = {SC(0.06), SC(0.07), SC(0.1)}, zero[3] = {0, 0, 0};
	struct ident_inertia e;
	ident_inertia_init(&e, 0, SC(25.0), SC(0.7), SC(1.0 / 90.0), SC(0.5), inertia, zero, zero);
	ident_sum_t prev = 0;
	bool monotonic = true;
	for (long k = 0; k < 20000; k++) {
		scalar_t big = (k / 100) % 2 ? big_p : big_n;
		scalar_t tb[3] = {big, big, big}, wb[3] = {big, big_p, big_n};
		ident_inertia_instrument(&e, big);
		ident_inertia_update(&e, tb, wb, true);
		ident_inertia_process(&e);
		monotonic = monotonic && e.c_zz[0] >= prev;
		prev = e.c_zz[0];
	}
	CHECK(monotonic); /* a sum of squares only grows, or stays at its saturation */
	CHECK(e.c_zz[0] > 0 && e.c_pp[0] > 0 && e.r_on);
	CHECK(isfinite(ident_inertia_est(&e)) && isfinite(ident_inertia_sd(&e)));
	CHECK(e.n == 20000u);
	/* validation: the largest errors saturate the sums */
	struct ident_fit v;
	ident_fit_init(&v);
	for (long k = 0; k < 1000; k++)
		ident_fit_add(&v, k % 2 ? big_p : big_n, k % 2 ? big_n : big_p);
	CHECK(v.sse > 0 && v.s2 > 0);
#if OCTO_FIXED
	CHECK(v.sse == INT64_MAX && e.c_zz[0] == INT64_MAX);
#endif
	CHECK(isfinite(ident_fit_ne(&v)) && isfinite(ident_fit_pct(&v)));
	/* rotor: throttles and measurements at both ends, then ordinary data: it still updates */
	struct ident_rotor_cfg cfg;
	memset(&cfg, 0, sizeof cfg);
	cfg.dt_s = SC(1.0 / 90.0);
	cfg.mot_tau_s = SC(0.03);
	cfg.delay_frames = 1;
	cfg.curve = SC(0.3);
	cfg.thr0 = SC(0.5);
	cfg.kf0 = 20.0f;
	cfg.ktau0 = 0.3f;
	struct ident_rotor r;
	ident_rotor_init(&r, &cfg);
	for (long k = 0; k < 2000; k++) {
		scalar_t big = (k / 50) % 2 ? big_p : big_n;
		ident_rotor_update(&r, big, big_p, big, true);
	}
	uint32_t n0 = r.lagaware.n_updates;
	for (long k = 0; k < 900; k++)
		ident_rotor_update(&r, k % 9 < 4 ? SC(0.45) : SC(0.55), SC(12.0), SC(0.15), true);
	CHECK(r.lagaware.n_updates > n0);
	float est[4], sd[4];
	ident_rotor_read(&r, est, sd);
	for (int i = 0; i < 4; i++)
		CHECK(isfinite(est[i]) && isfinite(sd[i]) && sd[i] >= 0.0f);
}
