/* rls.c - Bierman UD recursive least squares, the update (90 Hz path); see rls.h.
 * Configuration and the float getters are rls_setup.c. */
#include "rls.h"
#include "qfmt.h"
#include "est_ops.h"

/* The fixed build inlines bierman() below at both of its calls so that the one with n = 1 is
 * specialised (its 64-bit arithmetic is the step's cost); the float build, where flash is
 * what is short on Cortex-M0, keeps one copy with n as a variable */
#if OCTO_FIXED && defined(__GNUC__)
#define RLS_INLINE static inline __attribute__((always_inline))
#elif OCTO_FIXED
#define RLS_INLINE static inline
#elif defined(__GNUC__)
#define RLS_INLINE static __attribute__((noinline))
#else
#define RLS_INLINE static
#endif

/* ---------------------------------------------------------------- number operations
 * The algorithm below is written once against these; names say the formats:
 * sig Q7.24, unit Q1.30, acc Q23.40, wide Q1.62 (fixed build; all float otherwise). */
#if OCTO_FIXED
#define SIG_ZERO 0
#define ACC_ZERO 0
#define WIDE_ZERO 0
#define INN_ZERO 0
#define UNIT_SIG ((rls_sig_t)1 << QF_SIG_FRAC)
#define UNIT_ONE ((rls_unit_t)(1 << QF_UNIT_FRAC))
#define WIDE_HALF ((rls_wide_t)1 << (QF_WIDE_FRAC - 1))
#define WIDE_ONE ((rls_wide_t)1 << QF_WIDE_FRAC)
/* Q7.24 * Q7.24 -> Q7.24 */
static inline rls_sig_t sig_mul(rls_sig_t a, rls_sig_t b) { return q_mul32(a, b, QF_SIG_FRAC); }
/* Q1.62 * Q7.24 -> Q23.40 */
static inline rls_acc_t acc_of_wide_sig(rls_wide_t d, rls_sig_t b)
{
	return q_mul64_32(d, b, QF_WIDE_FRAC + QF_SIG_FRAC - QF_ACC_FRAC);
}
static inline rls_acc_t acc_add(rls_acc_t a, rls_acc_t b) { return q_add64(a, b); }
static inline rls_acc_t acc_sub(rls_acc_t a, rls_acc_t b) { return q_add64(a, -b); }
/* a 2^e (left shifts saturate) */
static inline rls_acc_t acc_ldexp(rls_acc_t a, int32_t e) { return est_scale64(a, (int)e); }
/* a 2^(2 s): a covariance bound of a parameter with phi_shift s */
static inline rls_acc_t acc_pow4(rls_acc_t a, int s) { return est_scale64(a, 2 * s); }
/* Q1.30 -> Q23.40 */
static inline rls_acc_t acc_of_unit(rls_unit_t m) { return (rls_acc_t)m * (1 << (QF_ACC_FRAC - QF_UNIT_FRAC)); }
static inline rls_acc_t acc_of_wide(rls_wide_t d) { return q_shr64(d, QF_WIDE_FRAC - QF_ACC_FRAC); }
static inline rls_wide_t wide_of_acc(rls_acc_t a) { return q_shl64(a, QF_WIDE_FRAC - QF_ACC_FRAC); }
static inline rls_wide_t wide_add(rls_wide_t a, rls_wide_t b) { return q_add64(a, b); }
/* a / b in Q1.30 (0 <= a, 0 < b; saturates at 2) */
static inline rls_unit_t unit_ratio(rls_acc_t a, rls_acc_t b) { return q30_ratio(a, b); }
/* d a / b = result 2^-*sh (0 < a <= 2 b, 0 < b): no bits lost however small a / b */
/* d 2^e (e <= 0 here: rounds) */
/* (e = 0, the common case, and every case of one parameter: d itself, as est_scale64 gives it
 * for any d but INT64_MIN, which no mantissa is) */
