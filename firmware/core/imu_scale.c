/*
 * imu_scale.c - each rotor's effectiveness from the accelerometer and the gyro against the
 * measured rotor speeds (imu_scale.h).
 */
#include "imu_scale.h"

#include <math.h>
#include <string.h>

#define N IMU_SCALE_ROTORS
#define NR IMU_SCALE_NR
#define NT IMU_SCALE_NT
#define NA IMU_SCALE_AXES
#define NP IMU_SCALE_NP
#define P_GAM N       /* gamma of axis k (1..3): P_GAM + k - 1 */
#define P_OFS (N + 3) /* offset of axis k: P_OFS + k */
#define MIN_FRAMES (10u * NR)

/* index of (i, k) (either order) in the upper triangle stored row by row */
static unsigned ut(unsigned i, unsigned k)
{
	unsigned a = i < k ? i : k, b = i < k ? k : i;
	return a * NR - a * (a - 1u) / 2u + (b - a);
}

void imu_scale_init(struct imu_scale *m, const struct imu_scale_cfg *cfg)
{
	memset(m, 0, sizeof *m);
	m->cfg = *cfg;
	m->cl_len = cfg->block_frames ? cfg->block_frames : 90u;
}

void imu_scale_step(struct imu_scale *m, const scalar_t thr[IMU_SCALE_ROTORS], const float w_rps[IMU_SCALE_ROTORS],
		    scalar_t f_n, const scalar_t rate[3], bool excited)
{
	if (m->q_pending)
		imu_scale_process(m);
	for (unsigned j = 0; j < N; j++) {
		m->q_w[j] = w_rps[j];
		m->q_thr[j] = thr[j];
	}
	m->q_f = f_n;
	for (unsigned i = 0; i < 3; i++)
		m->q_rate[i] = rate[i];
	m->q_excited = excited;
	m->q_pending = true;
}

void imu_scale_hold(struct imu_scale *m)
{
	if (m->q_pending)
		imu_scale_process(m);
	m->n_fr = 0; /* the central difference and the smoother need consecutive frames */
}

static void stat_add(struct imu_scale_stat *s, const float x[NR], const float z[NA])
{
	for (unsigned i = 0; i < NR; i++)
		for (unsigned k = i; k < NR; k++)
			s->g[ut(i, k)] += x[i] * x[k];
	for (unsigned a = 0; a < NA; a++) {
		for (unsigned i = 0; i < NR; i++)
			s->b[a][i] += x[i] * z[a];
		s->zz[a] += z[a] * z[a];
	}
}

/* a block's sums into the run's (double) */
static void dstat_add(struct imu_scale_dstat *d, const struct imu_scale_stat *s)
{
	for (unsigned i = 0; i < NT; i++)
		d->g[i] += (double)s->g[i];
	for (unsigned a = 0; a < NA; a++) {
		for (unsigned i = 0; i < NR; i++)
			d->b[a][i] += (double)s->b[a][i];
		d->zz[a] += (double)s->zz[a];
	}
}

/* a frame into the current block; a full set of blocks merges in pairs */
static void cl_add(struct imu_scale *m, const float x[NR], const float z[NA])
{
	stat_add(&m->blk[m->nb], x, z);
	if (++m->cl_k < m->cl_len)
		return;
	dstat_add(&m->all, &m->blk[m->nb]);
	m->cl_k = 0;
	if (++m->nb < IMU_SCALE_BLOCKS)
		return;
	for (unsigned k = 0; k < IMU_SCALE_BLOCKS / 2u; k++) {
		struct imu_scale_stat t = m->blk[2u * k];
		const struct imu_scale_stat *p1 = &m->blk[2u * k + 1u];
		for (unsigned i = 0; i < NT; i++)
			t.g[i] += p1->g[i];
		for (unsigned a = 0; a < NA; a++) {
			for (unsigned i = 0; i < NR; i++)
				t.b[a][i] += p1->b[a][i];
			t.zz[a] += p1->zz[a];
		}
		m->blk[k] = t;
	}
	memset(&m->blk[IMU_SCALE_BLOCKS / 2u], 0, (IMU_SCALE_BLOCKS / 2u + 1u) * sizeof m->blk[0]);
	m->nb = IMU_SCALE_BLOCKS / 2u;
	m->cl_len *= 2u;
}

