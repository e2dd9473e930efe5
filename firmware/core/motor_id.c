/* motor_id.c - joint identification of the rotor model, the per-frame part (90 Hz path): the
 * command ring, the lag filters of every hypothesis, the least-squares, torque, noise and
 * whiteness sums; see motor_id.h. The set-up, refinement and solve are motor_id_solve.c. */
#include "motor_id.h"
#include "motor_id_q.h"
#include "est_ops.h"

#define NR MOTOR_ID_ROTORS
#define ND MOTOR_ID_DELAYS
#define NL MOTOR_ID_LAGS
#if defined(__GNUC__)
#define MID_INLINE static inline __attribute__((always_inline))
#else
#define MID_INLINE static inline
#endif

/* ---------------------------------------------------------------- number operations
 * The algorithm below is written once against these; u: Q1.30, f: Q2.29, sum: block floating
 * point (motor_id.h) in the fixed build; all float otherwise. */
#if OCTO_FIXED
/* bits to shift a product into a sum's mantissa at exponent 0: Q1.30 x Q1.30, Q1.30 x Q2.29,
 * Q2.29 x Q2.29 */
#define SH_UU (2 * QF_UNIT_FRAC - QF_MSUM_FRAC)
#define SH_UF (QF_UNIT_FRAC + QF_MOTN_FRAC - QF_MSUM_FRAC)
#define SH_FF (2 * QF_MOTN_FRAC - QF_MSUM_FRAC)
#define SUM_HI_BIT 29 /* a kind is halved when one of its sums reaches 2^29 */
#define E_MAX 100     /* exponent ceiling (2^70 frames away): beyond it terms are dropped */
#define WBIN_U ((motor_id_u_t)(0.025 * (1 << QF_UNIT_FRAC) + 0.5))
typedef uint32_t big_t;
/* a b / 2^s rounded (est_mul_rnd), called: flash, where only the sums' terms (the hottest)
 * inline it */
static int64_t mid_mul_rnd(int32_t a, int32_t b, unsigned s) { return est_mul_rnd(a, b, s); }
static inline motor_id_u_t u_of_sc(scalar_t v) { return est_shl32c(v, QF_UNIT_FRAC - QF_SC_FRAC); }
static inline motor_id_f_t f_of_sc(scalar_t v, int kexp) { return est_scale32(v, QF_MOTN_FRAC - QF_SC_FRAC - kexp); }
static inline int32_t sub32(int32_t a, int32_t b) { return q_sat32((int64_t)a - b); }
/* s + k (u - s) */
MID_INLINE motor_id_u_t u_lag(motor_id_u_t s, motor_id_u_t k, motor_id_u_t u)
{
	return q_sat32((int64_t)s + mid_mul_rnd(k, sub32(u, s), QF_UNIT_FRAC));
}
/* x2 = s (s - 2 s_c) */
MID_INLINE motor_id_u_t u_x2(motor_id_u_t s, motor_id_u_t sc)
{
	return q_sat32(mid_mul_rnd(s, q_sat32((int64_t)s - 2 * (int64_t)sc), QF_UNIT_FRAC));
}
/* the reference model's thrust k_f0 s (c1 + c0 s), normalised */
MID_INLINE motor_id_f_t f_ref(const struct motor_id *m, motor_id_u_t s)
{
	int64_t cs = mid_mul_rnd(m->c0, s, QF_UNIT_FRAC);
	motor_id_u_t g = q_sat32(mid_mul_rnd(s, q_sat32(((int64_t)1 << QF_UNIT_FRAC) - m->c0 + cs), QF_UNIT_FRAC));
	return q_sat32(mid_mul_rnd(m->kf0n, g, 2 * QF_UNIT_FRAC - QF_MOTN_FRAC));
}
/* Q2.29 x Q1.30 -> Q2.29 */
MID_INLINE motor_id_f_t f_mul_u(motor_id_f_t f, motor_id_u_t u) { return q_sat32(mid_mul_rnd(f, u, QF_UNIT_FRAC)); }
#define SUM_LIM ((int64_t)1 << SUM_HI_BIT)
typedef int64_t term_t;
/* a product rounded to a sum's mantissa at exponent e (sh: SH_*) */
MID_INLINE term_t term(int32_t a, int32_t b, int sh, motor_id_e_t e)
{
	int s = sh + (int)e;
	if (s >= 1 && s <= 62)
		return est_mul_rnd(a, b, (unsigned)s);
	return q_scale64(q_smul32(a, b), -s); /* beyond: left shifts (saturating) or 0 */
}
static inline motor_id_sum_t sum_half(motor_id_sum_t v) { return (motor_id_sum_t)q_shr64(v, 1); }
static inline bool big_over(big_t b) { return (b >> SUM_HI_BIT) != 0u; }
static void sums_halve(struct motor_id *m, unsigned mask);
static inline bool sum_big(int64_t v) { return v >= SUM_LIM || v <= -SUM_LIM; }
/* a term or a sum of 2^29 or more (a sum that takes several terms a frame): the kind is
 * halved (its exponent raised) until both are below */