static inline rls_wide_t wide_ldexp(rls_wide_t d, int e) { return e ? est_scale64(d, e) : d; }
/* d 4^s (s <= 0 for the parameters in use: rounds) */
static inline rls_wide_t wide_pow4(rls_wide_t d, int s) { return est_scale64(d, 2 * s); }
/* x + a c / b in Q15.48 (x Q15.48, c Q7.24; a, b Q9.54, b > 0): the gain a / b as r 2^-sh */
/* Q15.48 * Q7.24 -> Q7.24 */
/* the reciprocal of an innovation (y 2^-e) and gains b / alpha as r 2^-sh (qfmt.h); the
 * reciprocal packed in one word, y in the low half, e (in [0, 94]) in the high half, so that
 * it is copied and selected in registers (an 8-byte struct is copied by memcpy at -Os) */
typedef uint64_t rls_rcp_t;
typedef struct {
	int32_t r;
	int sh;
} rls_gain_t;
#define RCP_NONE ((rls_rcp_t)0)
static inline uint32_t rcp_y(rls_rcp_t c) { return (uint32_t)c; }
static inline int rcp_e(rls_rcp_t c) { return (int)(uint32_t)(c >> 32); }
static inline rls_rcp_t rcp_of(rls_inn_t a)
{
	int e;
	uint32_t y = est_recip(a, &e);
	return ((uint64_t)(uint32_t)e << 32) | y;
}
static inline rls_gain_t gain_of(rls_inn_t a, rls_rcp_t c)
{
	rls_gain_t g;
	g.r = est30_mul_recip(a, rcp_y(c), rcp_e(c), &g.sh);
	return g;
}
/* x + g c: Q15.48 + gain * Q7.24 */
static inline rls_par_t par_add_g(rls_par_t x, rls_gain_t g, rls_sig_t c)
{
	return q_add64(x, est_scale64(q_smul32(c, g.r), QF_PAR_FRAC - QF_SIG_FRAC - QF_UNIT_FRAC - g.sh));
}
/* U_ij - f_j b_i / a_(j-1) in Q7.24 */
static inline rls_sig_t u_update(rls_sig_t uij, rls_inn_t b, rls_sig_t f, rls_rcp_t c)
{
	rls_gain_t g = gain_of(b, c);
	return q_sat32((int64_t)uij - est_scale64(q_smul32(f, g.r), -(QF_UNIT_FRAC + g.sh)));
}
/* gain_of(2^k, c) for k in [0, 62]: the mantissa of 2^k is 2^31, so the gain's is y / 2
 * rounded, (y + 1) / 2 (at most 2^30), and its shift 63 - k + e - 94; a zero reciprocal
 * gives 0 (shift 0), as gain_of */
static inline rls_gain_t gain_of_pow2(int k, rls_rcp_t c)
{
	rls_gain_t g = {0, 0};
	if (rcp_y(c) != 0u) {
		g.r = (int32_t)((rcp_y(c) + 1u) >> 1);
		g.sh = 63 - k + rcp_e(c) - 94;
	}
	return g;
}
/* d a_prev / (a lambda) = result 2^-*sh, with the reciprocal c of a (lambda = 1: no other);
 * k_prev >= 0: a_prev is 2^k_prev (the first innovation with lambda = 1) */
static inline rls_wide_t wide_scale_ratio(rls_wide_t d, rls_inn_t a_prev, rls_inn_t a, rls_rcp_t c, rls_unit_t lambda,
					  int k_prev, int *sh)
{
	rls_gain_t g;
	if (lambda == UNIT_ONE && k_prev >= 0)
		g = gain_of_pow2(k_prev, c);
	else
		g = gain_of(a_prev, lambda == UNIT_ONE ? c : rcp_of(q_mul64_q30(a, lambda)));
	*sh = g.sh;
	return q_mul64_q30(d, g.r);
}
/* the residual term e^2 / (a 2^fr / lambda) in Q23.40 */
static inline rls_acc_t acc_res(rls_sig_t e, rls_inn_t a, rls_rcp_t c, rls_unit_t lambda, int fr)
{
	(void)a;
	rls_gain_t g = gain_of(q_smul32(e, e), c); /* E^2 / A = r 2^-30 2^-sh (integers) */
	/* (E^2 2^-48) / (A 2^-54 2^-fr) in Q40: r 2^(16 - sh + fr) */
	rls_acc_t t = est_scale64(g.r, 16 - g.sh + fr);
	return lambda == UNIT_ONE ? t : q_mul64_q30(t, lambda);
}
/* a lambda (skipped for lambda = 1) */
static inline rls_acc_t acc_forget(rls_acc_t a, rls_unit_t lambda)
{
	return lambda == UNIT_ONE ? a : q_mul64_q30(a, lambda);
}
/* dot products accumulate in Q15.48 (int64) and round once */
typedef int64_t rls_dot_t;
#define DOT_ZERO 0
static inline rls_dot_t dot_of_sig(rls_sig_t x) { return (rls_dot_t)x * ((int64_t)1 << QF_SIG_FRAC); }
static inline rls_dot_t dot_mac(rls_dot_t s, rls_sig_t a, rls_sig_t b) { return q_add64(s, (int64_t)a * b); }
static inline rls_dot_t dot_mac_par(rls_dot_t s, rls_par_t t, rls_sig_t x)
{
	return q_add64(s, est_mul64_32c(t, x, QF_PAR_FRAC + QF_SIG_FRAC - 2 * QF_SIG_FRAC));
}
/* dot_mac_par(DOT_ZERO, t, x): the product alone (it is never INT64_MIN, which the add
 * would have turned into -INT64_MAX) */