void imu_scale_process(struct imu_scale *m)
{
	if (!m->q_pending)
		return;
	m->q_pending = false;
	float x[N], sw = 0.0f;
	bool ok = true;
	for (unsigned j = 0; j < N; j++) {
		float w = m->q_w[j];
		ok = ok && isfinite(w) && w >= 0.0f;
		x[j] = ok ? w * w : 0.0f;
		sw += x[j];
	}
	float f = sc_to_float(m->q_f);
	if (!ok || !isfinite(f)) {
		if (m->q_excited)
			m->lost = true;
		m->n_fr = 0;
		return;
	}
	if (!m->have_ref) { /* the centring point keeps the float sums' precision */
		if (!(sw > 0.0f)) {
			m->n_fr = 0;
			return;
		}
		m->w2_ref = sw / (float)N;
		for (unsigned j = 0; j < N; j++)
			m->x0[j] = x[j] / m->w2_ref;
		m->f0 = f;
		m->have_ref = true;
	}
	if (m->n_fr == 0u) { /* a new run of consecutive frames */
		memset(m->sx, 0, sizeof m->sx);
		m->sf = 0.0f;
	}
	const unsigned h = (m->rh + 1u) % IMU_SCALE_WIN; /* the new frame's slot: the oldest's */
	const bool full = m->n_fr >= IMU_SCALE_WIN;
	for (unsigned j = 0; j < N; j++) {
		float xj = x[j] / m->w2_ref - m->x0[j];
		m->sx[j] += xj - (full ? m->xr[h][j] : 0.0f);
		m->xr[h][j] = xj;
		if (m->q_excited) {
			float y = sc_to_float(m->q_thr[j]);
			m->sw2[j] += x[j] / m->w2_ref;
			m->sy[j] += y;
			m->syy[j] += y * y;
		}
	}
	m->sf += (f - m->f0) - (full ? m->fr[h] : 0.0f);
	m->fr[h] = f - m->f0;
	for (unsigned i = 0; i < 3; i++)
		m->rr3[h][i] = sc_to_float(m->q_rate[i]);
	m->er[h] = m->q_excited;
	m->rh = h;
	if (m->n_fr < IMU_SCALE_WIN)
		m->n_fr++;
	if (m->n_fr < IMU_SCALE_WIN)
		return;
	if (h == 0u) { /* once a lap the running sums afresh: their rounding does not build up */
		memset(m->sx, 0, sizeof m->sx);
		m->sf = 0.0f;
		for (unsigned d = 0; d < IMU_SCALE_WIN; d++) {
			for (unsigned j = 0; j < N; j++)
				m->sx[j] += m->xr[d][j];
			m->sf += m->fr[d];
		}
	}
	if (!m->er[(h + IMU_SCALE_WIN - IMU_SCALE_HALF) % IMU_SCALE_WIN])
		return;
	/* the window's middle frame: the rates' change over the window (the torque's integral
	 * over it) against the regressors' trapezoid mean over the same frames, and the force's
	 * trapezoid mean (one filter on both sides). The closed loop feeds the gyro's noise back
	 * into the speeds within a few frames: over a long window that feedback is a small share
	 * of the speeds' change, and the rates' noise enters only at the window's two ends. */
	const unsigned o = (h + 1u) % IMU_SCALE_WIN; /* the oldest */
	float xs[NR], z[NA], hg = 1.0f / (2.0f * (float)IMU_SCALE_HALF * m->cfg.dt_s),
			     wt = 0.5f / (float)IMU_SCALE_HALF;
	for (unsigned j = 0; j < N; j++)
		xs[j] = wt * (m->sx[j] - 0.5f * (m->xr[h][j] + m->xr[o][j]));
	xs[N] = 1.0f;
	z[0] = wt * (m->sf - 0.5f * (m->fr[h] + m->fr[o]));
	for (unsigned i = 0; i < 3; i++)
		z[1u + i] = hg * (m->rr3[h][i] - m->rr3[o][i]);
	m->n++;
	cl_add(m, xs, z);
}