static void sum_fit(struct motor_id *m, unsigned k, const motor_id_sum_t *s, term_t *t, big_t *big)
{
	while (sum_big(*t) || sum_big(*s)) {
		if (m->e[k] >= E_MAX) { /* unreachable: 2^70 frames of the largest terms */
			*t = 0;
			return;
		}
		sums_halve(m, 1u << k);
		*t = q_shr64(*t, 1);
	}
	*big = 0; /* every sum of the kind is below 2^29 now */
}
/* *s + t for a sum of kind k, noting its size in *big: a sum and a term below 2^29 in
 * magnitude cannot wrap */
MID_INLINE void sum_add(struct motor_id *m, unsigned k, motor_id_sum_t *s, term_t t, big_t *big)
{
	if (sum_big(t) || sum_big(*s))
		sum_fit(m, k, s, &t, big);
	*s += (motor_id_sum_t)t;
	*big |= (big_t)(*s < 0 ? -*s : *s);
}
#define MID_UNROLL_SUMS
#else
typedef int big_t;
#define WBIN_U 0.025f
#if defined(__GNUC__) && !defined(__clang__)
#define MID_UNROLL_SUMS _Pragma("GCC unroll 6")
#else
#define MID_UNROLL_SUMS
#endif
static inline motor_id_u_t u_of_sc(scalar_t v) { return sc_to_float(v); }
static inline motor_id_f_t f_of_sc(scalar_t v, int kexp)
{
	(void)kexp;
	return sc_to_float(v);
}
static inline float sub32(float a, float b) { return a - b; }
static inline motor_id_u_t u_lag(motor_id_u_t s, motor_id_u_t k, motor_id_u_t u) { return s + k * (u - s); }
static inline motor_id_u_t u_x2(motor_id_u_t s, motor_id_u_t sc) { return s * (s - 2.0f * sc); }
static inline motor_id_f_t f_ref(const struct motor_id *m, motor_id_u_t s)
{
	return m->kf0n * s * ((1.0f - m->c0) + m->c0 * s);
}
static inline motor_id_f_t f_mul_u(motor_id_f_t f, motor_id_u_t u) { return f * u; }
#define SH_UU 0
#define SH_UF 0
#define SH_FF 0
typedef float term_t;
static inline term_t term(float a, float b, int sh, motor_id_e_t e)
{
	(void)sh;
	(void)e;
	return a * b;
}
static inline void sum_add(struct motor_id *m, unsigned k, motor_id_sum_t *s, term_t t, big_t *big)
{
	(void)m;
	(void)k;
	(void)big;
	*s += t;
}
static inline bool big_over(big_t b)
{
	(void)b;
	return false;
}
#endif

/* Halves every sum of the kinds in mask (bits MID_E_*) and raises their exponents: the
 * fixed build's block floating point keeps each below 2^29 (see motor_id.h) */