static inline rls_dot_t dot_of_par(rls_par_t t, rls_sig_t x)
{
	return est_mul64_32c(t, x, QF_PAR_FRAC + QF_SIG_FRAC - 2 * QF_SIG_FRAC);
}
static inline rls_dot_t dot_sub(rls_dot_t a, rls_dot_t b) { return q_add64(a, -b); }
static inline rls_sig_t sig_of_dot(rls_dot_t s) { return est_sat_shr64c(s, QF_SIG_FRAC); }
/* x + a c / b in Q7.24 (x, c Q7.24; a, b Q9.54, b > 0): the gain a / b as r 2^-sh */
/* the same; in the float build, x + a (c / b) */
/* a b / c in Q23.40 (a, b Q7.24, c Q23.40 > 0) */
/* Q1.62 * Q7.24 / 2^s -> Q9.54 */
static inline rls_inn_t inn_of_wide_sig(rls_wide_t d, rls_sig_t f, int s)
{
	return est_mul64_32(d, f, (unsigned)(QF_WIDE_FRAC + QF_SIG_FRAC - QF_INN_FRAC + s));
}
/* Q9.54 * Q7.24 -> Q9.54 */
static inline rls_inn_t inn_mul_sig(rls_inn_t a, rls_sig_t b) { return est_mul64_32c(a, b, QF_SIG_FRAC); }
static inline rls_inn_t inn_add(rls_inn_t a, rls_inn_t b) { return q_add64(a, b); }
/* Q1.30 2^e -> Q9.54 (e <= 0) */
static inline rls_inn_t inn_of_unit(rls_unit_t m, int e)
{
	return est_scale64((int64_t)m << (QF_INN_FRAC - QF_UNIT_FRAC), e);
}
/* inn_of_unit(UNIT_ONE, e) is 2^INN_POW2(e) (e >= RLS_EXP_MIN > -QF_INN_FRAC: exact) */
#define INN_POW2(e) (QF_INN_FRAC + (e))
static inline bool wide_ok(rls_wide_t d) { return d > 0; }
static inline bool sig_ok(rls_sig_t x)
{
	(void)x;
	return true;
}
static inline bool acc_ok(rls_acc_t x)
{
	(void)x;
	return true;
}
/* (a left shift, the common case, inlined: est_shl32c is est_scale32 for shifts in [0, 30]) */
static inline rls_sig_t sig_of_sc(scalar_t x, int shift)
{
	int s = QF_SIG_FRAC - QF_SC_FRAC - shift;
	return s >= 0 && s <= 30 ? est_shl32c(x, (unsigned)s) : est_scale32(x, s);
}
static inline rls_acc_t phi2_of_sc(scalar_t x) { return q_smul32(x, x); } /* Q32 */
/* |phi|^2 is needed for the gate only (|phi|^2 >= 0 passes a zero phi_min) */
static inline bool phi2_needed(const struct rls *r) { return r->phi_min2 > 0; }
#else
#define SIG_ZERO 0.0f
#define ACC_ZERO 0.0f
#define WIDE_ZERO 0.0f
#define INN_ZERO 0.0f
#define UNIT_SIG 1.0f
#define UNIT_ONE 1.0f
static inline rls_sig_t sig_mul(rls_sig_t a, rls_sig_t b) { return a * b; }
static inline rls_acc_t acc_of_wide_sig(rls_wide_t d, rls_sig_t b) { return d * b; }
static inline rls_acc_t acc_add(rls_acc_t a, rls_acc_t b) { return a + b; }
static inline rls_acc_t acc_sub(rls_acc_t a, rls_acc_t b) { return a - b; }
static inline rls_acc_t acc_ldexp(rls_acc_t a, int32_t e)
{
	(void)e;
	return a;
} /* e is 0 */
static inline rls_acc_t acc_pow4(rls_acc_t a, int s) { return s ? a * sc_pow2f(2 * s) : a; }
static inline rls_acc_t acc_of_unit(rls_unit_t m) { return m; }
static inline rls_acc_t acc_of_wide(rls_wide_t d) { return d; }
static inline rls_wide_t wide_of_acc(rls_acc_t a) { return a; }
static inline rls_wide_t wide_add(rls_wide_t a, rls_wide_t b) { return a + b; }
static inline rls_unit_t unit_ratio(rls_acc_t a, rls_acc_t b) { return a / b; }
static inline rls_wide_t wide_ldexp(rls_wide_t d, int e)
{
	(void)e;
	return d;
} /* e is 0 */
static inline rls_wide_t wide_pow4(rls_wide_t d, int s) { return d * sc_pow2f(2 * s); } /* exact */
typedef float rls_rcp_t;
typedef float rls_gain_t;
#define RCP_NONE 1.0f
static inline rls_rcp_t rcp_of(rls_inn_t a) { return a; }
static inline rls_gain_t gain_of(rls_inn_t a, rls_rcp_t c) { return a / c; }
static inline rls_par_t par_add_g(rls_par_t x, rls_gain_t g, rls_sig_t c) { return x + g * c; }
static inline rls_sig_t u_update(rls_sig_t uij, rls_inn_t b, rls_sig_t f, rls_rcp_t c) { return uij + b * (-f / c); }
static inline rls_wide_t wide_scale_ratio(rls_wide_t d, rls_inn_t a_prev, rls_inn_t a, rls_rcp_t c, rls_unit_t lambda,
					  int k_prev, int *sh)
{
	(void)c;
	(void)k_prev;
	*sh = 0;
	return d * a_prev / (a * lambda);
}
static inline rls_acc_t acc_res(rls_sig_t e, rls_inn_t a, rls_rcp_t c, rls_unit_t lambda, int fr)
{
	(void)c;
	(void)fr;
	return e * e / (a / lambda);
}
static inline rls_acc_t acc_forget(rls_acc_t a, rls_unit_t lambda) { return a * lambda; }
typedef float rls_dot_t;
#define DOT_ZERO 0.0f
static inline rls_dot_t dot_of_sig(rls_sig_t x) { return x; }
static inline rls_dot_t dot_mac(rls_dot_t s, rls_sig_t a, rls_sig_t b) { return s + a * b; }
static inline rls_dot_t dot_mac_par(rls_dot_t s, rls_par_t t, rls_sig_t x) { return s + x * t; }
static inline rls_dot_t dot_of_par(rls_par_t t, rls_sig_t x) { return DOT_ZERO + x * t; }
static inline rls_dot_t dot_sub(rls_dot_t a, rls_dot_t b) { return a - b; }
static inline rls_sig_t sig_of_dot(rls_dot_t s) { return s; }
/* x + (a / b) c: the float build's order of operations */
/* x + a (c / b) */
static inline rls_inn_t inn_of_wide_sig(rls_wide_t d, rls_sig_t f, int s)
{
	(void)s;
	return d * f;
}
static inline rls_inn_t inn_mul_sig(rls_inn_t a, rls_sig_t b) { return a * b; }
static inline rls_inn_t inn_add(rls_inn_t a, rls_inn_t b) { return a + b; }
static inline rls_inn_t inn_of_unit(rls_unit_t m, int e)
{
	(void)e;
	return m;
}
#define INN_POW2(e) (e)
static inline bool wide_ok(rls_wide_t d) { return d > 0.0f && isfinite(d); }
static inline bool sig_ok(rls_sig_t x) { return isfinite(x); }
static inline bool acc_ok(rls_acc_t x) { return isfinite(x); }
static inline rls_sig_t sig_of_sc(scalar_t x, int shift) { return shift ? x * sc_pow2f(-shift) : x; }
static inline rls_acc_t phi2_of_sc(scalar_t x) { return x * x; }
/* also for the overflow check below */
static inline bool phi2_needed(const struct rls *r)
{
	(void)r;
	return true;
}
#endif

