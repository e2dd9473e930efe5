/*
 * imu_id_solve.c - the collective rotor model from the accelerometer (imu_id.h): the set-up,
 * the grid's refinement (once) and the solve, between frames, in float in both builds (the
 * per-frame sums read converted: imu_id_q.h). The per-frame part is imu_id.c.
 */
#include "imu_id.h"
#include "imu_id_int.h"

#include <math.h>
#include <string.h>

#define IMU_ID_CL_FLOOR 0.25 /* the clusters' factor's floor (the sd at least half the white-noise one) */
#define IMU_ID_TOP_SHARE 0.5 /* the top blocks' check: the share of j' H j its top clusters carry */
#define IMU_ID_TOP_T 2.5     /* |D| / sd beyond which its excess joins the variance */

/* a lag's pole as stored: 1 - a = -expm1(-dt / tau) in the fixed build (its precision where a
 * is near 1), a = exp(-dt / tau) in the float build; x = dt / tau */
static imu_id_u_t lag_coef(float x)
{
#if OCTO_FIXED
	return iid_u_of_float(-expm1f(-x));
#else
	return expf(-x);
#endif
}

/* sums read by the solve, as float: kind k of a record of gx, hs, blk; xq's */
static float gx_f(const struct imu_id *m, unsigned l, unsigned k)
{
	return iid_sum_to_float(m->gx[l][k], E_OF(m, e_gx, k), 0);
}
/* the unit of a hypothesis' (or a block's, from its b) member k relative to b: b, rr, bt, rrt */
static int hs_sh(const struct imu_id *m, unsigned k)
{
	int ke = kexp_of(m), te = texp_of(m);
	return k < K_RR ? ke : k == K_RR ? 2 * ke : k < HS_N - 1u ? te : 2 * te;
}
static float hs_f(const struct imu_id *m, const struct imu_id_hyp *h, unsigned k)
{
	const imu_id_sum_t *v = &h->b[0];
	return iid_sum_to_float(v[k], E_OF(m, e_hs, k), hs_sh(m, k));
}
static float xq_f(const struct imu_id *m, unsigned i, unsigned k)
{
	return iid_sum_to_float(m->xq[i][k], E_OF(m, e_xq, 2u * i + k), i == IMU_ID_NX ? kexp_of(m) : 0);
}
static float acc_f(imu_id_acc_t v, int frac, int sh) { return iid_acc_to_float(v, frac, sh); }

/* a block's or a hypothesis' sums in float (the solve's) */
struct stat_f {
	float g[NT], b[NP], rr;
	float bt[NP], rrt;
};
static void blk_get(const struct imu_id *m, unsigned q, struct stat_f *s)
{
	const struct imu_id_stat *b = &m->blk[q];
	int ke = kexp_of(m), te = texp_of(m);
	for (unsigned i = 0; i < NT; i++)
		s->g[i] = iid_sum_to_float(b->g[i], E_OF(m, e_blk, i), 0);
	for (unsigned i = 0; i < NP; i++) {
		s->b[i] = iid_sum_to_float(b->b[i], E_OF(m, e_blk, B_B + i), ke);
		s->bt[i] = iid_sum_to_float(b->bt[i], E_OF(m, e_blk, B_T + i), te);
	}
	s->rr = iid_sum_to_float(b->rr, E_OF(m, e_blk, B_RR), 2 * ke);
	s->rrt = iid_sum_to_float(b->rrt, E_OF(m, e_blk, B_T + NP), 2 * te);
}

/* index of (i, j) (either order) in the upper triangle stored row by row */
static unsigned ut(unsigned i, unsigned j)
{
	unsigned a = i < j ? i : j, b = i < j ? j : i;
	return a * NP - a * (a - 1u) / 2u + (b - a) - (a ? 0u : 0u);
}

/* the reference model's regressor: the prior's prediction over k_f */
static float ref_x(const struct imu_id_cfg *c, float x1, float x2) { return (1.0f - c->curve0) * x1 + c->curve0 * x2; }

static float grid_step(const struct imu_id *m) { return m->lstep; }

static float lag_tau(const struct imu_id *m, unsigned l) { return expf(m->ln0 + m->lstep * (float)l); }

/* the lags' poles for the grid (ln0, lstep) */
static void set_grid(struct imu_id *m)
{
	for (unsigned l = 0; l < IMU_ID_LAGS; l++)
		m->lk[l] = lag_coef(m->cfg.dt_s / lag_tau(m, l));
}

/* the square roots of the scales, which the filters' outputs carry, and the scales */
static void set_rs(struct imu_id *m)
{
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++) {
		m->rs[j] = iid_u_of_float(sqrtf(m->cfg.scale[j]));
		m->sc[j] = iid_c_of_float(m->cfg.scale[j]);
	}
}

/* lag l's filters at the outputs v (unscaled) */
static void set_lag(struct imu_id *m, unsigned l, const float v[IMU_ID_ROTORS])
{
	float yc = 0.0f;
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++) {
		m->y[l][j] = iid_u_of_float(iid_u_to_float(m->rs[j]) * v[j]);
		yc += m->cfg.scale[j] * v[j];
	}
	m->yc[l] = iid_x_of_float(yc, 0);
}

static float ref_coef(const struct imu_id *m, float *r0, float *r1);

/* The per-frame coefficients (struct imu_id_xmap) of the centred regressors (basis) as a
 * linear map of the smoothed sums (x1, x2) and of their sensitivities (x3, x4): x0 = k0 x1 +
 * k1 x2 + k2, x1 = k3 x1 + k4 x2 + k5, x2 = k0 x3 + k1 x4, x3 = k3 x3 + k4 x4. With the curve
 * estimated (x1 - y_h S, sum s (y - y_h)^2, x3, x4 - 2 y_h x3), else (the reference's less its
 * value at y_h, 0, its sensitivity, 0). With it the reference model's regressor (ref_coef: r0,
 * r1, x_r(y_h) in xh), 1 / (2 h), h the grid's step, for the sensitivities, the reference's
 * k_f and k_tau and its force and torque at x_r(y_h). At the start and the refinement. */
static void xmap_set(struct imu_id *m)
{
	const struct imu_id_cfg *c = &m->cfg;
	float yh = m->yh, s = m->ssum, k[6], r0, r1;
	if (c->est_curve) {
		k[0] = 1.0f;
		k[1] = 0.0f;
		k[2] = -yh * s;
		k[3] = -2.0f * yh;
		k[4] = 1.0f;
		k[5] = yh * yh * s;
	} else {
		k[0] = 1.0f - c->curve0;
		k[1] = c->curve0;
		k[2] = -ref_x(c, yh * s, yh * yh * s);
		k[3] = k[4] = k[5] = 0.0f;
	}
	float xh = ref_coef(m, &r0, &r1);
	int ke = kexp_of(m), te = texp_of(m);
	struct imu_id_xmap *x = &m->xm;
	x->k[0] = iid_c_of_float(k[0]);
	x->k[1] = iid_c_of_float(k[1]);
	x->k[2] = iid_c_of_float(k[3]);
	x->k[3] = iid_c_of_float(k[4]);
	x->o[0] = iid_x_of_float(k[2], 0);
	x->o[1] = iid_x_of_float(k[5], 0);
	x->r0 = iid_c_of_float(r0);
	x->r1 = iid_c_of_float(r1);
	x->ih = iid_c_of_float(0.5f / m->lstep);
	x->kf = iid_c_of_float(c->kf0 * sc_pow2f(-ke));
	x->kt = iid_c_of_float(c->kt0 * sc_pow2f(-te));
	x->fref = iid_x_of_float(c->kf0 * xh, ke);
	x->tref = iid_x_of_float(c->kt0 * xh, te);
}

/* the power of two that brings v > 0 into [0.5, 1) (0 otherwise) */
static int8_t exp_of(float v)
{
	int e = 0;
	if (v > 0.0f && isfinite(v))
		(void)frexpf(v, &e);
	return (int8_t)(e < -60 ? -60 : e > 60 ? 60 : e);
}

