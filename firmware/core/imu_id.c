/*
 * imu_id.c - the collective rotor model from the accelerometer (imu_id.h).
 */
#include "imu_id.h"
#include "est_ops.h"

#include <math.h>
#include <string.h>

#define NP IMU_ID_NP
#define NT IMU_ID_NT
#define P_B 1   /* B: pinned at 0 when the curve is not estimated */
#define P_LA 2  /* A d ln tau (k_f d ln tau when the curve is known) */
#define P_LB 3  /* B d ln tau: pinned with B */
#define P_OFS 4 /* the accelerometer's offset, N */

#define IMU_ID_CL_FLOOR 0.25 /* the clusters' factor's floor (the sd at least half the white-noise one) */
#define IMU_ID_TOP_SHARE 0.5 /* the top blocks' check: the share of j' H j its top clusters carry */
#define IMU_ID_TOP_T 2.5     /* |D| / sd beyond which its excess joins the variance */

#if defined(__GNUC__)
#define IID_INLINE static inline __attribute__((always_inline))
#else
#define IID_INLINE static inline
#endif

/* the sums' sets: the records whose members are the kinds of one exponent each (imu_id_q.h) */
enum { S_GX, S_HS, S_BLK, S_XQ };
#define HS_N (sizeof(struct imu_id_hyp) / sizeof(imu_id_sum_t))   /* b, rr, bt, rrt */
#define BLK_N (sizeof(struct imu_id_stat) / sizeof(imu_id_sum_t)) /* g, b, rr, bt, rrt */
_Static_assert(HS_N == 2u * NP && BLK_N == 2u * NP + NT + 2u, "the records hold their sums alone");
#define K_RR (NP - 1u)     /* a hypothesis' rr; its torque's from HS_T */
#define HS_T NP            /* a hypothesis' bt[0] */
#define B_B NT             /* a block's b[0]; rr, bt[0] and rrt follow */
#define B_RR (NT + NP)     /* a block's rr */
#define B_T (NT + NP + 1u) /* a block's bt[0] */

/* ---------------------------------------------------------------- number operations
 * The per-frame part below is written once against these: u Q1.30, x Q6.25, c Q4.27, sums in
 * block floating point, acc int64 (imu_id_q.h) in the fixed build; all float otherwise. */
#if OCTO_FIXED
#define SH_XX (2 * QF_IMUX_FRAC - QF_MSUM_FRAC) /* a product of two x values into a sum at exponent 0 */
#define SUM_LIM ((int64_t)1 << 29)              /* a term or sum this large shifts its kind first */
#define E_MAX 100                               /* exponent ceiling (2^70 frames away): beyond it terms are dropped */
#define X_ZERO 0
#define X_ONE ((imu_id_x_t)1 << QF_IMUX_FRAC)
#define E_OF(m, arr, k) ((int)(m)->arr[k])
typedef int64_t term_t;
IID_INLINE int32_t sub32(int32_t a, int32_t b) { return q_sat32((int64_t)a - b); }
IID_INLINE int32_t add32(int32_t a, int32_t b) { return q_sat32((int64_t)a + b); }
/* a scalar_t (Q16.16) as a throttle, as an x in units of 2^sh */
static inline imu_id_u_t u_of_sc(scalar_t v) { return est_shl32c(v, QF_UNIT_FRAC - QF_SC_FRAC); }
static inline imu_id_x_t x_of_sc(scalar_t v, int sh) { return est_scale32(v, QF_IMUX_FRAC - QF_SC_FRAC - sh); }
/* products: u u to u, u u to x, c u to x, c x to x; c0 x0 + c1 x1 */
IID_INLINE imu_id_u_t mul_uu(imu_id_u_t a, imu_id_u_t b) { return q_sat32(est_mul_rnd(a, b, QF_UNIT_FRAC)); }
IID_INLINE imu_id_x_t mul_uux(imu_id_u_t a, imu_id_u_t b)
{
	return q_sat32(est_mul_rnd(a, b, 2 * QF_UNIT_FRAC - QF_IMUX_FRAC));
}
IID_INLINE imu_id_x_t mul_cu(imu_id_c_t c, imu_id_u_t u)
{
	return q_sat32(est_mul_rnd(c, u, QF_IMUC_FRAC + QF_UNIT_FRAC - QF_IMUX_FRAC));
}
IID_INLINE imu_id_x_t mul_cx(imu_id_c_t c, imu_id_x_t x) { return q_sat32(est_mul_rnd(c, x, QF_IMUC_FRAC)); }
IID_INLINE imu_id_x_t lin2(imu_id_c_t c0, imu_id_x_t x0, imu_id_c_t c1, imu_id_x_t x1)
{
	return q_sat32(est_mul_rnd(c0, x0, QF_IMUC_FRAC) + est_mul_rnd(c1, x1, QF_IMUC_FRAC));
}
/* a lag filter's step y + (1 - a) (u - y), k = 1 - a: of a throttle, of an x */
IID_INLINE imu_id_u_t filt_u(imu_id_u_t y, imu_id_u_t k, imu_id_u_t u)
{
	return q_sat32((int64_t)y + est_mul_rnd(k, sub32(u, y), QF_UNIT_FRAC));
}
IID_INLINE imu_id_x_t filt_x(imu_id_x_t y, imu_id_u_t k, imu_id_x_t u)
{
	return q_sat32((int64_t)y + est_mul_rnd(k, sub32(u, y), QF_UNIT_FRAC));
}
/* the pole's coefficient stored: 1 - a = -expm1(-dt / tau) (its precision where a is near 1) */
static imu_id_u_t lag_coef(float x) { return iid_u_of_float(-expm1f(-x)); }
/* the [1 2 1] / 4 smoother: of a ring of three, of a series (r: its last input and the last
 * two's sum) */