/* ---------------------------------------------------------------- the update */

/* P_n_ii 2^d_exp = sum_{k >= i} U_ik^2 d_k */
static rls_acc_t pdiag_m(const struct rls *r, unsigned i)
{
	rls_acc_t s = acc_of_wide(r->d[i]);
	for (unsigned k = i + 1; k < r->cfg.n_params; k++)
		s = acc_add(s, acc_of_wide_sig(r->d[k], sig_mul(r->u[RLS_U_IDX(i, k)], r->u[RLS_U_IDX(i, k)])));
	return s;
}

/* Mantissas back to [0.5, 1) for the largest (fixed build; the float build keeps d_exp 0) */
static void renormalise(struct rls *r, unsigned n)
{
#if OCTO_FIXED
	rls_wide_t mx = 0;
	for (unsigned i = 0; i < n; i++)
		mx = r->d[i] > mx ? r->d[i] : mx;
	if (mx <= 0)
		return;
	int s = 0;
	while (mx < WIDE_HALF && r->d_exp + s < RLS_EXP_MAX) {
		mx <<= 1;
		s++;
	}
	while (mx >= WIDE_ONE && r->d_exp + s > RLS_EXP_MIN) {
		mx >>= 1;
		s--;
	}
	if (s == 0)
		return;
	for (unsigned i = 0; i < n; i++)
		r->d[i] = est_scale64(r->d[i], s);
	r->d_exp = (int8_t)(r->d_exp + s);
#else
	(void)r;
	(void)n;
#endif
}