void imu_id_init(struct imu_id *m, const struct imu_id_cfg *cfg, const scalar_t thr0[IMU_ID_ROTORS])
{
	memset(m, 0, sizeof *m);
	m->cfg = *cfg;
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
		if (!(m->cfg.scale[j] > 0.0f))
			m->cfg.scale[j] = 1.0f;
	float u[IMU_ID_ROTORS];
	imu_id_u_t uq[IMU_ID_ROTORS];
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++) {
		u[j] = sc_to_float(thr0[j]);
		uq[j] = iid_u_of_float(u[j]); /* exact: a Q16.16 throttle has 17 bits */
		m->pc[0][j] = iid_c_of_float(m->cfg.pat[0][j]);
		m->pc[1][j] = iid_c_of_float(m->cfg.pat[1][j]);
	}
	/* the refinement's frame: n_exc >= IMU_ID_FREEZE n_frames (float) in integers */
	float fz = ceilf(IMU_ID_FREEZE * (float)m->cfg.n_frames);
	m->n_freeze = fz < 4294967040.0f ? (uint32_t)fz : UINT32_MAX;
	m->ln0 = logf(IMU_ID_TAU_MIN);
	m->lstep = logf(IMU_ID_TAU_MAX / IMU_ID_TAU_MIN) / (float)(IMU_ID_LAGS - 1);
	set_grid(m);
	set_rs(m);
	for (unsigned l = 0; l < IMU_ID_LAGS; l++)
		set_lag(m, l, u);
	/* the centring point: the start's mean throttle and the scales' sum; and the reference
	 * model made to carry the weight there (k_f from the prior's curve and the mass), so that
	 * the responses relative to it stay small: both keep the float sums' precision */
	float yh = 0.0f, ss = 0.0f, gs = 0.0f, c0 = m->cfg.curve0;
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++) {
		yh += u[j] / (float)IMU_ID_ROTORS;
		ss += m->cfg.scale[j];
		gs += m->cfg.scale[j] * ((1.0f - c0) * u[j] + c0 * u[j] * u[j]);
	}
	m->yh = yh;
	m->ssum = ss;
	for (unsigned k = 0; k < AGE; k++)
		for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
			m->uq[k][j] = uq[j];
	for (unsigned k = 0; k < 3u; k++) {
		imu_id_x_t s[2][IMU_ID_LAGS];
		imu_id_advance(m, uq, s); /* the steady state in the smoother's rings */
	}
	float kr = gs > 0.0f ? m->cfg.mass_kg * m->cfg.g / gs : 0.0f;
	if (isfinite(kr) && kr > 0.0f && m->cfg.kf0 > 0.0f) {
		m->cfg.kt0 *= kr / m->cfg.kf0;
		m->cfg.kf0 = kr;
	}
#if OCTO_FIXED
	m->kexp = exp_of(m->cfg.kf0);
	m->texp = exp_of(m->cfg.kt0);
	for (unsigned k = S_GX; k <= S_XQ; k++)
		imu_id_restart_sums(m, k);
#else
	(void)exp_of;
#endif
	xmap_set(m);
}

/* inverse of a symmetric positive definite matrix (upper triangle) into h, by Cholesky
 * with the columns scaled to unit diagonal first (the regressors' sizes differ by orders of
 * magnitude); false if not positive */
static bool inv_sym(const float g[NT], float h[NP][NP])
{
	double a[NP][NP], l[NP][NP] = {{0}}, d[NP];
	for (unsigned i = 0; i < NP; i++) {
		float gi = g[ut(i, i)];
		if (!(gi > 0.0f) || !isfinite(gi))
			return false;
		d[i] = 1.0 / sqrt((double)gi);
	}
	for (unsigned i = 0; i < NP; i++)
		for (unsigned k = 0; k < NP; k++)
			a[i][k] = (double)g[ut(i, k)] * d[i] * d[k];
	for (unsigned k = 0; k < NP; k++) {
		double v = a[k][k];
		for (unsigned q = 0; q < k; q++)
			v -= l[k][q] * l[k][q];
		if (!(v > 1e-12))
			return false;
		l[k][k] = sqrt(v);
		for (unsigned i = k + 1; i < NP; i++) {
			double w = a[i][k];
			for (unsigned q = 0; q < k; q++)
				w -= l[i][q] * l[k][q];
			l[i][k] = w / l[k][k];
		}
	}
	/* L^-1 (lower), then A^-1 = L^-T L^-1 */
	double li[NP][NP] = {{0}};
	for (unsigned i = 0; i < NP; i++) {
		li[i][i] = 1.0 / l[i][i];
		for (unsigned k = 0; k < i; k++) {
			double w = 0.0;
			for (unsigned q = k; q < i; q++)
				w -= l[i][q] * li[q][k];
			li[i][k] = w / l[i][i];
		}
	}
	for (unsigned i = 0; i < NP; i++)
		for (unsigned k = 0; k < NP; k++) {
			double w = 0.0;
			for (unsigned q = (i > k ? i : k); q < NP; q++)
				w += li[q][i] * li[q][k];
			h[i][k] = (float)(w * d[i] * d[k]);
		}
	return true;
}

/* sums with the unused parameter pinned (curve not estimated: B = 0) */
static void pinned(const struct imu_id *m, const float gs[NT], const float *bs, float g[NT], float b[NP])
{
	memcpy(g, gs, NT * sizeof g[0]);
	for (unsigned i = 0; i < NP; i++)
		b[i] = bs ? bs[i] : 0.0f;
	if (!m->cfg.est_curve) {
		for (unsigned q = 0; q < 2; q++) {
			unsigned k = q ? P_LB : P_B;
			for (unsigned i = 0; i < NP; i++)
				g[ut(i, k)] = 0.0f;
			g[ut(k, k)] = 1.0f;
			b[k] = 0.0f;
		}
	}
}

/* The centred basis (xmap) to the parameters': theta = T theta'. With the curve estimated,
 * A = a' - 2 y_h B, A d = g' - 2 y_h B d, D = delta' - y_h S a' + y_h^2 S B; else
 * k_f = a', D = delta' - x_r(y_h) a'. */
static void basis(const struct imu_id *m, float t[NP][NP])
{
	memset(t, 0, NP * NP * sizeof t[0][0]);
	for (unsigned i = 0; i < NP; i++)
		t[i][i] = 1.0f;
	float yh = m->yh, s = m->ssum;
	if (m->cfg.est_curve) {
		t[0][P_B] = -2.0f * yh;
		t[P_LA][P_LB] = -2.0f * yh;
		t[P_OFS][0] = -yh * s;
		t[P_OFS][P_B] = yh * yh * s;
	} else {
		t[P_OFS][0] = -ref_x(&m->cfg, yh * s, yh * yh * s);
	}
}

/* theta = T theta' and H = T H' T^T */
static void to_params(const struct imu_id *m, float th[NP], float h[NP][NP])
{
	float t[NP][NP], th2[NP], th1[NP][NP];
	basis(m, t);
	for (unsigned i = 0; i < NP; i++) {
		th2[i] = 0.0f;
		for (unsigned k = 0; k < NP; k++) {
			th2[i] += t[i][k] * th[k];
			th1[i][k] = 0.0f;
			for (unsigned q = 0; q < NP; q++)
				th1[i][k] += t[i][q] * h[q][k];
		}
	}
	for (unsigned i = 0; i < NP; i++) {
		th[i] = th2[i];
		for (unsigned k = 0; k < NP; k++) {
			h[i][k] = 0.0f;
			for (unsigned q = 0; q < NP; q++)
				h[i][k] += th1[i][q] * t[k][q];
		}
	}
}

/* a projection j of the parameters as one of the centred basis': T^T j */
static void proj_centred(const struct imu_id *m, const float j[NP], float jc[NP])
{
	float t[NP][NP];
	basis(m, t);
	for (unsigned k = 0; k < NP; k++) {
		jc[k] = 0.0f;
		for (unsigned i = 0; i < NP; i++)
			jc[k] += t[i][k] * j[i];
	}
}