static imu_id_x_t smooth(const imu_id_x_t *r)
{
	return q_sat32(est_shr64c((int64_t)r[0] + 2 * (int64_t)r[1] + r[2], 2u));
}
static imu_id_x_t smooth_in(imu_id_x_t r[2], imu_id_x_t v)
{
	imu_id_x_t p = add32(v, r[0]), o = q_sat32(est_shr64c((int64_t)p + r[1], 2u));
	r[0] = v;
	r[1] = p;
	return o;
}
/* the grid's end differences: 4 s1 - 3 s0 - s2 (its first lags), 3 s0 - 4 s1 + s2 (its last) */
static imu_id_x_t end_diff(imu_id_x_t s0, imu_id_x_t s1, imu_id_x_t s2)
{
	return q_sat32(4 * (int64_t)s1 - 3 * (int64_t)s0 - s2);
}
static imu_id_x_t end_diff_hi(imu_id_x_t s0, imu_id_x_t s1, imu_id_x_t s2)
{
	return q_sat32(3 * (int64_t)s0 - 4 * (int64_t)s1 + s2);
}
/* the mean of the rotors' throttles */
static imu_id_u_t u_mean(const imu_id_u_t u[IMU_ID_ROTORS])
{
	int64_t s = 0;
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
		s += u[j];
	return (imu_id_u_t)est_shr64c(s, 3u);
}
_Static_assert(IMU_ID_ROTORS == 8, "u_mean divides by 8");
/* acc + f^2 (Q12.25) */
static inline imu_id_acc_t acc_sq(imu_id_acc_t acc, imu_id_x_t f)
{
	return q_add64(acc, est_mul_rnd(f, f, QF_IMUX_FRAC));
}
/* a product of two x values, a value, rounded to a sum's mantissa at exponent e */
IID_INLINE term_t term(imu_id_x_t a, imu_id_x_t b, int e)
{
	int s = SH_XX + e;
	if (s >= 1 && s <= 62)
		return est_mul_rnd(a, b, (unsigned)s);
	return est_scale64(q_smul32(a, b), -s); /* beyond: left shifts (saturating) or 0 */
}
IID_INLINE term_t term1(imu_id_x_t a, int e) { return est_scale64(a, QF_MSUM_FRAC - QF_IMUX_FRAC - e); }
static inline bool sum_big(int64_t v) { return v >= SUM_LIM || v <= -SUM_LIM; }

/* set's sums (nrec records of n members), its exponents */
static imu_id_sum_t *set_of(struct imu_id *m, unsigned set, int8_t **e, unsigned *n, unsigned *nrec)
{
	switch (set) {
	case S_GX: *e = m->e_gx, *n = NT - 3u, *nrec = IMU_ID_LAGS; return &m->gx[0][0];
	case S_HS: *e = m->e_hs, *n = HS_N, *nrec = IMU_ID_LAGS * IMU_ID_DELAYS; return &m->hs[0][0].b[0];
	case S_BLK: *e = m->e_blk, *n = BLK_N, *nrec = IMU_ID_BLOCKS + 1u; return &m->blk[0].g[0];
	default: *e = m->e_xq, *n = 2u * (IMU_ID_NX + 1u), *nrec = 1u; return &m->xq[0][0];
	}
}
/* every exponent of set at IMU_ID_E0 (its sums zero) */
static void set_restart(struct imu_id *m, unsigned set)
{
	int8_t *e;
	unsigned n, nrec;
	set_of(m, set, &e, &n, &nrec);
	for (unsigned k = 0; k < n; k++)
		e[k] = IMU_ID_E0;
}
/* a term or a sum of 2^29 or more: kind k of set shifted right (rounded, its exponent
 * raised) until both are below 2^28 */
static void sum_fit(struct imu_id *m, unsigned set, unsigned k, term_t *t)
{
	int8_t *e;
	unsigned n, nrec;
	imu_id_sum_t *v = set_of(m, set, &e, &n, &nrec);
	uint64_t a = (uint64_t)(*t < 0 ? -*t : *t);
	for (unsigned r = 0; r < nrec; r++) {
		imu_id_sum_t s = v[r * n + k];
		a |= (uint64_t)(s < 0 ? -(int64_t)s : s);
	}
	int sh = 64 - est_clz64(a) - 28;
	if (sh <= 0)
		return;
	if ((int)e[k] + sh > E_MAX) { /* unreachable: 2^70 frames of the largest terms */
		*t = 0;
		return;
	}
	for (unsigned r = 0; r < nrec; r++)
		v[r * n + k] = est_scale32(v[r * n + k], -sh);
	e[k] = (int8_t)(e[k] + sh);
	*t = est_scale64(*t, -sh);
}
/* *s + t, s of kind k of set: a sum and a term below 2^29 in magnitude cannot wrap */
IID_INLINE void sadd(struct imu_id *m, unsigned set, unsigned k, imu_id_sum_t *s, term_t t)
{
	if (sum_big(t) || sum_big(*s))
		sum_fit(m, set, k, &t);
	*s += (imu_id_sum_t)t;
}
/* sadd of term(a, b, e) when either is large (sadd_xx's rare case) */
static void sadd_slow(struct imu_id *m, unsigned set, unsigned k, imu_id_sum_t *s, imu_id_x_t a, imu_id_x_t b, int e)
{
	sadd(m, set, k, s, term(a, b, e));
}
/* sadd(m, set, k, s, term(a, b, e)) with e the kind's exponent, in 32-bit words: the
 * magnitudes' product from four 16 x 16 ones (Cortex-M0 has no long multiply), shifted by
 * s = SH_XX + e and rounded as est_mul_rnd; a term or a sum of 2^29 or more, or s outside
 * [1, 62], takes sadd_slow */