/* P = p0 I in the normalised units (the mantissa and exponent rls_init computed): D0_n_i =
 * d0 4^(phi_shift_i - m), m the largest phi_shift of the parameters (d0 is that one's) */
void rls_reset_covariance(struct rls *r)
{
	int m = r->cfg.phi_shift[0];
	for (unsigned i = 1; i < r->cfg.n_params; i++)
		m = r->cfg.phi_shift[i] > m ? r->cfg.phi_shift[i] : m;
	for (unsigned i = 0; i < RLS_MAX_PARAMS; i++)
		r->d[i] = wide_pow4(r->d0, r->cfg.phi_shift[i] - m);
	for (unsigned k = 0; k < RLS_U_N; k++)
		r->u[k] = SIG_ZERO;
	r->d_exp = r->d0_exp;
}

rls_acc_t rls_cov_diag_n(const struct rls *r, unsigned param)
{
	return param < r->cfg.n_params ? pdiag_m(r, param) : ACC_ZERO;
}

/* One Bierman step of n = cfg.n_params parameters with the effective forgetting lambda.
 * With sigma = 2^-d_exp, D = sigma d: f = U^T phi, v = d f (= D f / sigma), and the
 * innovations alpha_j = lambda + sum_{k <= j} f_k D_k f_k are carried as a_j = alpha_j / sigma,
 * in which sigma cancels from the gain and the U update; only the new d_j = d_j
 * a_(j-1) / (a_j lambda) and the residual need alpha itself. On a numerical failure the
 * estimate is kept and the covariance reset. */