static void sums_halve(struct motor_id *m, unsigned mask)
{
#if OCTO_FIXED
	if (mask & 0x3fu) {
		struct motor_id_stat *st = &m->st[0][0][0];
		for (unsigned n = 0; n < ND * NL * NR; n++) {
			if (mask & (1u << MID_E_G11))
				st[n].g11 = sum_half(st[n].g11);
			if (mask & (1u << MID_E_G12))
				st[n].g12 = sum_half(st[n].g12);
			if (mask & (1u << MID_E_G22))
				st[n].g22 = sum_half(st[n].g22);
			if (mask & (1u << MID_E_B1))
				st[n].b1 = sum_half(st[n].b1);
			if (mask & (1u << MID_E_B2))
				st[n].b2 = sum_half(st[n].b2);
			if (mask & (1u << MID_E_RR))
				st[n].rr = sum_half(st[n].rr);
		}
	}
	if (mask & (1u << MID_E_FF))
		m->ff = sum_half(m->ff);
	if (mask & (1u << MID_E_TF))
		m->tf = sum_half(m->tf);
	if (mask & (1u << MID_E_TT))
		m->tt = sum_half(m->tt);
	if (mask & (1u << MID_E_NZ))
		m->nz_ss = sum_half(m->nz_ss);
	struct motor_id_white *w = &m->wh;
	for (unsigned j = 0; j < NR; j++)
		for (unsigned b = 0; b < MOTOR_ID_WBINS; b++) {
			if (mask & (1u << MID_E_WSE))
				w->se[j][b] = sum_half(w->se[j][b]);
			if (mask & (1u << MID_E_WSEE)) {
				w->see[j][b] = sum_half(w->see[j][b]);
				for (unsigned l = 0; l < MOTOR_ID_WLAGS; l++)
					w->sl[j][b][l] = sum_half(w->sl[j][b][l]);
			}
		}
	for (unsigned k = 0; k < MID_E_N; k++)
		if ((mask & (1u << k)) && m->e[k] < E_MAX)
			m->e[k]++;
#else
	(void)m;
	(void)mask;
#endif
}

/* The bank's six sums of a rotor (struct motor_id_stat's members, in the order of their
 * exponents MID_E_G11..MID_E_RR) are the products a[k] b[k] of its regressors x1, x2 and
 * residual r; u and f values share one type in each build */
typedef motor_id_u_t opnd_t;
_Static_assert(sizeof(motor_id_u_t) == sizeof(motor_id_f_t), "motor_id_u_t and motor_id_f_t are one type");
_Static_assert(sizeof(struct motor_id_stat) == 6 * sizeof(motor_id_sum_t) && MID_E_RR - MID_E_G11 == 5,
	       "struct motor_id_stat: six sums in the order of their exponents");
static const int bank_sh[6] = {SH_UU, SH_UU, SH_UU, SH_UF, SH_UF, SH_FF};
/* the factors of rotor j's six terms at lag state s and normalised thrust fm */
MID_INLINE void bank_factors(const struct motor_id *m, motor_id_u_t s, unsigned j, motor_id_f_t fm, opnd_t a[6],
			     opnd_t b[6])
{
	motor_id_u_t x2 = u_x2(s, m->s_c[j]);
	motor_id_f_t r = sub32(fm, f_ref(m, s));
	a[0] = a[1] = a[3] = b[0] = s;
	a[2] = a[4] = b[1] = b[2] = x2;
	a[5] = b[3] = b[4] = b[5] = r;
}
/* the six sums of a struct motor_id_stat as an array (its members, without padding) */
static inline motor_id_sum_t *stat_sums(struct motor_id_stat *st) { return (motor_id_sum_t *)(void *)st; }

/* The bank's exponents at a restart (every sum zero), from the first hypothesis' terms of
 * this frame: below 2^27 there, so that the first frame does not halve the 120 sums of each
 * kind many times over (the other hypotheses' terms are alike; a larger one halves as usual) */
static void bank_exponents(struct motor_id *m, const motor_id_f_t fm[NR])
{
#if OCTO_FIXED
	int bits[6] = {0, 0, 0, 0, 0, 0};
	const motor_id_u_t *s = m->s[0][0];
	for (unsigned j = 0; j < NR; j++) {
		opnd_t a[6], b[6];
		bank_factors(m, s[j], j, fm[j], a, b);
		for (unsigned k = 0; k < 6; k++) {
			int64_t t = term(a[k], b[k], bank_sh[k], MOTOR_ID_E0);
			int nb = 64 - q_clz64((uint64_t)(t < 0 ? -t : t));
			if (nb > bits[k])
				bits[k] = nb;
		}
	}
	for (unsigned k = 0; k < 6; k++)
		m->e[MID_E_G11 + k] = (motor_id_e_t)(MOTOR_ID_E0 + (bits[k] > 27 ? bits[k] - 27 : 0));
#else
	(void)m;
	(void)fm;
#endif
}