/* the least squares of sums (G, b, z'z) in the centred basis: the parameters (relative to the
 * reference), G^-1, and the residual sum */
static float fit(const struct imu_id *m, const float gs[NT], const float bs[NP], float rr, float th[NP],
		 float h[NP][NP])
{
	float g[NT], b[NP];
	pinned(m, gs, bs, g, b);
	if (!inv_sym(g, h)) {
		memset(th, 0, NP * sizeof th[0]);
		return INFINITY;
	}
	float j = rr;
	for (unsigned i = 0; i < NP; i++) {
		th[i] = 0.0f;
		for (unsigned k = 0; k < NP; k++)
			th[i] += h[i][k] * b[k];
		j -= th[i] * b[i];
	}
	return j;
}

/* the coefficients (r0, r1) of the reference model's regressor on the centred x0 and x1
 * (xmap): x_r = x_r(y_h) + r0 x0 + r1 x1, and x_r(y_h) */
static float ref_coef(const struct imu_id *m, float *r0, float *r1)
{
	const struct imu_id_cfg *c = &m->cfg;
	float yh = m->yh, s = m->ssum;
	*r0 = c->est_curve ? 1.0f - c->curve0 + 2.0f * c->curve0 * yh : 1.0f;
	*r1 = c->est_curve ? c->curve0 : 0.0f;
	return ref_x(c, yh * s, yh * yh * s);
}

static float sens(const float s[IMU_ID_LAGS], unsigned l, float ih);

/* hypothesis (d, l)'s sums: its lag's G (the sums of x2 and x3 are the sensitivities of the
 * sums of x0 and x1 across the grid, as x2 and x3 are of x0 and x1: bank_take), the count
 * n_st, its own b and z'z; the offset's b is the delay's force sum less the reference's over
 * the lag's frames (the force rings hold f less k_f0 x_r(y_h); G holds the sums of x0, x1) */
static void hyp_stat(const struct imu_id *m, unsigned d, unsigned l, struct stat_f *s)
{
	const struct imu_id_hyp *h = &m->hs[l][d];
	float r0, r1, s0[IMU_ID_LAGS], s1[IMU_ID_LAGS], ih = 0.5f / m->lstep;
	ref_coef(m, &r0, &r1);
	for (unsigned k = 0; k < IMU_ID_LAGS; k++) {
		s0[k] = gx_f(m, k, ut(0, P_OFS));
		s1[k] = gx_f(m, k, ut(P_B, P_OFS));
	}
	for (unsigned i = 0; i < ut(P_LA, P_OFS); i++) /* up to (2, 3) */
		s->g[i] = gx_f(m, l, i);
	s->g[ut(P_LA, P_OFS)] = sens(s0, l, ih);
	s->g[ut(P_LB, P_LB)] = gx_f(m, l, ut(P_LA, P_OFS));
	s->g[ut(P_LB, P_OFS)] = sens(s1, l, ih);
	s->g[ut(P_OFS, P_OFS)] = (float)m->n_st;
	float sx = r0 * s->g[ut(0, P_OFS)] + r1 * s->g[ut(P_B, P_OFS)];
	for (unsigned i = 0; i < P_OFS; i++) {
		s->b[i] = hs_f(m, h, i);
		s->bt[i] = hs_f(m, h, HS_T + i);
	}
	s->b[P_OFS] = acc_f(m->fs[d], QF_IMUX_FRAC, kexp_of(m)) - m->cfg.kf0 * sx;
	s->bt[P_OFS] = acc_f(m->ts[d], QF_IMUX_FRAC, texp_of(m)) - m->cfg.kt0 * sx;
	s->rr = hs_f(m, h, K_RR);
	s->rrt = hs_f(m, h, HS_N - 1u);
}

/* hypothesis (d, l)'s force fit (fit), or its torque fit (tq), as the parameters */
static float hyp_solve(const struct imu_id *m, unsigned d, unsigned l, bool tq, float th[NP], float h[NP][NP])
{
	struct stat_f s;
	hyp_stat(m, d, l, &s);
	float j = fit(m, s.g, tq ? s.bt : s.b, tq ? s.rrt : s.rr, th, h);
	to_params(m, th, h);
	return j;
}

/* every hypothesis' least residual (its force fit) into jr; the least one's (bd, bl) */
static void best_hyp(const struct imu_id *m, unsigned *bd, unsigned *bl, float jr[IMU_ID_DELAYS][IMU_ID_LAGS])
{
	float best = INFINITY;
	*bd = 0;
	*bl = 0;
	for (unsigned d = 0; d < IMU_ID_DELAYS; d++)
		for (unsigned l = 0; l < IMU_ID_LAGS; l++) {
			struct stat_f st;
			hyp_stat(m, d, l, &st);
			float th[NP], h[NP][NP], j = fit(m, st.g, st.b, st.rr, th, h); /* hyp_solve's residual */
			jr[d][l] = j;
			if (j < best) {
				best = j;
				*bd = d;
				*bl = l;
			}
		}
}

/* the sensitivity of the smoothed sums s (x1 or x2) to ln tau at lag l: a central difference
 * across the grid, second order at its ends (ih: 1 / (2 h), h the grid's step); in float (the
 * solve's, on the sums) and per frame */
static float sens(const float s[IMU_ID_LAGS], unsigned l, float ih)
{
	_Static_assert(IMU_ID_LAGS >= 3, "the differences need three lags");
	const unsigned e = IMU_ID_LAGS - 1u;
	if (l == 0u)
		return ih * (4.0f * s[1] - 3.0f * s[0] - s[2]);
	if (l == e)
		return ih * (3.0f * s[e] - 4.0f * s[e - 1u] + s[e - 2u]);
	return ih * (s[l + 1u] - s[l - 1u]);
}

static float step_of(const struct imu_id *m, const float th[NP]);

void imu_id_set_scales(struct imu_id *m, const float scale[IMU_ID_ROTORS])
{
	if (m->refined)
		return;
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
		m->scale_next[j] = scale[j] > 0.0f && isfinite(scale[j]) ? scale[j] : m->cfg.scale[j];
	m->scale_new = true;
}

/* At the refinement (the sums restart): the scales imu_id_set_scales gave, the centring's
 * scale sum and the references scaled so that k_f0 sum s_j keeps its value. */
static void scales_take(struct imu_id *m)
{
	if (!m->scale_new)
		return;
	m->scale_new = false;
	float ss = 0.0f;
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
		ss += m->scale_next[j];
	if (!(ss > 0.0f) || !(m->ssum > 0.0f))
		return;
	float k = m->ssum / ss;
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
		m->cfg.scale[j] = m->scale_next[j];
	m->cfg.kf0 *= k;
	m->cfg.kt0 *= k;
	m->ssum = ss;
}

/* The grid's refinement: about the best hypothesis' lag (its Gauss-Newton step taken),
 * +/- IMU_ID_FINE_HALF of the first grid's steps, kept inside IMU_ID_TAU_MIN..MAX; each new
 * lag's filter state interpolated (in ln tau) between the old grid's; the sums restarted
 * (from the frames whose force and regressors all come after it), the clusters' hypothesis
 * the best delay at the centre. */