/* ---------------------------------------------------------------- the solve (double) */

/* Cholesky of the n x n matrix a (row stride NP) with the columns scaled to unit diagonal;
 * into l and d; false if not positive definite */
static bool chol(unsigned n, const double a[][NP], double l[][NP], double d[NP])
{
	for (unsigned i = 0; i < n; i++) {
		if (!(a[i][i] > 0.0) || !isfinite(a[i][i]))
			return false;
		d[i] = 1.0 / sqrt(a[i][i]);
	}
	for (unsigned k = 0; k < n; k++) {
		double v = a[k][k] * d[k] * d[k];
		for (unsigned q = 0; q < k; q++)
			v -= l[k][q] * l[k][q];
		if (!(v > 1e-13))
			return false;
		l[k][k] = sqrt(v);
		for (unsigned i = k + 1u; i < n; i++) {
			double w = a[i][k] * d[i] * d[k];
			for (unsigned q = 0; q < k; q++)
				w -= l[i][q] * l[k][q];
			l[i][k] = w / l[k][k];
		}
	}
	return true;
}

/* solves a u = r with the factor of chol */
static void chol_solve(unsigned n, const double l[][NP], const double d[NP], const double r[NP], double u[NP])
{
	double y[NP];
	for (unsigned i = 0; i < n; i++) {
		double w = r[i] * d[i];
		for (unsigned q = 0; q < i; q++)
			w -= l[i][q] * y[q];
		y[i] = w / l[i][i];
	}
	for (unsigned i = n; i-- > 0;) {
		double w = y[i];
		for (unsigned q = i + 1u; q < n; q++)
			w -= l[q][i] * u[q];
		u[i] = w / l[i][i];
	}
	for (unsigned i = 0; i < n; i++)
		u[i] *= d[i];
}

/* the inverse of the n x n positive definite a into v; false if singular */
static bool inv_spd(unsigned n, const double a[][NP], double v[][NP])
{
	double l[NP][NP] = {{0}}, d[NP];
	if (!chol(n, a, l, d))
		return false;
	for (unsigned c = 0; c < n; c++) {
		double e[NP] = {0}, u[NP];
		e[c] = 1.0;
		chol_solve(n, l, d, e, u);
		for (unsigned i = 0; i < n; i++)
			v[i][c] = u[i];
	}
	return true;
}

/* the run's sums (the completed blocks' and the block being filled) in full */
static void unpack_all(const struct imu_scale *m, double g[NR][NP], double b[NA][NR], double zz[NA])
{
	const struct imu_scale_stat *p = &m->blk[m->nb];
	for (unsigned i = 0; i < NR; i++)
		for (unsigned k = 0; k < NR; k++)
			g[i][k] = m->all.g[ut(i, k)] + (double)p->g[ut(i, k)];
	for (unsigned a = 0; a < NA; a++) {
		for (unsigned i = 0; i < NR; i++)
			b[a][i] = m->all.b[a][i] + (double)p->b[a][i];
		zz[a] = m->all.zz[a] + (double)p->zz[a];
	}
}

/* a block's sums' Gram matrix in full, and b */
static void unpack(const struct imu_scale_stat *s, double g[NR][NP], double b[NA][NR])
{
	for (unsigned i = 0; i < NR; i++)
		for (unsigned k = 0; k < NR; k++)
			g[i][k] = (double)s->g[ut(i, k)];
	for (unsigned a = 0; a < NA; a++)
		for (unsigned i = 0; i < NR; i++)
			b[a][i] = (double)s->b[a][i];
}