IID_INLINE void sadd_xx(struct imu_id *m, unsigned set, unsigned k, imu_id_sum_t *sum, imu_id_x_t a, imu_id_x_t b,
			int e)
{
	int s = SH_XX + e;
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a, ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b;
	uint32_t al = ua & 0xffffu, ah = ua >> 16, bl = ub & 0xffffu, bh = ub >> 16;
	uint32_t ll = al * bl, lh = al * bh, hl = ah * bl, hh = ah * bh;
	uint32_t mid = (ll >> 16) + (lh & 0xffffu) + (hl & 0xffffu);
	uint32_t hi = hh + (lh >> 16) + (hl >> 16) + (mid >> 16), lo = (mid << 16) | (ll & 0xffffu), r;
	if (s >= 32 && s <= 62) { /* hi < 2^30 */
		unsigned sh = (unsigned)s - 32u;
		r = sh ? (hi >> sh) + ((hi >> (sh - 1u)) & 1u) : hi + (lo >> 31);
	} else if (s >= 1 && s < 32 && (hi >> (s - 1)) == 0u) { /* the quotient below 2^31 */
		r = (hi << (32 - s)) + (lo >> s) + ((lo >> (s - 1)) & 1u);
	} else {
		r = 1u << 29; /* the slow case */
	}
	if (r >= (1u << 29) || (uint32_t)*sum + (1u << 29) >= (1u << 30)) {
		sadd_slow(m, set, k, sum, a, b, e);
		return;
	}
	*sum += (a < 0) != (b < 0) ? -(int32_t)r : (int32_t)r;
}
static int kexp_of(const struct imu_id *m) { return m->kexp; }
static int texp_of(const struct imu_id *m) { return m->texp; }
#else
#define X_ZERO 0.0f
#define X_ONE 1.0f
#define E_OF(m, arr, k) 0
typedef float term_t;
static inline float sub32(float a, float b) { return a - b; }
static inline float add32(float a, float b) { return a + b; }
static inline imu_id_u_t u_of_sc(scalar_t v) { return sc_to_float(v); }
static inline imu_id_x_t x_of_sc(scalar_t v, int sh)
{
	(void)sh;
	return sc_to_float(v);
}
static inline imu_id_u_t mul_uu(imu_id_u_t a, imu_id_u_t b) { return a * b; }
static inline imu_id_x_t mul_uux(imu_id_u_t a, imu_id_u_t b) { return a * b; }
static inline imu_id_x_t mul_cu(imu_id_c_t c, imu_id_u_t u) { return c * u; }
static inline imu_id_x_t mul_cx(imu_id_c_t c, imu_id_x_t x) { return c * x; }
static inline imu_id_x_t lin2(imu_id_c_t c0, imu_id_x_t x0, imu_id_c_t c1, imu_id_x_t x1) { return c0 * x0 + c1 * x1; }
/* a y + (1 - a) u: the float build keeps the pole a */
static inline imu_id_u_t filt_u(imu_id_u_t y, imu_id_u_t a, imu_id_u_t u) { return a * y + (1.0f - a) * u; }
static inline imu_id_x_t filt_x(imu_id_x_t y, imu_id_u_t a, imu_id_x_t u) { return a * y + (1.0f - a) * u; }
static imu_id_u_t lag_coef(float x) { return expf(-x); }
static float smooth(const float *r) { return 0.25f * (r[0] + 2.0f * r[1] + r[2]); }
static float smooth_in(float r[2], float v)
{
	float p = v + r[0], o = 0.25f * (p + r[1]);
	r[0] = v;
	r[1] = p;
	return o;
}
static inline float end_diff(float s0, float s1, float s2) { return 4.0f * s1 - 3.0f * s0 - s2; }
static inline float end_diff_hi(float s0, float s1, float s2) { return 3.0f * s0 - 4.0f * s1 + s2; }
static float u_mean(const float u[IMU_ID_ROTORS])
{
	float s = 0.0f;
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
		s += u[j];
	return s / (float)IMU_ID_ROTORS;
}
static inline float acc_sq(float acc, float f) { return acc + f * f; }
static inline term_t term(float a, float b, int e)
{
	(void)e;
	return a * b;
}
static inline term_t term1(float a, int e)
{
	(void)e;
	return a;
}
static void set_restart(struct imu_id *m, unsigned set)
{
	(void)m;
	(void)set;
}
static inline void sadd(struct imu_id *m, unsigned set, unsigned k, float *s, float t)
{
	(void)m;
	(void)set;
	(void)k;
	*s += t;
}
static inline void sadd_xx(struct imu_id *m, unsigned set, unsigned k, float *s, float a, float b, int e)
{
	(void)m;
	(void)set;
	(void)k;
	(void)e;
	*s += a * b;
}
static int kexp_of(const struct imu_id *m)
{
	(void)m;
	return 0;
}
static int texp_of(const struct imu_id *m)
{
	(void)m;
	return 0;
}
#endif
static inline imu_id_x_t x_add(imu_id_x_t a, imu_id_x_t b) { return add32(a, b); }
static inline imu_id_x_t x_sub(imu_id_x_t a, imu_id_x_t b) { return sub32(a, b); }

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