/* the mask of kinds whose largest sum grew past the limit (big[k]: their sizes) */
static unsigned over_mask(const big_t *big, unsigned k0, unsigned n)
{
	unsigned mask = 0;
	for (unsigned k = 0; k < n; k++)
		if (big_over(big[k]))
			mask |= 1u << (k0 + k);
	return mask;
}

/* the commands of the next frame into the ring's next slot (the oldest, which the next
 * advance no longer reads) */
static void push(struct motor_id *m, const scalar_t thr_prev[NR])
{
	motor_id_u_t *h = m->hist[(m->head + 1u) % ND];
	for (unsigned j = 0; j < NR; j++)
		h[j] = u_of_sc(thr_prev[j]);
}

/* every filter one frame on, with the commands push left in the next slot */
static void advance(struct motor_id *m)
{
	m->head = (uint8_t)((m->head + 1u) % ND);
	for (unsigned d = 0; d < ND; d++) {
		const motor_id_u_t *u = m->hist[(m->head + ND - d) % ND];
		for (unsigned i = 0; i < NL; i++) {
			motor_id_u_t k = m->k1[d][i], *s = m->s[d][i];
			for (unsigned j = 0; j < NR; j++)
				s[j] = u_lag(s[j], k, u[j]);
		}
	}
	if (m->wh.on) { /* the whiteness model's own lag */
		const motor_id_u_t *u = m->hist[(m->head + ND - m->wh.delay) % ND];
		for (unsigned j = 0; j < NR; j++)
			m->wh.s[j] = u_lag(m->wh.s[j], m->wh.k1, u[j]);
	}
}

void motor_id_hold(struct motor_id *m, const scalar_t thr_prev[NR])
{
	motor_id_process(m);
	push(m, thr_prev);
	advance(m);
	m->nz_have = false;
	m->wh.run = 0; /* no prediction error across a lost frame */
}

void motor_id_step(struct motor_id *m, const scalar_t thr_prev[NR], const scalar_t f[NR], const scalar_t tq[NR],
		   bool excited)
{
	motor_id_process(m); /* the previous frame's, if nobody did it between frames */
	push(m, thr_prev);
	/* thrust noise from first differences of still frames (slow control motion cancels),
	 * taken here while the previous frame's thrust is still in q_f (only in the settling
	 * second: excited steps just copy the frame) */
	if (!excited && m->nz_have) {
		big_t big = 0;
		for (unsigned j = 0; j < NR; j++) {
			motor_id_f_t dd = sub32(f_of_sc(f[j], m->kexp), f_of_sc(m->q_f[j], m->kexp));
			sum_add(m, MID_E_NZ, &m->nz_ss, term(dd, dd, SH_FF, m->e[MID_E_NZ]), &big);
			m->nz_n += 2u;
		}
		sums_halve(m, over_mask(&big, MID_E_NZ, 1));
	}
	for (unsigned j = 0; j < NR; j++) {
		m->q_f[j] = f[j];
		m->q_tq[j] = tq[j];
	}
	m->nz_have = !excited;
	m->q_excited = excited;
	m->q_pending = true;
}

void motor_id_white_pause(struct motor_id *m, uint16_t frames)
{
	if (frames > m->white_pause)
		m->white_pause = frames;
}

/* the frozen model's one-step prediction error of every rotor at this frame, into the
 * whiteness sums (its level, lagged products with the ring) */