/* the model's coefficients of axis a on (x, 1), and their Jacobian in the parameters p */
static void beta_of(const struct imu_scale_cfg *c, const double p[NP], unsigned a, double beta[NR], double jac[NR][NP])
{
	memset(jac, 0, NR * sizeof jac[0]);
	for (unsigned j = 0; j < N; j++) {
		double gj = a == 0u ? 1.0 : (double)c->geo[a - 1u][j];
		double gam = a == 0u ? 1.0 : p[P_GAM + a - 1u];
		beta[j] = gam * gj * p[j];
		jac[j][j] = gam * gj;
		if (a > 0u)
			jac[j][P_GAM + a - 1u] = gj * p[j];
	}
	beta[N] = p[P_OFS + a];
	jac[N][P_OFS + a] = 1.0;
}

/* the score of one set of sums: sum_a J_a' (b_a - G beta_a) / s2_a */
static void score(const struct imu_scale_cfg *c, const double g[NR][NP], const double b[NA][NR], const double p[NP],
		  const double w[NA], const bool on[NA], double u[NP])
{
	memset(u, 0, NP * sizeof u[0]);
	for (unsigned a = 0; a < NA; a++) {
		if (!on[a])
			continue;
		double beta[NR], jac[NR][NP], r[NR];
		beta_of(c, p, a, beta, jac);
		for (unsigned i = 0; i < NR; i++) {
			r[i] = b[a][i];
			for (unsigned k = 0; k < NR; k++)
				r[i] -= g[i][k] * beta[k];
		}
		for (unsigned q = 0; q < NP; q++)
			for (unsigned i = 0; i < NR; i++)
				u[q] += jac[i][q] * r[i] * w[a];
	}
}

/* the Gauss-Newton matrix sum_a J_a' G J_a / s2_a; the parameters of axes not used pinned */
static void hess(const struct imu_scale_cfg *c, const double g[NR][NP], const double p[NP], const double w[NA],
		 const bool on[NA], double hm[NP][NP])
{
	memset(hm, 0, NP * sizeof hm[0]);
	for (unsigned a = 0; a < NA; a++) {
		if (!on[a]) {
			if (a > 0u)
				hm[P_GAM + a - 1u][P_GAM + a - 1u] = 1.0;
			hm[P_OFS + a][P_OFS + a] = 1.0;
			continue;
		}
		double beta[NR], jac[NR][NP], gj[NR][NP];
		beta_of(c, p, a, beta, jac);
		for (unsigned i = 0; i < NR; i++)
			for (unsigned q = 0; q < NP; q++) {
				gj[i][q] = 0.0;
				for (unsigned k = 0; k < NR; k++)
					gj[i][q] += g[i][k] * jac[k][q];
			}
		for (unsigned q = 0; q < NP; q++)
			for (unsigned s = 0; s < NP; s++) {
				double v = 0.0;
				for (unsigned i = 0; i < NR; i++)
					v += jac[i][q] * gj[i][s];
				hm[q][s] += v * w[a];
			}
	}
}

/* least squares of z on two combinations (v, 1) of the regressors: coefficients k1, k2 */
static bool fit2(const double g[NR][NP], const double b[NR], const double v[N], double *k1, double *k2)
{
	double s11 = 0.0, s12 = 0.0, r1 = 0.0;
	for (unsigned i = 0; i < N; i++) {
		for (unsigned k = 0; k < N; k++)
			s11 += v[i] * g[i][k] * v[k];
		s12 += v[i] * g[i][N];
		r1 += v[i] * b[i];
	}
	double s22 = g[N][N], r2 = b[N], det = s11 * s22 - s12 * s12;
	if (!(det > 0.0) || !isfinite(det))
		return false;
	*k1 = (r1 * s22 - r2 * s12) / det;
	*k2 = (r2 * s11 - r1 * s12) / det;
	return true;
}

/* median of the N coefficients (the mean of the middle two, or the middle one); their
 * indices in *ia, *ib */
static double median_of(const double v[N], unsigned *ia, unsigned *ib)
{
	unsigned idx[N];
	for (unsigned j = 0; j < N; j++)
		idx[j] = j;
	for (unsigned i = 1; i < N; i++)
		for (unsigned k = i; k > 0 && v[idx[k - 1u]] > v[idx[k]]; k--) {
			unsigned t = idx[k];
			idx[k] = idx[k - 1u];
			idx[k - 1u] = t;
		}
	*ia = idx[(N - 1u) / 2u];
	*ib = idx[N / 2u];
	return 0.5 * (v[*ia] + v[*ib]);
}