RLS_INLINE enum rls_result bierman(struct rls *r, const rls_sig_t *phi, const rls_sig_t *y, rls_unit_t lambda,
				   unsigned n)
{
	const unsigned no = r->cfg.n_outputs;
	rls_sig_t f[RLS_MAX_PARAMS], u[RLS_MAX_PARAMS][RLS_MAX_PARAMS];
	rls_inn_t v[RLS_MAX_PARAMS], b[RLS_MAX_PARAMS];
	rls_wide_t d[RLS_MAX_PARAMS];
	/* the frame of v, b and the innovation: D 2^-fr, fr = min(d_exp, 0), so that v = D f
	 * keeps its bits when P is small and stays within |2 f| when P is large */
	const int fr = r->d_exp < 0 ? (int)r->d_exp : 0;
	for (unsigned j = 0; j < n; j++) {
		rls_dot_t sd = DOT_ZERO;
		for (unsigned i = 0; i < j; i++)
			sd = dot_mac(sd, r->u[RLS_U_IDX(i, j)], phi[i]);
		/* U_jj = 1 (f_0 = phi_0: the round trip through the dot format is exact) */
		rls_sig_t s = j ? sig_of_dot(dot_mac(sd, phi[j], UNIT_SIG)) : phi[j];
		f[j] = s;
		v[j] = inn_of_wide_sig(r->d[j], s, (int)r->d_exp - fr);
		for (unsigned i = 0; i < j; i++) /* the strict upper part: all that is read */
			u[i][j] = r->u[RLS_U_IDX(i, j)];
	}
	rls_inn_t alpha = inn_of_unit(lambda, fr);
	bool ok = true;
	int sh[RLS_MAX_PARAMS], sh_min = 64;
	/* the reciprocal of each innovation, once (the fixed build multiplies by it) */
	rls_rcp_t rc = RCP_NONE, rc_prev;
	for (unsigned j = 0; j < n; j++) {
		rls_inn_t alpha_prev = alpha;
		rc_prev = rc;
		alpha = inn_add(alpha_prev, inn_mul_sig(v[j], f[j]));
		rc = rcp_of(alpha);
		/* d_j a_(j-1) / (a_j lambda) = d[j] 2^-sh[j] */
		d[j] = wide_scale_ratio(r->d[j], alpha_prev, alpha, rc, lambda, j ? -1 : INN_POW2(fr), &sh[j]);
		sh_min = sh[j] < sh_min ? sh[j] : sh_min;
		b[j] = v[j];
		for (unsigned i = 0; i < j; i++) {
			rls_sig_t uij = u[i][j];
			u[i][j] = u_update(uij, b[i], f[j], rc_prev); /* U_ij - f_j b_i / a_(j-1) */
			b[i] = inn_add(b[i], inn_mul_sig(v[j], uij));
		}
		if (!wide_ok(d[j]))
			ok = false;
	}
	if (!(alpha > INN_ZERO))
		ok = false;
	/* a priori errors and new estimates: theta += K e, K = b / a_n (one gain per parameter,
	 * shared by the outputs) */
	rls_par_t th[RLS_MAX_OUTPUTS][RLS_MAX_PARAMS];
	rls_sig_t e[RLS_MAX_OUTPUTS];
	rls_gain_t gain[RLS_MAX_PARAMS];
	for (unsigned i = 0; i < n; i++)
		gain[i] = gain_of(b[i], rc);
	for (unsigned o = 0; ok && o < no; o++) {
		rls_dot_t yhat = dot_of_par(r->theta[o][0], phi[0]);
		for (unsigned i = 1; i < n; i++)
			yhat = dot_mac_par(yhat, r->theta[o][i], phi[i]);
		e[o] = sig_of_dot(dot_sub(dot_of_sig(y[o]), yhat));
		for (unsigned i = 0; i < n; i++) {
			th[o][i] = par_add_g(r->theta[o][i], gain[i], e[o]);
			if (!acc_ok(th[o][i]))
				ok = false;
		}
	}
	for (unsigned i = 0; ok && i < n; i++)
		for (unsigned j = i + 1; j < n; j++)
			if (!sig_ok(u[i][j]))
				ok = false;
	if (!ok) {
		rls_reset_covariance(r);
		r->n_resets++;
		return RLS_RESET;
	}

	/* the common part of the shifts goes to the exponent (within its limits), the rest
	 * into the mantissas (fixed build; all shifts are 0 in the float build) */
	int e_new = r->d_exp + sh_min;
	if (e_new > RLS_EXP_MAX)
		e_new = RLS_EXP_MAX;
	for (unsigned i = 0; i < n; i++) {
		r->d[i] = wide_ldexp(d[i], e_new - r->d_exp - sh[i]);
		for (unsigned j = i + 1; j < n; j++)
			r->u[RLS_U_IDX(i, j)] = u[i][j];
	}
	r->d_exp = (int8_t)e_new;
	for (unsigned o = 0; o < no; o++) {
		for (unsigned i = 0; i < n; i++)
			r->theta[o][i] = th[o][i];
		/* residual: e^2 / innov, innov = alpha_n / lambda */
		rls_acc_t s = acc_add(acc_forget(r->ssr[o], lambda), acc_res(e[o], alpha, rc, lambda, fr));
		r->ssr[o] = acc_ok(s) ? s : ACC_ZERO;
	}
	r->n_eff = acc_add(acc_forget(r->n_eff, lambda), acc_of_unit(UNIT_ONE));

	/* covariance floor, from the last row up (raising D_i changes P_kk for k <= i only) */
	for (unsigned ii = n; ii-- > 0;) {
		if (!(r->p_min_n > ACC_ZERO))
			continue;
		rls_acc_t pmin = acc_ldexp(acc_pow4(r->p_min_n, r->cfg.phi_shift[ii]), r->d_exp);
		rls_acc_t p = pdiag_m(r, ii);
		if (p < pmin)
			r->d[ii] = wide_add(r->d[ii], wide_of_acc(acc_sub(pmin, p)));
	}
	renormalise(r, n);
	r->n_updates++;
	return RLS_UPDATED;
}

