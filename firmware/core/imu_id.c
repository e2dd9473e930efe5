/*
 * imu_id.c - the collective rotor model from the accelerometer (imu_id.h): the per-frame part
 * (the lag filters, smoothers, regressors and the bank's and the blocks' sums), integer in the
 * fixed build (imu_id_q.h). The set-up, the grid's refinement and the solve are imu_id_solve.c.
 */
#include "imu_id.h"
#include "est_ops.h"
#include "imu_id_int.h"

#include <string.h>

#if defined(__GNUC__)
#define IID_INLINE static inline __attribute__((always_inline))
#else
#define IID_INLINE static inline
#endif

/* ---------------------------------------------------------------- number operations
 * The per-frame part below is written once against these: u Q1.30, x Q6.25, c Q4.27, sums in
 * block floating point, acc int64 (imu_id_q.h) in the fixed build; all float otherwise. */
#if OCTO_FIXED
#define SH_XX (2 * QF_IMUX_FRAC - QF_MSUM_FRAC) /* a product of two x values into a sum at exponent 0 */
#define SUM_LIM ((int64_t)1 << 29)              /* a term or sum this large shifts its kind first */
#define E_MAX 100                               /* exponent ceiling (2^70 frames away): beyond it terms are dropped */
#define X_ZERO 0
#define X_ONE ((imu_id_x_t)1 << QF_IMUX_FRAC)
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
/* (called: flash; the regressors' few products a frame) */
static imu_id_x_t mul_cx(imu_id_c_t c, imu_id_x_t x) { return q_sat32(est_mul_rnd(c, x, QF_IMUC_FRAC)); }
static imu_id_x_t lin2(imu_id_c_t c0, imu_id_x_t x0, imu_id_c_t c1, imu_id_x_t x1)
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
/* every exponent of set at IMU_ID_E0 (its sums zero; imu_id_int.h) */
void imu_id_restart_sums(struct imu_id *m, unsigned set)
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
 * magnitudes' product (four 16 x 16 ones on Cortex-M0, which has no long multiply), shifted by
 * s = SH_XX + e and rounded as est_mul_rnd; a term or a sum of 2^29 or more, or s outside
 * [1, 62], takes sadd_slow */
IID_INLINE void sadd_xx_in(struct imu_id *m, unsigned set, unsigned k, imu_id_sum_t *sum, imu_id_x_t a, imu_id_x_t b,
			   int e)
{
	int s = SH_XX + e;
	uint32_t ua = a < 0 ? 0u - (uint32_t)a : (uint32_t)a, ub = b < 0 ? 0u - (uint32_t)b : (uint32_t)b, r;
#if defined(__ARM_ARCH_6M__)
	uint32_t al = ua & 0xffffu, ah = ua >> 16, bl = ub & 0xffffu, bh = ub >> 16;
	uint32_t ll = al * bl, lh = al * bh, hl = ah * bl, hh = ah * bh;
	uint32_t mid = (ll >> 16) + (lh & 0xffffu) + (hl & 0xffffu);
	uint32_t hi = hh + (lh >> 16) + (hl >> 16) + (mid >> 16), lo = (mid << 16) | (ll & 0xffffu);
#else
	uint64_t p = (uint64_t)ua * ub;
	uint32_t hi = (uint32_t)(p >> 32), lo = (uint32_t)p;
#endif
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
/* the same, one copy called (flash: inlined only in the hypotheses' sums, the hottest) */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
static void
sadd_xx(struct imu_id *m, unsigned set, unsigned k, imu_id_sum_t *sum, imu_id_x_t a, imu_id_x_t b, int e)
{
	sadd_xx_in(m, set, k, sum, a, b, e);
}
#define IID_UNROLL_DELAYS /* flash: Cortex-M0 */
#define IID_UNROLL_ROTORS
#else
#define X_ZERO 0.0f
#define X_ONE 1.0f
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
static inline term_t term1(float a, int e)
{
	(void)e;
	return a;
}
void imu_id_restart_sums(struct imu_id *m, unsigned set)
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
#define sadd_xx_in sadd_xx
#if defined(__GNUC__) && !defined(__clang__)
#define IID_UNROLL_DELAYS _Pragma("GCC unroll 5")
#define IID_UNROLL_ROTORS _Pragma("GCC unroll 8")
#else
#define IID_UNROLL_DELAYS
#define IID_UNROLL_ROTORS
#endif
#endif
static inline imu_id_x_t x_add(imu_id_x_t a, imu_id_x_t b) { return add32(a, b); }
static inline imu_id_x_t x_sub(imu_id_x_t a, imu_id_x_t b) { return sub32(a, b); }

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
		IID_UNROLL_ROTORS
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

void imu_id_advance(struct imu_id *m, const imu_id_u_t u_new[IMU_ID_ROTORS], imu_id_x_t s[2][IMU_ID_LAGS])
{
	advance(m, u_new, s);
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

/* the sensitivity of the smoothed sums s (x1 or x2) to ln tau at lag l (imu_id_solve.c: sens) */
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
	sadd_xx_in(m, S_HS, k0, &b[k0], x0, z, E_OF(m, e_hs, k0));
	sadd_xx_in(m, S_HS, k0 + 1u, &b[k0 + 1u], x1, z, E_OF(m, e_hs, k0 + 1u));
	sadd_xx_in(m, S_HS, k0 + 2u, &b[k0 + 2u], x2, z, E_OF(m, e_hs, k0 + 2u));
	sadd_xx_in(m, S_HS, k0 + 3u, &b[k0 + 3u], x3, z, E_OF(m, e_hs, k0 + 3u));
	sadd_xx_in(m, S_HS, k0 + 4u, &b[k0 + 4u], z, z, E_OF(m, e_hs, k0 + 4u));
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
		IID_UNROLL_DELAYS
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
	push_meas(m, x_sub(f, m->xm.fref), x_sub(t, m->xm.tref), true);
	if (m->fok != (1u << IMU_ID_DELAYS) - 1u)
		return; /* a delay's force is not all taken frames' */
	bank_take(m, s);
	if (!m->refined && m->n_exc >= m->n_freeze && m->n_st >= 30u) {
		imu_id_refine(m);
		return;
	}
	if (m->cl_on)
		cl_add(m, s);
}