/* J V J' for the scales' Jacobian js (N x NP) */
static void cov_scales(const double js[N][NP], const double v[NP][NP], float out[N][N])
{
	double jv[N][NP];
	for (unsigned i = 0; i < N; i++)
		for (unsigned t = 0; t < NP; t++) {
			jv[i][t] = 0.0;
			for (unsigned q = 0; q < NP; q++)
				jv[i][t] += js[i][q] * v[q][t];
		}
	for (unsigned i = 0; i < N; i++)
		for (unsigned k = 0; k < N; k++) {
			double s = 0.0;
			for (unsigned t = 0; t < NP; t++)
				s += jv[i][t] * js[k][t];
			out[i][k] = (float)s;
		}
}

/* The clusters' sandwich H^-1 S H^-1 G / (G - 3), S the nb blocks' score products at p, into
 * vc; with fewer than 5 blocks, H^-1 itself. */
static void sandwich(const struct imu_scale *m, unsigned nb, const double p[NP], const double w[NA], const bool on[NA],
		     const double hi[NP][NP], double vc[NP][NP])
{
	const struct imu_scale_cfg *c = &m->cfg;
	memcpy(vc, hi, sizeof(double) * NP * NP);
	if (nb < 5u)
		return;
	double sm[NP][NP] = {{0}};
	for (unsigned k = 0; k < nb; k++) {
		double gb[NR][NP], bb[NA][NR], ub[NP];
		unpack(&m->blk[k], gb, bb);
		score(c, gb, bb, p, w, on, ub);
		for (unsigned q = 0; q < NP; q++)
			for (unsigned s = 0; s < NP; s++)
				sm[q][s] += ub[q] * ub[s];
	}
	double t[NP][NP], gf = (double)nb;
	for (unsigned q = 0; q < NP; q++)
		for (unsigned s = 0; s < NP; s++) {
			t[q][s] = 0.0;
			for (unsigned k = 0; k < NP; k++)
				t[q][s] += hi[q][k] * sm[k][s];
		}
	for (unsigned q = 0; q < NP; q++)
		for (unsigned s = 0; s < NP; s++) {
			vc[q][s] = 0.0;
			for (unsigned k = 0; k < NP; k++)
				vc[q][s] += t[q][k] * hi[k][s];
			vc[q][s] *= gf / (gf - 3.0);
		}
}