/* the lag whose patterns' responses advance computes: the clusters' hypothesis after the
 * refinement (refine), the grid's centre */
#define CL_LAG (IMU_ID_LAGS / 2u)
#define AGE (IMU_ID_DELAYS - 1u) /* the bank's regressors' age: the filters' input is this old */

/* the throttles into the queue and the lag filters on the ones AGE frames before (each rotor's
 * scaled by the square root of its scale: x2 is the sum of the outputs' squares; x1 from the
 * scaled throttles' sum, the filters being linear); x1 and x2 smoothed into s, and
 * the patterns' responses into qs */
static void advance(struct imu_id *m, const imu_id_u_t u_new[IMU_ID_ROTORS], imu_id_x_t s[2][IMU_ID_LAGS])
{
	imu_id_u_t u[IMU_ID_ROTORS];
	imu_id_x_t us = X_ZERO;
	imu_id_u_t *uq = m->uq[m->uqh];
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++) {
		u[j] = mul_uu(m->rs[j], uq[j]);
		us = x_add(us, mul_cu(m->sc[j], uq[j]));
		uq[j] = u_new[j];
	}
	m->uqh = (uint8_t)(m->uqh + 1u < AGE ? m->uqh + 1u : 0u);
	for (unsigned l = 0; l < IMU_ID_LAGS; l++) {
		imu_id_u_t k = m->lk[l], *y = m->y[l];
		imu_id_x_t q = X_ZERO; /* at most 8 terms below 4: no overflow */
#pragma GCC unroll 8
		for (unsigned j = 0; j < IMU_ID_ROTORS; j++) {
			imu_id_u_t v = filt_u(y[j], k, u[j]);
			y[j] = v;
			q += mul_uux(v, v);
		}
		imu_id_x_t yc = filt_x(m->yc[l], k, us);
		m->yc[l] = yc;
		s[0][l] = smooth_in(m->x1[l], yc);
		s[1][l] = smooth_in(m->x2[l], q);
	}
	imu_id_x_t p1 = X_ZERO, p2 = X_ZERO;
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++) {
		imu_id_x_t sy = mul_uux(m->rs[j], m->y[CL_LAG][j]);
		p1 = x_add(p1, mul_cx(m->pc[0][j], sy));
		p2 = x_add(p2, mul_cx(m->pc[1][j], sy));
	}
	m->qs[0] = smooth_in(m->q1, p1);
	m->qs[1] = smooth_in(m->q2, p2);
}

/* the frame's smoothed force and torque (less the reference at hover) into the rings by age;
 * ok: the frame is taken (excited, the smoother full) */
static void push_meas(struct imu_id *m, imu_id_x_t f, imu_id_x_t t, bool ok)
{
	m->fh = (uint8_t)(m->fh ? m->fh - 1u : IMU_ID_DELAYS - 1u);
	m->fz[m->fh] = f;
	m->tz[m->fh] = t;
	m->fok = (uint8_t)(((unsigned)m->fok << 1 | (ok ? 1u : 0u)) & ((1u << IMU_ID_DELAYS) - 1u));
}

/* the rings' slot of the frame of age k */
static unsigned meas_slot(const struct imu_id *m, unsigned k)
{
	unsigned i = m->fh + k;
	return i < IMU_ID_DELAYS ? i : i - IMU_ID_DELAYS;
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
		uq[j] = u_of_sc(thr0[j]);
		m->pc[0][j] = iid_c_of_float(m->cfg.pat[0][j]);
		m->pc[1][j] = iid_c_of_float(m->cfg.pat[1][j]);
	}
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
		advance(m, uq, s); /* the steady state in the smoother's rings */
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
		set_restart(m, k);
#else
	(void)exp_of;
#endif
	xmap_set(m);
}

void imu_id_step(struct imu_id *m, const scalar_t thr_prev[IMU_ID_ROTORS], scalar_t f_n, scalar_t fw_n, scalar_t vz,
		 scalar_t tq_n, bool excited)
{
	if (m->q_pending)
		imu_id_process(m);
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
		m->q_thr[j] = thr_prev[j];
	m->q_f = f_n;
	m->q_fw = fw_n;
	m->q_vz = vz;
	m->q_tq = tq_n;
	m->q_excited = excited;
	m->q_pending = true;
}

void imu_id_hold(struct imu_id *m, const scalar_t thr_prev[IMU_ID_ROTORS])
{
	if (m->q_pending)
		imu_id_process(m);
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
		m->h_thr[j] = thr_prev[j];
	m->n_hold++;
}

/* the lost frames counted by imu_id_hold: the filters run on what the plant held, the
 * calibration takes the last frame's force for each, the smoother restarts and the bank
 * takes no regressors the lost frames' force would pair with */