void imu_id_refine(struct imu_id *m)
{
	unsigned bd, bl;
	float jr[IMU_ID_DELAYS][IMU_ID_LAGS];
	best_hyp(m, &bd, &bl, jr);
	float th[NP], h[NP][NP], h0 = m->lstep;
	hyp_solve(m, bd, bl, false, th, h);
	float dl = step_of(m, th);
	dl = dl > h0 ? h0 : dl < -h0 ? -h0 : dl;
	float lo = logf(IMU_ID_TAU_MIN), hi = logf(IMU_ID_TAU_MAX), half = IMU_ID_FINE_HALF * h0;
	float c = m->ln0 + h0 * (float)bl + dl;
	c = c - half < lo ? lo + half : c + half > hi ? hi - half : c;
	float y[IMU_ID_LAGS][IMU_ID_ROTORS], v[IMU_ID_LAGS][IMU_ID_ROTORS], ln_old0 = m->ln0;
	for (unsigned l = 0; l < IMU_ID_LAGS; l++)
		for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
			y[l][j] = iid_u_to_float(m->y[l][j]) / iid_u_to_float(m->rs[j]);
	m->ln0 = c - half;
	m->lstep = 2.0f * half / (float)(IMU_ID_LAGS - 1);
	for (unsigned l = 0; l < IMU_ID_LAGS; l++) {
		float q = (m->ln0 + m->lstep * (float)l - ln_old0) / h0;
		q = q < 0.0f ? 0.0f : q > (float)(IMU_ID_LAGS - 1) ? (float)(IMU_ID_LAGS - 1) : q;
		unsigned i = (unsigned)q;
		i = i >= IMU_ID_LAGS - 1u ? IMU_ID_LAGS - 2u : i;
		float fq = q - (float)i;
		for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
			v[l][j] = y[i][j] + fq * (y[i + 1u][j] - y[i][j]);
	}
	set_grid(m);
	scales_take(m);
	set_rs(m);
	for (unsigned l = 0; l < IMU_ID_LAGS; l++)
		set_lag(m, l, v[l]);
	memset(m->gx, 0, sizeof m->gx);
	memset(m->hs, 0, sizeof m->hs);
	memset(m->fs, 0, sizeof m->fs);
	memset(m->ts, 0, sizeof m->ts);
	imu_id_restart_sums(m, S_GX);
	imu_id_restart_sums(m, S_HS);
	m->n_st = 0;
	m->fok = 0; /* the bank waits for the new grid's regressors and the new reference's force */
	m->refined = true;
	m->cl_d = (uint8_t)bd;
	m->cl_l = (uint8_t)CL_LAG;
	m->cl_len = m->cfg.block_frames ? m->cfg.block_frames : 90u;
	m->cl_on = true;
	xmap_set(m); /* the new grid's step, the references the scales moved */
}

/* The eigen-decomposition a = v diag(d) v' of a symmetric matrix (cyclic Jacobi; a is
 * overwritten). Single precision: it serves well-scaled matrices (a cluster's leverages, in
 * [0, 1)), and the M4F's FPU is single. */
static void eig_sym(float a[NP][NP], float v[NP][NP], float d[NP])
{
	for (unsigned i = 0; i < NP; i++)
		for (unsigned k = 0; k < NP; k++)
			v[i][k] = i == k ? 1.0f : 0.0f;
	for (unsigned sweep = 0; sweep < 12u; sweep++) {
		float off = 0.0f, dia = 0.0f;
		for (unsigned p = 0; p < NP; p++) {
			dia += a[p][p] * a[p][p];
			for (unsigned q = p + 1; q < NP; q++)
				off += a[p][q] * a[p][q];
		}
		if (!(off > 1e-14f * dia))
			break;
		for (unsigned p = 0; p < NP; p++)
			for (unsigned q = p + 1; q < NP; q++) {
				if (a[p][q] == 0.0f)
					continue;
				float th = (a[q][q] - a[p][p]) / (2.0f * a[p][q]);
				float t = (th >= 0.0f ? 1.0f : -1.0f) / (fabsf(th) + sqrtf(th * th + 1.0f));
				float c = 1.0f / sqrtf(t * t + 1.0f), sn = t * c;
				for (unsigned k = 0; k < NP; k++) {
					float x = a[k][p], y = a[k][q];
					a[k][p] = c * x - sn * y;
					a[k][q] = sn * x + c * y;
				}
				for (unsigned k = 0; k < NP; k++) {
					float x = a[p][k], y = a[q][k];
					a[p][k] = c * x - sn * y;
					a[q][k] = sn * x + c * y;
				}
				for (unsigned k = 0; k < NP; k++) {
					float x = v[k][p], y = v[k][q];
					v[k][p] = c * x - sn * y;
					v[k][q] = sn * x + c * y;
				}
			}
	}
	for (unsigned i = 0; i < NP; i++)
		d[i] = a[i][i];
}

/* The Cholesky factor L (lower) of the positive semi-definite h, h = L L'; a zero pivot (a
 * pinned parameter's row) leaves its column zero. */
static void chol_psd(const double h[NP][NP], double l[NP][NP])
{
	memset(l, 0, sizeof(double) * NP * NP);
	for (unsigned k = 0; k < NP; k++) {
		double d = h[k][k];
		for (unsigned q = 0; q < k; q++)
			d -= l[k][q] * l[k][q];
		if (!(d > 0.0))
			continue;
		l[k][k] = sqrt(d);
		for (unsigned i = k + 1; i < NP; i++) {
			double w = h[i][k];
			for (unsigned q = 0; q < k; q++)
				w -= l[i][q] * l[k][q];
			l[i][k] = w / l[k][k];
		}
	}
}

/* A cluster's weight vector z = (I - H W)^-1/2 H j (CR2) for the projection j, given H = L L'
 * and u = L' j: with M = L' W L (symmetric, its eigenvalues the cluster's leverages, in
 * [0, 1)), (I - H W)^-1/2 = L (I - M)^-1/2 L^-1, so z = L (I - M)^-1/2 u. False where a
 * leverage reaches 1 (the cluster alone determines a direction). */
static bool lev_half(const double l[NP][NP], const double w[NP][NP], const double u[NP], double z[NP])
{
	double wl[NP][NP], y[NP], t[NP];
	float mm[NP][NP], p[NP][NP], mu[NP];
	for (unsigned i = 0; i < NP; i++)
		for (unsigned k = 0; k < NP; k++) {
			wl[i][k] = 0.0;
			for (unsigned q = k; q < NP; q++)
				wl[i][k] += w[i][q] * l[q][k];
		}
	for (unsigned i = 0; i < NP; i++)
		for (unsigned k = 0; k <= i; k++) {
			double m = 0.0;
			for (unsigned q = i; q < NP; q++)
				m += l[q][i] * wl[q][k];
			mm[i][k] = mm[k][i] = (float)m;
		}
	eig_sym(mm, p, mu);
	for (unsigned k = 0; k < NP; k++) {
		if (!(mu[k] < 1.0f - 1e-5f))
			return false;
		double pu = 0.0;
		for (unsigned i = 0; i < NP; i++)
			pu += (double)p[i][k] * u[i];
		y[k] = pu / sqrt(1.0 - (double)(mu[k] > 0.0f ? mu[k] : 0.0f));
	}
	for (unsigned i = 0; i < NP; i++) {
		t[i] = 0.0;
		for (unsigned k = 0; k < NP; k++)
			t[i] += (double)p[i][k] * y[k];
	}
	for (unsigned i = 0; i < NP; i++) {
		z[i] = 0.0;
		for (unsigned k = 0; k <= i; k++)
			z[i] += l[i][k] * t[k];
	}
	return true;
}

/* a parameter pinned at 0 (the curve and its lag term when the curve is not estimated) */
static bool is_pinned(const struct imu_id *m, unsigned i) { return !m->cfg.est_curve && (i == P_B || i == P_LB); }

/* The top blocks' check, for the projection j (v = H j, vw = j' H j, gs the clusters' summed
 * Gram matrix, th the fit): the clusters that carry most of j' theta (largest v' W_g v, until
 * IMU_ID_TOP_SHARE of j' H j) are left out, and j' theta from the rest compared with it:
 *     D = j' H_r sum_{g in top} r_g,   H_r = (G - W_top)^-1,
 * the fit's change (the scores r_g sum to 0 over all clusters). Its variance from the clusters
 * (as scores: D = sum_top (H j)' s_g - sum_rest ((H_r - H) j)' s_g to first order)
 *     V_D = sum_top (v' r_g)^2 + sum_rest ((H_r j - v)' r_g)^2.
 * The clusters' variance assumes the top steps' errors independent; the rotors' vibration at
 * the top steps' speed can alias to nearly a constant whose phase repeats from step to step
 * (the sweep is periodic), a common offset of every top step that the curve absorbs and no
 * cluster's spread shows. The rest then disagree: beyond IMU_ID_TOP_T of V_D's sds the
 * excess D^2 - V_D is returned (0 otherwise), a variance the factor adds. *t_out (if given):
 * D / sqrt(V_D). */