void imu_scale_solve(const struct imu_scale *m, struct imu_scale_result *r)
{
	memset(r, 0, sizeof *r);
	for (unsigned j = 0; j < N; j++)
		r->scale[j] = 1.0f;
	r->n = m->n;
	r->worst = -1;
	const struct imu_scale_cfg *c = &m->cfg;
	if (m->lost) {
		r->cause = IMU_SCALE_SPEED_LOST;
		return;
	}
	r->cause = IMU_SCALE_NO_DATA;
	if (m->n < MIN_FRAMES)
		return;
	double g[NR][NP], b[NA][NR], gi[NR][NP], zz[NA];
	unpack_all(m, g, b, zz);
	if (!inv_spd(NR, g, gi))
		return;
	/* each axis' own fit: its noise variance (the weights) */
	bool on[NA];
	double s2[NA], w[NA];
	for (unsigned a = 0; a < NA; a++) {
		on[a] = a == 0u;
		for (unsigned j = 0; a > 0u && j < N; j++)
			on[a] = on[a] || c->geo[a - 1u][j] != 0.0f;
		double e = zz[a];
		for (unsigned i = 0; i < NR; i++)
			for (unsigned k = 0; k < NR; k++)
				e -= b[a][i] * gi[i][k] * b[a][k];
		s2[a] = e / (double)(m->n - NR);
		if (!(s2[a] > 0.0)) /* a response without noise (a noiseless simulation) */
			s2[a] = 1e-12 * (zz[a] / (double)m->n + 1e-12);
		w[a] = on[a] ? 1.0 / s2[a] : 0.0;
		r->noise_sd[a] = (float)sqrt(s2[a]);
	}
	/* the collective start: one coefficient for every rotor, then each axis' gain */
	double p[NP] = {0}, v1[N], k1, k2;
	for (unsigned j = 0; j < N; j++)
		v1[j] = 1.0;
	if (!fit2(g, b[0], v1, &k1, &k2) || !(k1 > 0.0))
		return;
	for (unsigned j = 0; j < N; j++)
		p[j] = k1;
	p[P_OFS] = k2;
	for (unsigned a = 1; a < NA; a++) {
		if (!on[a])
			continue;
		double vg[N];
		for (unsigned j = 0; j < N; j++)
			vg[j] = (double)c->geo[a - 1u][j] * p[j];
		if (!fit2(g, b[a], vg, &k1, &k2))
			return;
		p[P_GAM + a - 1u] = k1;
		p[P_OFS + a] = k2;
	}
	double hm[NP][NP], hi[NP][NP], u[NP], dp[NP];
	unsigned it = 0;
	for (; it < IMU_SCALE_ITERS; it++) {
		double l[NP][NP] = {{0}}, d[NP];
		hess(c, g, p, w, on, hm);
		score(c, g, b, p, w, on, u);
		if (!chol(NP, hm, l, d))
			return;
		chol_solve(NP, l, d, u, dp);
		double big = 0.0;
		for (unsigned q = 0; q < NP; q++)
			p[q] += dp[q];
		for (unsigned j = 0; j < N; j++)
			big = fmax(big, fabs(dp[j]) / fabs(p[j]));
		if (big < 1e-9)
			break;
	}
	r->iters = it;
	hess(c, g, p, w, on, hm);
	if (!inv_spd(NP, hm, hi))
		return;
	unsigned nb = m->nb + (m->cl_k * 2u >= m->cl_len ? 1u : 0u);
	r->blocks = nb;
	double vc[NP][NP];
	sandwich(m, nb, p, w, on, hi, vc);
	/* the scales c_j / median(c) and their Jacobian */
	unsigned ia, ib;
	double cj[N], js[N][NP] = {{0}};
	for (unsigned j = 0; j < N; j++)
		cj[j] = p[j];
	double med = median_of(cj, &ia, &ib);
	if (!(med > 0.0) || !isfinite(med))
		return;
	for (unsigned j = 0; j < N; j++) {
		js[j][j] += 1.0 / med;
		js[j][ia] -= 0.5 * cj[j] / (med * med);
		js[j][ib] -= 0.5 * cj[j] / (med * med);
		r->scale[j] = (float)(cj[j] / med);
	}
	cov_scales(js, hi, r->cov_w);
	cov_scales(js, vc, r->cov_c);
	float worst = -1.0f;
	for (unsigned j = 0; j < N; j++) {
		float v = fmaxf(r->cov_w[j][j], r->cov_c[j][j]);
		r->scale_sd[j] = v > 0.0f ? sqrtf(v) : 0.0f;
		if (r->scale_sd[j] > worst) {
			worst = r->scale_sd[j];
			r->worst = (int)j;
		}
	}
	for (unsigned a = 1; a < NA; a++)
		r->gain[a - 1u] = (float)p[P_GAM + a - 1u];
	r->cause = worst <= c->sd_max && isfinite(worst) ? IMU_SCALE_OK : IMU_SCALE_NOT_SEPARATED;
}

/* c' = J c J^T into c */
static void cov_map(const float jm[N][N], float c[N][N])
{
	float t[N][N];
	for (unsigned i = 0; i < N; i++)
		for (unsigned k = 0; k < N; k++) {
			t[i][k] = 0.0f;
			for (unsigned q = 0; q < N; q++)
				t[i][k] += jm[i][q] * c[q][k];
		}
	for (unsigned i = 0; i < N; i++)
		for (unsigned k = 0; k < N; k++) {
			c[i][k] = 0.0f;
			for (unsigned q = 0; q < N; q++)
				c[i][k] += t[i][q] * jm[k][q];
		}
}