static void holds_take(struct imu_id *m)
{
	for (; m->n_hold > 0u; m->n_hold--) {
		imu_id_u_t u[IMU_ID_ROTORS];
		imu_id_x_t s[2][IMU_ID_LAGS];
		for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
			u[j] = u_of_sc(m->h_thr[j]);
		advance(m, u, s);
		push_meas(m, X_ZERO, X_ZERO, false);
		if (m->n_cal > 0u) {
			m->fw_sum += m->fw_last;
			m->n_cal++;
		}
		m->n_fr = 0;
	}
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

/* hypothesis (d, l)'s force fit (fit), as the parameters */
static float hyp_solve(const struct imu_id *m, unsigned d, unsigned l, float th[NP], float h[NP][NP])
{
	struct stat_f s;
	hyp_stat(m, d, l, &s);
	float j = fit(m, s.g, s.b, s.rr, th, h);
	to_params(m, th, h);
	return j;
}

/* the same hypothesis' torque fit */
static float hyp_solve_tq(const struct imu_id *m, unsigned d, unsigned l, float th[NP], float h[NP][NP])
{
	struct stat_f s;
	hyp_stat(m, d, l, &s);
	float j = fit(m, s.g, s.bt, s.rrt, th, h);
	to_params(m, th, h);
	return j;
}

/* a frame's regressors x and responses (force z, torque zt, both relative to the
 * references) into a block's sums */
static void stat_add(struct imu_id *m, struct imu_id_stat *s, const imu_id_x_t x[NP], imu_id_x_t z, imu_id_x_t zt,
		     bool tq)
{
	/* G += x x' (its upper triangle in storage order) and b += x z, written out for the five
	 * parameters: kinds 0..NT - 1, then b, rr, bt, rrt (B_B...) */
	_Static_assert(NP == 5 && NT == 15, "stat_add is written out for five parameters");
	sadd_xx(m, S_BLK, 0, &s->g[0], x[0], x[0], E_OF(m, e_blk, 0));
	sadd_xx(m, S_BLK, 1, &s->g[1], x[0], x[1], E_OF(m, e_blk, 1));
	sadd_xx(m, S_BLK, 2, &s->g[2], x[0], x[2], E_OF(m, e_blk, 2));
	sadd_xx(m, S_BLK, 3, &s->g[3], x[0], x[3], E_OF(m, e_blk, 3));
	sadd_xx(m, S_BLK, 4, &s->g[4], x[0], x[4], E_OF(m, e_blk, 4));
	sadd_xx(m, S_BLK, 5, &s->g[5], x[1], x[1], E_OF(m, e_blk, 5));
	sadd_xx(m, S_BLK, 6, &s->g[6], x[1], x[2], E_OF(m, e_blk, 6));
	sadd_xx(m, S_BLK, 7, &s->g[7], x[1], x[3], E_OF(m, e_blk, 7));
	sadd_xx(m, S_BLK, 8, &s->g[8], x[1], x[4], E_OF(m, e_blk, 8));
	sadd_xx(m, S_BLK, 9, &s->g[9], x[2], x[2], E_OF(m, e_blk, 9));
	sadd_xx(m, S_BLK, 10, &s->g[10], x[2], x[3], E_OF(m, e_blk, 10));
	sadd_xx(m, S_BLK, 11, &s->g[11], x[2], x[4], E_OF(m, e_blk, 11));
	sadd_xx(m, S_BLK, 12, &s->g[12], x[3], x[3], E_OF(m, e_blk, 12));
	sadd_xx(m, S_BLK, 13, &s->g[13], x[3], x[4], E_OF(m, e_blk, 13));
	sadd_xx(m, S_BLK, 14, &s->g[14], x[4], x[4], E_OF(m, e_blk, 14));
	for (unsigned i = 0; i < NP; i++)
		sadd_xx(m, S_BLK, B_B + i, &s->b[i], x[i], z, E_OF(m, e_blk, B_B + i));
	sadd_xx(m, S_BLK, B_RR, &s->rr, z, z, E_OF(m, e_blk, B_RR));
	if (!tq)
		return;
	for (unsigned i = 0; i < NP; i++)
		sadd_xx(m, S_BLK, B_T + i, &s->bt[i], x[i], zt, E_OF(m, e_blk, B_T + i));
	sadd_xx(m, S_BLK, B_T + NP, &s->rrt, zt, zt, E_OF(m, e_blk, B_T + NP));
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

static imu_id_x_t sens_x(const imu_id_x_t s[IMU_ID_LAGS], unsigned l, imu_id_c_t ih)
{
	const unsigned e = IMU_ID_LAGS - 1u;
	if (l == 0u)
		return mul_cx(ih, end_diff(s[0], s[1], s[2]));
	if (l == e)
		return mul_cx(ih, end_diff_hi(s[e], s[e - 1u], s[e - 2u]));
	return mul_cx(ih, x_sub(s[l + 1u], s[l - 1u]));
}

/* lag l's centred regressors (the offset's 1 implied) of the frame AGE old */
static void lag_x(const struct imu_id_xmap *xm, const imu_id_x_t s[2][IMU_ID_LAGS], unsigned l, imu_id_x_t x[NP - 1u])
{
	const imu_id_c_t *k = xm->k;
	const imu_id_x_t d0 = sens_x(s[0], l, xm->ih), d1 = sens_x(s[1], l, xm->ih);
	x[0] = x_add(lin2(k[0], s[0][l], k[1], s[1][l]), xm->o[0]);
	x[P_B] = x_add(lin2(k[2], s[0][l], k[3], s[1][l]), xm->o[1]);
	x[P_LA] = lin2(k[0], d0, k[1], d1);
	x[P_LB] = lin2(k[2], d0, k[3], d1);
}

/* a hypothesis' products of the regressors with its measurement z (relative to the
 * reference model) and z's square: the members k0..k0 + 4 of its record b (the force's from 0,
 * the torque's from HS_T) */
IID_INLINE void hyp_add(struct imu_id *m, imu_id_sum_t *b, unsigned k0, imu_id_x_t x0, imu_id_x_t x1, imu_id_x_t x2,
			imu_id_x_t x3, imu_id_x_t z)
{
	sadd_xx(m, S_HS, k0, &b[k0], x0, z, E_OF(m, e_hs, k0));
	sadd_xx(m, S_HS, k0 + 1u, &b[k0 + 1u], x1, z, E_OF(m, e_hs, k0 + 1u));
	sadd_xx(m, S_HS, k0 + 2u, &b[k0 + 2u], x2, z, E_OF(m, e_hs, k0 + 2u));
	sadd_xx(m, S_HS, k0 + 3u, &b[k0 + 3u], x3, z, E_OF(m, e_hs, k0 + 3u));
	sadd_xx(m, S_HS, k0 + 4u, &b[k0 + 4u], z, z, E_OF(m, e_hs, k0 + 4u));
}

/* the regressors of the frame AGE old (from its smoothed sums s) into every hypothesis: the
 * products x x' and the sums of x0 and x1 into their lag's sums (hyp_stat derives those of
 * x2 and x3), the products with the force of each delay (less the reference model's
 * prediction from x) into the hypothesis' own */
static void bank_take(struct imu_id *m, const imu_id_x_t s[2][IMU_ID_LAGS])
{
	const struct imu_id_cfg *c = &m->cfg;
	const struct imu_id_xmap xl = m->xm, *xm = &xl; /* a copy: the sums' stores cannot alias it */
	const imu_id_c_t *k = xm->k, r0 = xm->r0, r1 = xm->r1, ih = xm->ih;
	imu_id_x_t fd[IMU_ID_DELAYS], td[IMU_ID_DELAYS];
	for (unsigned q = 0; q < IMU_ID_DELAYS; q++) {
		fd[q] = m->fz[meas_slot(m, AGE - q)];
		td[q] = m->tz[meas_slot(m, AGE - q)];
		m->fs[q] += fd[q];
		m->ts[q] += td[q];
	}
	m->n_st++;
	const bool tq_one = c->torque && m->cl_on, tq_all = c->torque && !m->cl_on;
	const unsigned qf = m->cl_d < IMU_ID_DELAYS ? m->cl_d : 0u;
	const imu_id_x_t tdf = td[qf];
	_Static_assert(NP == 5 && NT == 15, "bank_take is written out for five parameters");
	_Static_assert(sizeof(struct imu_id_hyp) == 2u * NP * sizeof(imu_id_sum_t), "b, rr, bt, rrt in a row");
	for (unsigned l = 0; l < IMU_ID_LAGS; l++) {
		/* lag_x, written out (the grid's ends by sens_x) */
		imu_id_x_t d0, d1;
		if (l - 1u < IMU_ID_LAGS - 2u) {
			d0 = mul_cx(ih, x_sub(s[0][l + 1u], s[0][l - 1u]));
			d1 = mul_cx(ih, x_sub(s[1][l + 1u], s[1][l - 1u]));
		} else {
			d0 = sens_x(s[0], l, ih);
			d1 = sens_x(s[1], l, ih);
		}
		const imu_id_x_t x0 = x_add(lin2(k[0], s[0][l], k[1], s[1][l]), xm->o[0]);
		const imu_id_x_t x1 = x_add(lin2(k[2], s[0][l], k[3], s[1][l]), xm->o[1]);
		const imu_id_x_t x2 = lin2(k[0], d0, k[1], d1), x3 = lin2(k[2], d0, k[3], d1);
		const imu_id_x_t xr = lin2(r0, x0, r1, x1);
		imu_id_sum_t *g = m->gx[l];
		sadd_xx(m, S_GX, 0, &g[0], x0, x0, E_OF(m, e_gx, 0));
		sadd_xx(m, S_GX, 1, &g[1], x0, x1, E_OF(m, e_gx, 1));
		sadd_xx(m, S_GX, 2, &g[2], x0, x2, E_OF(m, e_gx, 2));
		sadd_xx(m, S_GX, 3, &g[3], x0, x3, E_OF(m, e_gx, 3));
		sadd(m, S_GX, 4, &g[4], term1(x0, E_OF(m, e_gx, 4)));
		sadd_xx(m, S_GX, 5, &g[5], x1, x1, E_OF(m, e_gx, 5));
		sadd_xx(m, S_GX, 6, &g[6], x1, x2, E_OF(m, e_gx, 6));
		sadd_xx(m, S_GX, 7, &g[7], x1, x3, E_OF(m, e_gx, 7));
		sadd(m, S_GX, 8, &g[8], term1(x1, E_OF(m, e_gx, 8)));
		sadd_xx(m, S_GX, 9, &g[9], x2, x2, E_OF(m, e_gx, 9));
		sadd_xx(m, S_GX, 10, &g[10], x2, x3, E_OF(m, e_gx, 10));
		sadd_xx(m, S_GX, 11, &g[11], x3, x3, E_OF(m, e_gx, 11));
		imu_id_x_t kx = mul_cx(xm->kf, xr);
#pragma GCC unroll 5
		for (unsigned q = 0; q < IMU_ID_DELAYS; q++) {
			hyp_add(m, &m->hs[l][q].b[0], 0u, x0, x1, x2, x3, x_sub(fd[q], kx));
		}
		/* the torque's sums: after the refinement only the delay frozen there (the
		 * clusters' own), whose lags k_tau is solved on; before it every delay's, which
		 * the refinement clears */
		if (tq_one) {
			hyp_add(m, &m->hs[l][qf].b[0], HS_T, x0, x1, x2, x3, x_sub(tdf, mul_cx(xm->kt, xr)));
		} else if (tq_all) {
			kx = mul_cx(xm->kt, xr);
			for (unsigned q = 0; q < IMU_ID_DELAYS; q++) {
				hyp_add(m, &m->hs[l][q].b[0], HS_T, x0, x1, x2, x3, x_sub(td[q], kx));
			}
		}
	}
}

/* the frozen hypothesis' frame into its block (a full set of blocks merges in pairs), and its
 * products with the two patterns' responses into the scales' check (whose other sums are the
 * blocks') */
static void cl_add(struct imu_id *m, const imu_id_x_t s[2][IMU_ID_LAGS])
{
	const struct imu_id_xmap xl = m->xm, *xm = &xl;
	imu_id_x_t xx[IMU_ID_NX];
	lag_x(xm, s, m->cl_l, xx);
	xx[P_OFS] = X_ONE;
	xx[NP] = m->qs[0];
	xx[NP + 1u] = m->qs[1];
	/* the rings hold f less k_f0 x_r(y_h): z = f - k_f0 x_r */
	imu_id_x_t xr = lin2(xm->r0, xx[0], xm->r1, xx[P_B]);
	unsigned a = meas_slot(m, AGE - m->cl_d);
	imu_id_x_t z = x_sub(m->fz[a], mul_cx(xm->kf, xr)), zt = x_sub(m->tz[a], mul_cx(xm->kt, xr));
	for (unsigned i = 0; i < IMU_ID_NX; i++) {
		sadd_xx(m, S_XQ, 2u * i, &m->xq[i][0], xx[i], xx[NP], E_OF(m, e_xq, 2u * i));
		sadd_xx(m, S_XQ, 2u * i + 1u, &m->xq[i][1], xx[i], xx[NP + 1u], E_OF(m, e_xq, 2u * i + 1u));
	}
	sadd_xx(m, S_XQ, 2u * IMU_ID_NX, &m->xq[IMU_ID_NX][0], xx[NP], z, E_OF(m, e_xq, 2u * IMU_ID_NX));
	sadd_xx(m, S_XQ, 2u * IMU_ID_NX + 1u, &m->xq[IMU_ID_NX][1], xx[NP + 1u], z, E_OF(m, e_xq, 2u * IMU_ID_NX + 1u));
	m->xn++;
	stat_add(m, &m->blk[m->nb], xx, z, zt, m->cfg.torque);
	if (++m->cl_k < m->cl_len)
		return;
	m->cl_k = 0;
	if (++m->nb < IMU_ID_BLOCKS)
		return;
	/* block k the sum of blocks 2 k and 2 k + 1 (in place: block k is read before it is
	 * written, the pair's sums share their exponents) */
	for (unsigned k = 0; k < IMU_ID_BLOCKS / 2u; k++) {
		imu_id_sum_t *t = &m->blk[k].g[0];
		const imu_id_sum_t *p0 = &m->blk[2u * k].g[0], *p1 = &m->blk[2u * k + 1u].g[0];
		for (unsigned i = 0; i < BLK_N; i++) {
			t[i] = p0[i];
			sadd(m, S_BLK, i, &t[i], (term_t)p1[i]);
		}
	}
	memset(&m->blk[IMU_ID_BLOCKS / 2u], 0, (IMU_ID_BLOCKS / 2u + 1u) * sizeof m->blk[0]);
	m->nb = IMU_ID_BLOCKS / 2u;
	m->cl_len *= 2u;
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
static void refine(struct imu_id *m)
{
	unsigned bd, bl;
	float jr[IMU_ID_DELAYS][IMU_ID_LAGS];
	best_hyp(m, &bd, &bl, jr);
	float th[NP], h[NP][NP], h0 = m->lstep;
	hyp_solve(m, bd, bl, th, h);
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
	set_restart(m, S_GX);
	set_restart(m, S_HS);
	m->n_st = 0;
	m->fok = 0; /* the bank waits for the new grid's regressors and the new reference's force */
	m->refined = true;
	m->cl_d = (uint8_t)bd;
	m->cl_l = (uint8_t)CL_LAG;
	m->cl_len = m->cfg.block_frames ? m->cfg.block_frames : 90u;
	m->cl_on = true;
	xmap_set(m); /* the new grid's step, the references the scales moved */
}

void imu_id_process(struct imu_id *m)
{
	holds_take(m);
	if (!m->q_pending)
		return;
	m->q_pending = false;
	imu_id_u_t thr[IMU_ID_ROTORS];
	for (unsigned j = 0; j < IMU_ID_ROTORS; j++)
		thr[j] = u_of_sc(m->q_thr[j]);
	scalar_t qfw = m->q_fw, qvz = m->q_vz, qtq = m->cfg.torque ? m->q_tq : SC_ZERO;
	if (!sc_isfinite(qtq)) {
		m->tq_lost = true;
		qtq = SC_ZERO;
	}
	imu_id_x_t s[2][IMU_ID_LAGS];
	advance(m, thr, s);
	if (m->q_excited) { /* the calibration's sums: from the velocity before the first */
		if (m->n_cal == 0u)
			m->v0 = m->vz_prev;
		m->fw_sum += qfw;
		m->n_cal++;
		m->v_last = qvz;
	}
	m->fw_last = qfw;
	m->vz_prev = qvz;
	m->fr[2] = m->fr[1];
	m->fr[1] = m->fr[0];
	m->fr[0] = x_of_sc(m->q_f, kexp_of(m));
	m->tr[2] = m->tr[1];
	m->tr[1] = m->tr[0];
	m->tr[0] = x_of_sc(qtq, texp_of(m));
	if (++m->n_fr < 3u) {
		push_meas(m, X_ZERO, X_ZERO, false); /* the smoother fills */
		return;
	}
	imu_id_x_t f = smooth(m->fr), t = smooth(m->tr);
	if (!m->q_excited) {
		push_meas(m, X_ZERO, X_ZERO, false);
		m->nz_n++;
		m->nz_s += f;
		m->nz_ss = acc_sq(m->nz_ss, f);
		m->nz_thr += u_mean(thr);
		return;
	}
	m->n_exc++;
	m->ff = acc_sq(m->ff, f);
	const struct imu_id_cfg *c = &m->cfg;
	push_meas(m, x_sub(f, m->xm.fref), x_sub(t, m->xm.tref), true);
	if (m->fok != (1u << IMU_ID_DELAYS) - 1u)
		return; /* a delay's force is not all taken frames' */
	bank_take(m, s);
	if (!m->refined && (float)m->n_exc >= IMU_ID_FREEZE * (float)c->n_frames && m->n_st >= 30u) {
		refine(m);
		return;
	}
	if (m->cl_on)
		cl_add(m, s);
}

/* z solving (I - H W) z = v by Gaussian elimination with partial pivoting; false if singular */
static bool solve_lev(const double h[NP][NP], const double w[NP][NP], const double v[NP], double z[NP])
{
	double a[NP][NP + 1];
	for (unsigned i = 0; i < NP; i++) {
		for (unsigned k = 0; k < NP; k++) {
			double hw = 0.0;
			for (unsigned q = 0; q < NP; q++)
				hw += h[i][q] * w[q][k];
			a[i][k] = (i == k ? 1.0 : 0.0) - hw;
		}
		a[i][NP] = v[i];
	}
	for (unsigned k = 0; k < NP; k++) {
		unsigned p = k;
		for (unsigned i = k + 1; i < NP; i++)
			if (fabs(a[i][k]) > fabs(a[p][k]))
				p = i;
		if (!(fabs(a[p][k]) > 1e-9))
			return false;
		for (unsigned q = 0; q <= NP; q++) {
			double t = a[k][q];
			a[k][q] = a[p][q];
			a[p][q] = t;
		}
		for (unsigned i = k + 1; i < NP; i++) {
			double f = a[i][k] / a[k][k];
			for (unsigned q = k; q <= NP; q++)
				a[i][q] -= f * a[k][q];
		}
	}
	for (unsigned i = NP; i-- > 0;) {
		double t = a[i][NP];
		for (unsigned q = i + 1; q < NP; q++)
			t -= a[i][q] * z[q];
		z[i] = t / a[i][i];
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
 * leverage-corrected one (CR3, the clusters' jackknife): with H = G^-1 of all the clusters, W_g
 * a cluster's Gram matrix and r_g its score (b_g - W_g theta),
 *     V = sum_g (z_g' r_g)^2,   (I - H W_g) z_g = H j,
 * which is the sum of the squared changes of j' theta when cluster g is left out. The plain
 * sandwich sum_g (j' H r_g)^2 is optimistic where a few clusters carry the information (the
 * sweep's top steps): a cluster of high leverage pulls the fit towards itself, so its own
 * residuals understate what it carries. Its degrees of freedom (Bell and McCaffrey's, for
 * white residuals): V is a weighted sum of chi^2_1 whose weights are the eigenvalues of the
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
		if (!solve_lev(h, w, v, z))
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
	float j = hyp_solve_tq(m, bd, bl, th, h);
	if (bl > 0u && bl + 1u < IMU_ID_LAGS) {
		float tm[NP], tp[NP], hh[NP][NP], k = dl / (4.0f * grid_step(m));
		hyp_solve_tq(m, bd, bl - 1u, tm, hh);
		hyp_solve_tq(m, bd, bl + 1u, tp, hh);
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
	hyp_solve(m, bd, bl, th, h);
	float hstep = grid_step(m), dl = step_of(m, th), lcorr = 0.0f;
	/* the grid point nearest the lag found (the least residual's may lie a few of the
	 * refined grid's steps off where the lag is weakly seen): the expansion below is about it */
	for (int it = 0; it < 3; it++) {
		float q = (float)bl + dl / hstep;
		unsigned to = q <= 0.0f ? 0u : q >= (float)(IMU_ID_LAGS - 1) ? IMU_ID_LAGS - 1u : (unsigned)(q + 0.5f);
		if (to == bl)
			break;
		bl = to;
		j0 = hyp_solve(m, bd, bl, th, h);
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
		hyp_solve(m, bd, bl - 1u, tm, hh);
		hyp_solve(m, bd, bl + 1u, tp, hh);
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