static double top_check(const struct imu_id *m, const float th[NP], const float jo[NP], bool tq, unsigned nb,
			const float gs[NT], const double v[NP], double vw, float *t_out)
{
	bool top[IMU_ID_BLOCKS + 1] = {false};
	double lev[IMU_ID_BLOCKS + 1], got = 0.0;
	float gr[NT];
	memcpy(gr, gs, sizeof gr);
	for (unsigned k = 0; k < nb; k++) {
		struct stat_f bf;
		blk_get(m, k, &bf);
		const struct stat_f *b = &bf;
		lev[k] = 0.0;
		for (unsigned i = 0; i < NP; i++)
			for (unsigned q = 0; q < NP; q++)
				lev[k] += v[i] * (double)b->g[ut(i, q)] * v[q];
	}
	while (got < IMU_ID_TOP_SHARE * vw) {
		unsigned kb = nb;
		for (unsigned k = 0; k < nb; k++)
			if (!top[k] && (kb == nb || lev[k] > lev[kb]))
				kb = k;
		if (kb == nb)
			return 0.0;
		top[kb] = true;
		got += lev[kb];
		struct stat_f bf;
		blk_get(m, kb, &bf);
		for (unsigned i = 0; i < NT; i++)
			gr[i] -= bf.g[i];
	}
	float g[NT], hf[NP][NP], bb0[NP], j[NP];
	proj_centred(m, jo, j);
	pinned(m, gr, NULL, g, bb0);
	if (!inv_sym(g, hf))
		return 0.0; /* the rest cannot tell j' theta: no check */
	double vr[NP];
	for (unsigned i = 0; i < NP; i++) {
		vr[i] = 0.0;
		for (unsigned k = 0; k < NP; k++)
			if (!is_pinned(m, i) && !is_pinned(m, k))
				vr[i] += (double)hf[i][k] * (double)j[k];
	}
	double d = 0.0, vd = 0.0;
	for (unsigned k = 0; k < nb; k++) {
		struct stat_f bf;
		blk_get(m, k, &bf);
		const struct stat_f *b = &bf;
		const float *bb = tq ? b->bt : b->b;
		double pv = 0.0, pr = 0.0;
		for (unsigned i = 0; i < NP; i++) {
			if (is_pinned(m, i))
				continue;
			double r = (double)bb[i];
			for (unsigned q = 0; q < NP; q++)
				if (!is_pinned(m, q))
					r -= (double)b->g[ut(i, q)] * (double)th[q];
			pv += v[i] * r;
			pr += vr[i] * r;
		}
		if (top[k]) {
			d += pr;
			vd += pv * pv;
		} else {
			vd += (pr - pv) * (pr - pv);
		}
	}
	if (!(vd > 0.0))
		return 0.0;
	if (t_out)
		*t_out = (float)(d / sqrt(vd));
	return d * d > IMU_ID_TOP_T * IMU_ID_TOP_T * vd ? d * d - vd : 0.0;
}

/* The clusters' variance factor for the projection j of the parameters: the cluster-robust
 * variance of j' theta over its white-noise variance, both on the frozen hypothesis' frames
 * (its residuals from theta, the whole flight's estimate). The cluster-robust variance is the
 * bias-reduced one (CR2, Bell and McCaffrey's): with H = G^-1 of all the clusters, W_g a
 * cluster's Gram matrix and r_g its score (b_g - W_g theta),
 *     V = sum_g (z_g' r_g)^2,   z_g = (I - H W_g)^-1/2 H j,
 * unbiased for white residuals whatever each cluster's leverage. The plain sandwich
 * sum_g (j' H r_g)^2 is optimistic where a few clusters carry the information (the sweep's
 * top steps): a cluster of high leverage pulls the fit towards itself, so its own
 * residuals understate what it carries. The jackknife (CR3, (I - H W_g)^-1 in place of the
 * root) corrects that twice over: with the t's nu / (nu - 2) on top it overstated the
 * variance by a fifth (test_imu_id.c, imu_id_leverage_var_over_sd2). The root comes from a
 * symmetric form (lev_half). Its degrees of freedom (Bell and McCaffrey's, for white
 * residuals): V is a weighted sum of chi^2_1 whose weights are the eigenvalues of the
 * clusters' matrix C_gh = delta_gh z_g' W_g z_g - (W_g z_g)' H (W_h z_h), so
 * nu = (tr C)^2 / tr(C^2); the estimate then follows a t with nu degrees of freedom, whose
 * variance nu / (nu - 2) the factor carries (*nu_out; 0 when there are not enough clusters).
 * The factor may lie below 1: the residuals' power is mostly the vibration's aliases near half
 * the frame rate, which the sweep's slow regressors average out, so the white-noise variance
 * overstates; it is floored at IMU_ID_CL_FLOOR (the clusters' variance on a dozen degrees of
 * freedom is itself uncertain). top_check's excess (the top blocks' disagreement) is added.
 * 1 with fewer than 4 clusters (*g_out: the clusters used). */