void imu_scale_per_throttle(const struct imu_scale *m, float curve, float curve_sd, const float *share,
			    const float *share_sd, struct imu_scale_result *r)
{
	if (r->cause != IMU_SCALE_OK)
		return;
	float v[N], sp[N], dm[N];
	double vd[N];
	for (unsigned j = 0; j < N; j++) {
		float gs = (1.0f - curve) * m->sy[j] + curve * m->syy[j];
		/* the speed share, given or w^2 / g(y) over the run */
		sp[j] = share ? share[j] : gs > 0.0f ? m->sw2[j] / gs : 0.0f;
		if (!(sp[j] > 0.0f) || !isfinite(sp[j]))
			return;
		/* its sd: given, or from the curve's through d ln(share) / d c */
		dm[j] = share ? 0.0f : (m->sy[j] - m->syy[j]) / gs;
		v[j] = r->scale[j] * sp[j];
		vd[j] = (double)v[j];
	}
	unsigned ia, ib;
	float med = (float)median_of(vd, &ia, &ib), dmean = 0.0f;
	if (!(med > 0.0f) || !isfinite(med))
		return;
	/* s' = (s sp) / median(s sp): its Jacobian in s (the scales before, already over a
	 * median: s' depends on their ratios only, so the map is exact to first order) */
	float jm[N][N] = {{0}};
	for (unsigned j = 0; j < N; j++) {
		jm[j][j] += sp[j] / med;
		jm[j][ia] -= 0.5f * v[j] * sp[ia] / (med * med);
		jm[j][ib] -= 0.5f * v[j] * sp[ib] / (med * med);
		dmean += dm[j] / (float)N;
	}
	cov_map(jm, r->cov_w);
	cov_map(jm, r->cov_c);
	for (unsigned j = 0; j < N; j++) {
		/* the curve moves each share by d ln(share) / d c: what differs from the rotors'
		 * mean is not cancelled by the median */
		float dv = v[j] / med * (share ? (share_sd ? share_sd[j] / sp[j] : 0.0f) : (dm[j] - dmean) * curve_sd);
		dv = isfinite(dv) ? dv * dv : 0.0f;
		r->cov_w[j][j] += dv;
		r->cov_c[j][j] += dv;
		r->scale[j] = v[j] / med;
		float q = fmaxf(r->cov_w[j][j], r->cov_c[j][j]);
		r->scale_sd[j] = q > 0.0f ? sqrtf(q) : 0.0f;
	}
}

float imu_scale_ratio_rsd(const struct imu_scale_result *r, const float a[IMU_SCALE_ROTORS],
			  const float b[IMU_SCALE_ROTORS])
{
	float sa = 0.0f, sb = 0.0f, d[N];
	for (unsigned j = 0; j < N; j++) {
		sa += a[j] * r->scale[j];
		sb += b ? b[j] * r->scale[j] : 0.0f;
	}
	if (!(fabsf(sa) > 0.0f) || (b && !(fabsf(sb) > 0.0f)))
		return INFINITY;
	for (unsigned j = 0; j < N; j++)
		d[j] = a[j] / sa - (b ? b[j] / sb : 0.0f);
	float vw = 0.0f, vc = 0.0f;
	for (unsigned i = 0; i < N; i++)
		for (unsigned k = 0; k < N; k++) {
			vw += d[i] * r->cov_w[i][k] * d[k];
			vc += d[i] * r->cov_c[i][k] * d[k];
		}
	float v = fmaxf(vw, vc);
	return v > 0.0f ? sqrtf(v) : 0.0f;
}

const char *imu_scale_cause_text(enum imu_scale_cause c)
{
	switch (c) {
	case IMU_SCALE_OK: return "ok";
	case IMU_SCALE_NO_DATA: return "too few frames";
	case IMU_SCALE_SPEED_LOST: return "a rotor speed reading lost";
	case IMU_SCALE_NOT_SEPARATED: return "the excitation does not separate the rotors";
	}
	return "?";
}