enum rls_result rls_update_n(struct rls *r, const rls_sig_t *phi_n, const rls_sig_t *y_n, rls_acc_t phi2, bool excited)
{
	const unsigned n = r->cfg.n_params;
	if (!excited || phi2 < r->phi_min2) {
		r->n_gated++;
		return RLS_GATED;
	}

	/* effective forgetting: never wind any P_ii above the ceiling */
	rls_unit_t lambda = r->lambda;
	if (lambda < UNIT_ONE) {
		for (unsigned i = 0; i < n; i++) {
			if (!(r->p_max_n > ACC_ZERO))
				continue;
			rls_unit_t lmin = unit_ratio(pdiag_m(r, i),
						     acc_ldexp(acc_pow4(r->p_max_n, r->cfg.phi_shift[i]), r->d_exp));
			if (lmin > lambda)
				lambda = lmin < UNIT_ONE ? lmin : UNIT_ONE;
		}
	}

#if OCTO_FIXED
	/* each n (rls_init clamps it to 1..RLS_MAX_PARAMS = 2) is a call with a constant, which
	 * the compiler specialises: no loops, no copies, and the same arithmetic */
	_Static_assert(RLS_MAX_PARAMS == 2, "rls_update_n specialises n = 1 and n = 2");
	if (n == 1)
		return bierman(r, phi_n, y_n, lambda, 1);
	return bierman(r, phi_n, y_n, lambda, 2);
#else
	return bierman(r, phi_n, y_n, lambda, n);
#endif
}

enum rls_result rls_update(struct rls *r, const scalar_t *phi, const scalar_t *y, bool excited)
{
	rls_sig_t pn[RLS_MAX_PARAMS], yn[RLS_MAX_OUTPUTS];
	rls_acc_t phi2 = ACC_ZERO;
	for (unsigned i = 0; i < r->cfg.n_params; i++) {
		if (!sc_isfinite(phi[i])) {
			r->n_rejected++;
			return RLS_REJECTED;
		}
		pn[i] = sig_of_sc(phi[i], r->cfg.phi_shift[i]);
		if (phi2_needed(r))
			phi2 = acc_add(phi2, phi2_of_sc(phi[i]));
	}
	for (unsigned o = 0; o < r->cfg.n_outputs; o++) {
		if (!sc_isfinite(y[o])) {
			r->n_rejected++;
			return RLS_REJECTED;
		}
		yn[o] = sig_of_sc(y[o], r->y_shift[o]);
	}
	if (!acc_ok(phi2)) { /* float: |phi|^2 overflowed */
		r->n_gated++;
		return RLS_GATED;
	}
	return rls_update_n(r, pn, yn, phi2, excited);
}