static float cl_factor(const struct imu_id *m, const float th[NP], const float jo[NP], bool tq, unsigned *g_out,
		       float *nu_out, float *t_out)
{
	if (t_out)
		*t_out = 0.0f;
	unsigned nb =
		m->nb + (m->cl_k * 2u >= m->cl_len && m->cl_len > 0u ? 1u : 0u); /* a half-full last block counts */
	*g_out = nb;
	*nu_out = 0.0f;
	if (!m->cl_on || nb < 4u)
		return 1.0f;
	float gs[NT] = {0}, ee = 0.0f;
	uint32_t n = 0;
	for (unsigned k = 0; k < nb; k++) {
		struct stat_f bf;
		blk_get(m, k, &bf);
		const struct stat_f *b = &bf;
		const float *bb = tq ? b->bt : b->b;
		/* the block's e'e = rr - 2 theta' b + theta' G theta */
		for (unsigned i = 0; i < NP; i++) {
			float gth = 0.0f;
			for (unsigned q = 0; q < NP; q++)
				gth += b->g[ut(i, q)] * th[q];
			ee += th[i] * (gth - 2.0f * bb[i]);
		}
		ee += tq ? b->rrt : b->rr;
		for (unsigned i = 0; i < NT; i++)
			gs[i] += b->g[i];
		n += k < m->nb ? m->cl_len : m->cl_k;
	}
	float g[NT], hf[NP][NP], bb0[NP], j[NP];
	proj_centred(m, jo, j);
	pinned(m, gs, NULL, g, bb0);
	if (!inv_sym(g, hf) || !(ee > 0.0f) || n <= NP)
		return 1.0f;
	double h[NP][NP], v[NP], vw = 0.0, vc = 0.0;
	for (unsigned i = 0; i < NP; i++)
		for (unsigned k = 0; k < NP; k++)
			h[i][k] = is_pinned(m, i) || is_pinned(m, k) ? 0.0 : (double)hf[i][k];
	for (unsigned i = 0; i < NP; i++) {
		v[i] = 0.0;
		for (unsigned k = 0; k < NP; k++)
			v[i] += h[i][k] * (double)j[k];
		vw += (double)j[i] * v[i];
	}
	/* H = L L' (positive semi-definite: zero on the pinned parameters) and u = L' j */
	double lh[NP][NP], u[NP];
	chol_psd(h, lh);
	for (unsigned i = 0; i < NP; i++) {
		u[i] = 0.0;
		for (unsigned k = i; k < NP; k++)
			u[i] += lh[k][i] * (double)j[k];
	}
	/* the degrees of freedom from running sums, with c_g = W_g z_g, s_g = z_g' c_g and
	 * q_g = c_g' H c_g: tr C = sum (s_g - q_g), tr C^2 = sum s_g^2 - 2 sum s_g q_g + tr((H S)^2),
	 * S = sum c_g c_g' */
	double sc[NP][NP] = {{0}}, tr = 0.0, tr2 = 0.0;
	for (unsigned k = 0; k < nb; k++) {
		struct stat_f bf;
		blk_get(m, k, &bf);
		const struct stat_f *b = &bf;
		const float *bb = tq ? b->bt : b->b;
		double w[NP][NP], r[NP], z[NP], cz[NP];
		for (unsigned i = 0; i < NP; i++) {
			r[i] = (double)bb[i];
			for (unsigned q = 0; q < NP; q++) {
				w[i][q] = is_pinned(m, i) || is_pinned(m, q) ? 0.0 : (double)b->g[ut(i, q)];
				r[i] -= w[i][q] * (double)th[q];
			}
			if (is_pinned(m, i))
				r[i] = 0.0;
		}
		if (!lev_half(lh, w, u, z))
			return INFINITY; /* a cluster alone determines the projection */
		double zr = 0.0, sz = 0.0, qz = 0.0;
		for (unsigned i = 0; i < NP; i++) {
			zr += z[i] * r[i];
			cz[i] = 0.0;
			for (unsigned q = 0; q < NP; q++)
				cz[i] += w[i][q] * z[q];
			sz += z[i] * cz[i];
		}
		for (unsigned i = 0; i < NP; i++) {
			for (unsigned q = 0; q < NP; q++) {
				qz += cz[i] * h[i][q] * cz[q];
				sc[i][q] += cz[i] * cz[q];
			}
		}
		vc += zr * zr;
		tr += sz - qz;
		tr2 += sz * sz - 2.0 * sz * qz;
	}
	double hs[NP][NP];
	for (unsigned i = 0; i < NP; i++)
		for (unsigned k = 0; k < NP; k++) {
			hs[i][k] = 0.0;
			for (unsigned q = 0; q < NP; q++)
				hs[i][k] += h[i][q] * sc[q][k];
		}
	for (unsigned i = 0; i < NP; i++)
		for (unsigned k = 0; k < NP; k++)
			tr2 += hs[i][k] * hs[k][i];
	double nu = tr2 > 0.0 ? tr * tr / tr2 : 0.0;
	*nu_out = (float)nu;
	double top = top_check(m, th, jo, tq, nb, gs, v, vw, t_out);
	vw *= (double)ee / (double)(n - NP);
	if (!(vw > 0.0))
		return 1.0f;
	double q = nu > 2.0 ? vc / vw * nu / (nu - 2.0) : (double)INFINITY;
	return (float)((q > IMU_ID_CL_FLOOR ? q : IMU_ID_CL_FLOOR) + top / vw);
}

/* a hypothesis' Gauss-Newton step from its grid point, d ln tau = (A d + B d) / (A + B) */
static float step_of(const struct imu_id *m, const float th[NP])
{
	const struct imu_id_cfg *c = &m->cfg;
	float A = c->est_curve ? c->kf0 * (1.0f - c->curve0) + th[0] : c->kf0 + th[0];
	float B = c->est_curve ? c->kf0 * c->curve0 + th[P_B] : 0.0f;
	return A + B > 0.0f ? (th[P_LA] + (c->est_curve ? th[P_LB] : 0.0f)) / (A + B) : 0.0f;
}

/* The scales' check: the frozen hypothesis refitted with the two null-space patterns'
 * responses; each response over its sd in t[2] (0 when the fit is not possible). */
static void scales_check(const struct imu_id *m, float t[2])
{
	enum { N = IMU_ID_NX };
	double a[N][N], l[N][N] = {{0}}, b[N];
	t[0] = t[1] = 0.0f;
	if (m->xn <= 2u * N)
		return;
	/* the parameters' sums are the blocks' (merging keeps them), the patterns' cl_add's */
	double rr = 0.0;
	for (unsigned i = 0; i < N; i++) {
		b[i] = i < NP ? 0.0 : (double)xq_f(m, IMU_ID_NX, i - NP);
		for (unsigned k = 0; k < N; k++)
			a[i][k] = k >= NP ? (double)xq_f(m, i, k - NP) : i >= NP ? (double)xq_f(m, k, i - NP) : 0.0;
	}
	for (unsigned q = 0; q <= m->nb && q <= IMU_ID_BLOCKS; q++) {
		struct stat_f sf;
		blk_get(m, q, &sf);
		const struct stat_f *s = &sf;
		for (unsigned i = 0; i < NP; i++) {
			b[i] += (double)s->b[i];
			for (unsigned k = 0; k < NP; k++)
				a[i][k] += (double)s->g[ut(i, k)];
		}
		rr += (double)s->rr;
	}
	if (!m->cfg.est_curve) {
		for (unsigned q = 0; q < 2; q++) {
			unsigned k = q ? P_LB : P_B;
			for (unsigned i = 0; i < N; i++)
				a[i][k] = a[k][i] = 0.0;
			a[k][k] = 1.0;
			b[k] = 0.0;
		}
	}
	double d[N];
	for (unsigned i = 0; i < N; i++) {
		if (!(a[i][i] > 0.0))
			return;
		d[i] = 1.0 / sqrt(a[i][i]);
	}
	for (unsigned k = 0; k < N; k++) {
		double v = a[k][k] * d[k] * d[k];
		for (unsigned q = 0; q < k; q++)
			v -= l[k][q] * l[k][q];
		if (!(v > 1e-12))
			return;
		l[k][k] = sqrt(v);
		for (unsigned i = k + 1; i < N; i++) {
			double w = a[i][k] * d[i] * d[k];
			for (unsigned q = 0; q < k; q++)
				w -= l[i][q] * l[k][q];
			l[i][k] = w / l[k][k];
		}
	}
	/* solves (D A D) u = r by L L' */
	double th[N], col[2][N];
	for (unsigned s = 0; s < 3; s++) {
		double r[N], y[N], u[N];
		for (unsigned i = 0; i < N; i++)
			r[i] = s == 0 ? b[i] * d[i] : (i == N - 3u + s ? d[i] : 0.0);
		for (unsigned i = 0; i < N; i++) {
			double w = r[i];
			for (unsigned q = 0; q < i; q++)
				w -= l[i][q] * y[q];
			y[i] = w / l[i][i];
		}
		for (unsigned i = N; i-- > 0;) {
			double w = y[i];
			for (unsigned q = i + 1; q < N; q++)
				w -= l[q][i] * u[q];
			u[i] = w / l[i][i];
		}
		for (unsigned i = 0; i < N; i++) {
			if (s == 0)
				th[i] = u[i] * d[i];
			else
				col[s - 1][i] = u[i] * d[i]; /* column of A^-1 */
		}
	}
	double ee = rr;
	for (unsigned i = 0; i < N; i++)
		ee -= th[i] * b[i];
	double s2 = ee / (double)(m->xn - N);
	for (unsigned k = 0; k < 2; k++) {
		double v = s2 * col[k][N - 2u + k];
		t[k] = v > 0.0 ? (float)(th[N - 2u + k] / sqrt(v)) : 0.0f;
	}
}

/* j' V j */
static float quad(const float v[NP][NP], const float j[NP])
{
	float w = 0.0f;
	for (unsigned i = 0; i < NP; i++)
		for (unsigned k = 0; k < NP; k++)
			w += j[i] * v[i][k] * j[k];
	return w > 0.0f ? w : 0.0f;
}

/* The chosen delay bd and its margin: the log-likelihood ratio of the best lag of every other
 * delay over bd's (into r), from the hypotheses' residuals jr (best_hyp); bd's least residual. */