static void white_update(struct motor_id *m, const motor_id_f_t fm[NR])
{
	struct motor_id_white *w = &m->wh;
	if (!w->on)
		return;
	if (m->white_pause > 0u) {
		m->white_pause--;
		w->run = 0;
		return;
	}
	const motor_id_u_t *s = w->s;
	big_t big[2] = {0, 0};
	for (unsigned j = 0; j < NR; j++) {
		motor_id_u_t x1 = s[j], x2 = u_x2(s[j], m->s_c[j]);
		motor_id_f_t e =
			sub32(sub32(sub32(fm[j], f_ref(m, s[j])), f_mul_u(w->dl[j][0], x1)), f_mul_u(w->dl[j][1], x2));
		motor_id_u_t ds = sub32(s[j], m->s_c[j]);
		unsigned b = ds < -WBIN_U ? 0u : (ds > WBIN_U ? 2u : 1u);
		if (w->n[j][b] < UINT16_MAX) { /* a full series keeps what it has */
			w->n[j][b]++;
#if OCTO_FIXED
			sum_add(m, MID_E_WSE, &w->se[j][b], q_scale64(e, QF_MSUM_FRAC - QF_MOTN_FRAC - m->e[MID_E_WSE]),
				&big[0]);
#else
			sum_add(m, MID_E_WSE, &w->se[j][b], e, &big[0]);
#endif
			sum_add(m, MID_E_WSEE, &w->see[j][b], term(e, e, SH_FF, m->e[MID_E_WSEE]), &big[1]);
			for (unsigned l = 0; l < MOTOR_ID_WLAGS; l++)
				if (l < w->run)
					sum_add(m, MID_E_WSEE, &w->sl[j][b][l],
						term(e, w->ring[l][j], SH_FF, m->e[MID_E_WSEE]), &big[1]);
		}
		for (unsigned l = MOTOR_ID_WLAGS - 1u; l > 0u; l--)
			w->ring[l][j] = w->ring[l - 1u][j];
		w->ring[0][j] = e;
	}
	if (w->run < MOTOR_ID_WLAGS)
		w->run++;
	sums_halve(m, over_mask(big, MID_E_WSE, 2));
}

void motor_id_process(struct motor_id *m)
{
	if (!m->q_pending)
		return;
	m->q_pending = false;
	if (m->refine_due || m->white_due || m->reref_due)
		motor_id_refine(m);
	advance(m);
	if (!m->q_excited)
		return;
	motor_id_f_t fm[NR];
	big_t bt[3] = {0, 0, 0};
	for (unsigned j = 0; j < NR; j++) {
		fm[j] = f_of_sc(m->q_f[j], m->kexp);
		motor_id_f_t t = f_of_sc(m->q_tq[j], m->kexp);
		sum_add(m, MID_E_FF, &m->ff, term(fm[j], fm[j], SH_FF, m->e[MID_E_FF]), &bt[0]);
		sum_add(m, MID_E_TF, &m->tf, term(t, fm[j], SH_FF, m->e[MID_E_TF]), &bt[1]);
		sum_add(m, MID_E_TT, &m->tt, term(t, t, SH_FF, m->e[MID_E_TT]), &bt[2]);
	}
	sums_halve(m, over_mask(bt, MID_E_FF, 3));
	m->n_exc++;
	if (m->skip > 0u) {
		m->skip--;
	} else {
		if (m->n_stat == 0u)
			bank_exponents(m, fm);
		const motor_id_e_t *e = m->e;
		big_t big[6] = {0, 0, 0, 0, 0, 0};
		for (unsigned d = 0; d < ND; d++)
			for (unsigned i = 0; i < NL; i++) {
				const motor_id_u_t *s = m->s[d][i];
				struct motor_id_stat *st = m->st[d][i];
				for (unsigned j = 0; j < NR; j++) {
					opnd_t a[6], b[6];
					bank_factors(m, s[j], j, fm[j], a, b);
					motor_id_sum_t *v = stat_sums(&st[j]);
					/* one copy of the term and the sum for the six kinds in the fixed
					 * build (flash); unrolled in float, where a term is one product */
					MID_UNROLL_SUMS
					for (unsigned k = 0; k < 6; k++)
						sum_add(m, MID_E_G11 + k, &v[k],
							term(a[k], b[k], bank_sh[k], e[MID_E_G11 + k]), &big[k]);
				}
			}
		sums_halve(m, over_mask(big, MID_E_G11, 6));
		m->n_stat++;
		white_update(m, fm);
	}
	/* the first stage's re-referencing, the stage's end, or in the last stage the whiteness
	 * model's freezing: between frames */
	if (m->stage == 0 && !m->reref_done && m->n_stat >= MOTOR_ID_NREF)
		m->reref_due = true;
	if (m->n_exc >= m->n_next) {
		if (m->stage < MOTOR_ID_STAGES - 1)
			m->refine_due = true;
		else if (!m->wh.on && m->n_stat >= 30u)
			m->white_due = true;
	}
}