static float delay_margin(const struct imu_id *m, unsigned bd, float jr[IMU_ID_DELAYS][IMU_ID_LAGS],
			  struct imu_id_result *r)
{
	float jb[IMU_ID_DELAYS];
	for (unsigned d = 0; d < IMU_ID_DELAYS; d++) {
		jb[d] = INFINITY;
		for (unsigned l = 0; l < IMU_ID_LAGS; l++)
			if (jr[d][l] < jb[d])
				jb[d] = jr[d][l];
	}
	float j0 = jb[bd], j2 = INFINITY;
	for (unsigned d = 0; d < IMU_ID_DELAYS; d++)
		if (d != bd && jb[d] < j2)
			j2 = jb[d];
	r->delay = bd;
	r->delay_margin = j0 > 0.0f ? 0.5f * (float)m->n_st * logf(j2 / j0) : INFINITY;
	return j0;
}

/* The white-noise covariance s2 H into v, and the frozen hypothesis' fit of the force (or,
 * tq, the torque) in the centred basis into thc (zero before the clusters start): what
 * cl_factor scales each projection's variance by. */
static void cov_frozen(const struct imu_id *m, float s2, const float h[NP][NP], bool tq, float v[NP][NP], float thc[NP])
{
	for (unsigned i = 0; i < NP; i++)
		for (unsigned k = 0; k < NP; k++)
			v[i][k] = s2 * h[i][k];
	memset(thc, 0, NP * sizeof thc[0]);
	if (m->cl_on) {
		struct stat_f s;
		float hc[NP][NP];
		hyp_stat(m, m->cl_d, m->cl_l, &s);
		fit(m, s.g, tq ? s.bt : s.b, tq ? s.rrt : s.rr, thc, hc);
	}
}

/* k_tau from the ESCs' torques: the torque's fit on the hypothesis the force chose (bd, bl),
 * with the same second-order correction from the neighbours at the force's step dl, and its
 * white-noise covariance scaled by the clusters' factor of its own residuals. */
static void torque_solve(const struct imu_id *m, unsigned bd, unsigned bl, float dl, struct imu_id_result *r)
{
	const struct imu_id_cfg *c = &m->cfg;
	if (!c->torque || m->tq_lost)
		return;
	if (m->cl_on && bd != m->cl_d) { /* the torque's sums were kept for the frozen delay alone */
		r->tq_moved = true;
		return;
	}
	unsigned np = c->est_curve ? NP : NP - 2u;
	float th[NP], h[NP][NP], v[NP][NP], thc[NP], nu = 0.0f;
	float j = hyp_solve(m, bd, bl, true, th, h);
	if (bl > 0u && bl + 1u < IMU_ID_LAGS) {
		float tm[NP], tp[NP], hh[NP][NP], k = dl / (4.0f * grid_step(m));
		hyp_solve(m, bd, bl - 1u, true, tm, hh);
		hyp_solve(m, bd, bl + 1u, true, tp, hh);
		for (unsigned i = 0; i < NP; i++)
			th[i] += k * (tp[i] - tm[i]);
	}
	float s2 = j / (float)(m->n_st - np);
	if (!(s2 >= 0.0f) || !isfinite(s2))
		return;
	cov_frozen(m, s2, h, true, v, thc);
	float A = c->est_curve ? c->kt0 * (1.0f - c->curve0) + th[0] : c->kt0 + th[0];
	float B = c->est_curve ? c->kt0 * c->curve0 + th[P_B] : 0.0f;
	const float jk[NP] = {1.0f, c->est_curve ? 1.0f : 0.0f, 0.0f, 0.0f, 0.0f};
	unsigned ncl = 0;
	r->tq_hac = cl_factor(m, thc, jk, true, &ncl, &r->tq_dof, NULL);
	r->ktau = A + B;
	r->ktau_sd = sqrtf(quad(v, jk) * r->tq_hac);
	r->tq_noise = sqrtf(s2);
	float yh = m->nz_n ? acc_f(m->nz_thr, QF_UNIT_FRAC, 0) / (float)m->nz_n : 0.0f, sl = A + 2.0f * B * yh;
	const float js[NP] = {1.0f, c->est_curve ? 2.0f * yh : 0.0f, 0.0f, 0.0f, 0.0f};
	r->tq_slope = sl;
	r->tq_slope_rsd = sl > 0.0f ? sqrtf(quad(v, js) * cl_factor(m, thc, js, true, &ncl, &nu, NULL)) / sl : INFINITY;
	r->tq_ok = isfinite(r->ktau) && isfinite(r->ktau_sd) && r->ktau > 0.0f;
}

/* The acceptance cause from the result's diagnostics (dl: the lag's step from grid point bl). */
static enum imu_id_cause verdict(const struct imu_id *m, const struct imu_id_result *r, unsigned bl, float dl,
				 float hac_max)
{
	float hstep = grid_step(m);
	/* the step must stay within the grid's reach: beyond half a step the neighbour is
	 * better, and at an end of the grid beyond it the lag is outside the range */
	bool edge = (bl == 0u && dl < -0.5f * hstep) || (bl == IMU_ID_LAGS - 1u && dl > 0.5f * hstep) ||
		    !(fabsf(dl) <= 1.5f * hstep);
	if (m->nz_n < 20u)
		return IMU_ID_NOISE_UNKNOWN;
	if (edge)
		return IMU_ID_LAG_RANGE;
	if (r->delay == IMU_ID_DELAYS - 1u)
		return IMU_ID_DELAY_RANGE;
	if (r->delay_margin < 12.0f)
		return IMU_ID_DELAY_AMBIGUOUS;
	if (!(r->hac <= hac_max))
		return IMU_ID_MODEL;
	if (m->cfg.est_curve && !(r->curve_sd < 0.2f))
		return IMU_ID_CURVE_WEAK;
	if (fabsf(r->t_pattern[0]) > IMU_ID_T_ROTOR || fabsf(r->t_pattern[1]) > IMU_ID_T_ROTOR)
		return IMU_ID_SCALES;
	return IMU_ID_OK;
}

void imu_id_solve(const struct imu_id *m, float ne_max, struct imu_id_result *r)
{
	memset(r, 0, sizeof *r);
	const struct imu_id_cfg *c = &m->cfg;
	uint32_t n = m->n_st;
	r->n = n;
	r->cl_delay = m->cl_d;
	r->curve = c->curve0;
	r->kf = c->kf0;
	unsigned np = c->est_curve ? NP : NP - 2u;
	if (n < 60u) {
		r->cause = IMU_ID_NO_DATA;
		return;
	}
	float nz_var = 0.0f;
	if (m->nz_n >= 20u) {
		float mu = acc_f(m->nz_s, QF_IMUX_FRAC, kexp_of(m)) / (float)m->nz_n;
		nz_var = acc_f(m->nz_ss, QF_IMUX_FRAC, 2 * kexp_of(m)) / (float)m->nz_n - mu * mu;
		if (nz_var < 0.0f)
			nz_var = 0.0f;
	}
	r->noise_sd = sqrtf(nz_var);
	unsigned bd, bl;
	float jr[IMU_ID_DELAYS][IMU_ID_LAGS];
	best_hyp(m, &bd, &bl, jr);
	float j0 = delay_margin(m, bd, jr, r);
	float th[NP], h[NP][NP], v[NP][NP], thc[NP];
	hyp_solve(m, bd, bl, false, th, h);
	float hstep = grid_step(m), dl = step_of(m, th), lcorr = 0.0f;
	/* the grid point nearest the lag found (the least residual's may lie a few of the
	 * refined grid's steps off where the lag is weakly seen): the expansion below is about it */
	for (int it = 0; it < 3; it++) {
		float q = (float)bl + dl / hstep;
		unsigned to = q <= 0.0f ? 0u : q >= (float)(IMU_ID_LAGS - 1) ? IMU_ID_LAGS - 1u : (unsigned)(q + 0.5f);
		if (to == bl)
			break;
		bl = to;
		j0 = hyp_solve(m, bd, bl, false, th, h);
		dl = step_of(m, th);
	}
	float s2 = j0 / (float)(n - np);
	/* the residual variance over the noise the still frames measured, scaled to each frame's
	 * thrust: the vibration's amplitude goes with the rotor speed squared, as the thrust
	 * does, so a frame at force f has the still variance times (f / f_still)^2 */
	float mu = m->nz_n ? acc_f(m->nz_s, QF_IMUX_FRAC, kexp_of(m)) / (float)m->nz_n : 0.0f;
	float ff = acc_f(m->ff, QF_IMUX_FRAC, 2 * kexp_of(m));
	float grow = mu > 0.0f && m->n_exc > 0u ? ff / (float)m->n_exc / (mu * mu) : 1.0f;
	r->ne = nz_var > 0.0f ? s2 / (nz_var * (grow > 1.0f ? grow : 1.0f)) : INFINITY;

	/* the Gauss-Newton step is first order: each grid point's estimate at the lag found is
	 * off by about K d^2 (d its distance in ln tau). The neighbours on either side, at d + h
	 * and d - h, give K: theta* = theta + d (theta(l+1) - theta(l-1)) / (4 h), and the same
	 * for ln tau (their own steps from their own points) */
	if (bl > 0u && bl + 1u < IMU_ID_LAGS) {
		float tm[NP], tp[NP], hh[NP][NP];
		hyp_solve(m, bd, bl - 1u, false, tm, hh);
		hyp_solve(m, bd, bl + 1u, false, tp, hh);
		float k = dl / (4.0f * hstep);
		for (unsigned i = 0; i < NP; i++)
			th[i] += k * (tp[i] - tm[i]);
		lcorr = k * ((hstep + step_of(m, tp)) - (-hstep + step_of(m, tm)));
	}
	/* the white-noise covariance (s2 H); each quantity's variance then scaled by the
	 * clusters' factor for its projection (the frozen hypothesis' estimate theta) */
	cov_frozen(m, s2, h, false, v, thc);
	unsigned ncl = 0;
	float nu = 0.0f;
	/* the raw (uncalibrated) k_f = A + B, the curve c = B / (A + B) */
	float A = c->est_curve ? c->kf0 * (1.0f - c->curve0) + th[0] : c->kf0 + th[0];
	float B = c->est_curve ? c->kf0 * c->curve0 + th[P_B] : 0.0f;
	float kf_raw = A + B;
	r->curve = c->est_curve ? (kf_raw != 0.0f ? B / kf_raw : 0.0f) : c->curve0;
	if (c->est_curve) { /* dc/dA = -B / K^2, dc/dB = A / K^2 */
		float k2 = kf_raw * kf_raw, jc[NP] = {-B / k2, A / k2, 0.0f, 0.0f, 0.0f};
		r->curve_sd = sqrtf(quad(v, jc) * cl_factor(m, thc, jc, false, &ncl, &r->curve_dof, NULL));
	}
	/* the calibration: kappa = m (g T + v_last - v0) / (sum (F_w - D) dt), D the offset;
	 * k_f = kappa (A + B), its sd from the parameters' covariance through the Jacobian
	 * (kappa, kappa, 0, k_f / (F_w mean - D)) and the velocity's share of kappa's */
	float tc = (float)m->n_cal * c->dt_s, kap = 1.0f, kap_sd = 0.0f, ofs = th[P_OFS];
	float fm = m->n_cal > 0u ? acc_f(m->fw_sum, QF_SC_FRAC, 0) / (float)m->n_cal - ofs : 0.0f;
	if (fm > 0.0f) {
		kap = c->mass_kg * (c->g + (sc_to_float(m->v_last) - sc_to_float(m->v0)) / tc) / fm;
		kap_sd = kap * 1.41421356f * IMU_ID_VEL_SD / (c->g * tc);
	}
	r->kappa = kap;
	r->offset_n = ofs;
	r->kf = kap * kf_raw;
	float jac[NP] = {kap, c->est_curve ? kap : 0.0f, 0.0f, 0.0f, fm > 0.0f ? r->kf / fm : 0.0f};
	float var = quad(v, jac);
	r->hac = cl_factor(m, thc, jac, false, &ncl, &r->dof, &r->top_t);
	r->blocks = ncl;
	var *= r->hac;
	const float jo[NP] = {0.0f, 0.0f, 0.0f, 0.0f, 1.0f};
	float jl[NP] = {0.0f, 0.0f, 1.0f, c->est_curve ? 1.0f : 0.0f, 0.0f};
	float vo = v[P_OFS][P_OFS] * cl_factor(m, thc, jo, false, &ncl, &nu, NULL);
	r->kappa_sd = fm > 0.0f ? sqrtf(kap_sd * kap_sd + kap * kap * vo / (fm * fm)) : 0.0f;
	r->kf_sd = sqrtf(var + kap_sd * kap_sd * kf_raw * kf_raw);
	/* the slope at hover: kappa (A + 2 B y_h) */
	float yh = m->nz_n ? acc_f(m->nz_thr, QF_UNIT_FRAC, 0) / (float)m->nz_n : 0.0f, sl_raw = A + 2.0f * B * yh;
	r->thr_hover = yh;
	r->slope = kap * sl_raw;
	float js[NP] = {kap, c->est_curve ? 2.0f * kap * yh : 0.0f, 0.0f, 0.0f, fm > 0.0f ? r->slope / fm : 0.0f};
	float vs = quad(v, js) * cl_factor(m, thc, js, false, &ncl, &nu, NULL) + kap_sd * kap_sd * sl_raw * sl_raw;
	r->slope_rsd = r->slope > 0.0f ? sqrtf(vs) / r->slope : INFINITY;
	/* the lag: the grid point moved by the Gauss-Newton step, its second-order term removed */
	float vl = quad(v, jl) * cl_factor(m, thc, jl, false, &ncl, &nu, NULL);
	float dl_sd = kf_raw > 0.0f ? sqrtf(fmaxf(vl, 0.0f)) / kf_raw : INFINITY;
	r->tau = lag_tau(m, bl) * expf(dl + lcorr);
	scales_check(m, r->t_pattern);
	r->tau_sd = r->tau * dl_sd;
	r->cause = verdict(m, r, bl, dl, ne_max);
	torque_solve(m, bd, bl, dl, r);
}

const char *imu_id_cause_text(enum imu_id_cause c)
{
	switch (c) {
	case IMU_ID_OK: return "ok";
	case IMU_ID_NO_DATA: return "too few frames";
	case IMU_ID_NOISE_UNKNOWN: return "accelerometer noise not measured";
	case IMU_ID_LAG_RANGE: return "motor lag outside 5-250 ms";
	case IMU_ID_DELAY_RANGE: return "delay at the largest hypothesis";
	case IMU_ID_DELAY_AMBIGUOUS: return "delay ambiguous";
	case IMU_ID_MODEL: return "residuals coloured beyond the vibration's";
	case IMU_ID_CURVE_WEAK: return "thrust curve not determined";
	case IMU_ID_SCALES: return "a rotor's effectiveness is not MOT_SCALE's";
	}
	return "?";
}

const char *imu_id_cause_remedy(enum imu_id_cause c)
{
	switch (c) {
	case IMU_ID_OK: return "";
	case IMU_ID_NO_DATA:
	case IMU_ID_DELAY_AMBIGUOUS:
	case IMU_ID_CURVE_WEAK: return "raise ID_EXC_TIME or ID_SWP_DZ";
	case IMU_ID_NOISE_UNKNOWN: return "hover still before the experiment";
	case IMU_ID_LAG_RANGE:
	case IMU_ID_DELAY_RANGE: return "check the ESC protocol and its latency";
	case IMU_ID_MODEL: return "check VEH_MASS, the accelerometer's mounting and its vibration";
	case IMU_ID_SCALES: return "MOT_SCALE1..8 from thrust rows (ID_SOURCE 1) or a bench";
	}
	return "";
}
