/*
 * rls.h - recursive least squares, Bierman UD form, several outputs sharing one regressor.
 *
 * Model: y_o = phi^T theta_o + e_o, o = 0..n_outputs-1, phi in R^n_params (n_params <= 2,
 * n_outputs <= 2: what the identification uses, see RLS_MAX_PARAMS). All outputs share one
 * regressor, hence one covariance P and one gain K: e.g. the paper's eq. (18) with phi = [T_1],
 * y = [f_1, tau_1], theta = [k_f, k_tau] is two scalar problems sharing P (one gain updates k_f
 * and k_tau).
 *
 * P = U D U^T (U unit upper triangular) is updated by Bierman's algorithm with forgetting
 * factor lambda (docs/identification.md, "Recursive least squares").
 *
 * Number representation (one source, two builds; docs/number-formats.md):
 *   - The algorithm runs on normalised signals: phi_n_i = phi_i 2^-phi_shift_i and
 *     y_n_o = y_o 2^-y_shift_o, hence theta_n_oi = theta_oi 2^(phi_shift_i - y_shift_o) and
 *     P_n_ij = P_ij 2^(phi_shift_i + phi_shift_j). Scaling by powers of two is exact, so the
 *     float build computes what it computed without them. rls_init takes phi_shift from the
 *     configuration and chooses y_shift_o so that the largest |theta0_n| of output o is in
 *     [0.71, 1.41) (k_f scaled by its nominal); an output whose theta0 is all zero keeps 0.
 *   - D is kept as a mantissa d_i and one exponent shared by the factor:
 *     D_i = d_i 2^-d_exp. After each update the mantissas are renormalised (max d_i in
 *     [0.5, 1), d_exp in [RLS_EXP_MIN, RLS_EXP_MAX]), so that P's nine or more decades
 *     between p0 and a long flight's converged value keep 30 significant bits.
 *   - Float build: every rls_* type is float, d_exp stays 0.
 *   - Fixed build (OCTO_FIXED): integer arithmetic only in rls.c, formats from qfmt.h:
 *       theta_n                                           Q15.48 int64 (|x| < 32768)
 *       U, phi_n, y_n, f = U^T phi_n, errors              Q7.24 int32 (|x| < 128)
 *       d (mantissa of D)                                 Q1.62 int64 ([0, 2))
 *       lambda, ratios (as r 2^-sh)                       Q1.30 int32
 *       D f, gain numerators, innovation, in the frame
 *       D 2^-min(d_exp, 0) (|.| <= 2 |f|, sums < 512)     Q9.54 int64
 *       P diagonal, residual sums, effective sample count Q23.40 int64
 *     Everything saturates (never wraps): a normalised signal beyond +/-128 is clipped,
 *     d_exp stops at its limits (P beyond 2^-RLS_EXP_MIN saturates, P under
 *     2^-RLS_EXP_MAX loses precision and a mantissa that reaches 0 triggers RLS_RESET).
 *   The update path (rls.c) is free of float in the fixed build; configuration and the
 *   float getters, which run off the 90 Hz path, are rls_setup.c.
 *
 * Robustness options (rls_config):
 *   - gating: an update runs only if the caller says `excited` and |phi|_2 >= phi_min;
 *     a gated sample changes nothing (no forgetting either, so no covariance wind-up);
 *   - covariance ceiling p_max (in the fixed build at most RLS_FIXED_P_CEIL p0, also when
 *     p_max is 0: its precision cannot follow a covariance wound up further): forgetting is limited so that no diagonal entry of P exceeds
 *     p_max (effective lambda = max(lambda, max_i P_ii / p_max) <= 1);
 *   - covariance floor p_min: after an update, a diagonal entry of P below p_min is raised to
 *     p_min (D_i += p_min - P_ii, keeps P positive definite; keeps tracking alive);
 *   - NaN/Inf guard: a non-finite input sample is rejected (RLS_REJECTED); if an update
 *     produces a non-finite value or D_i <= 0, the previous estimate is kept and the
 *     covariance is reset to p0 I (RLS_RESET).
 * Residual variance per output and parameter sds: with lambda = 1 and a large p0, the
 * batch least-squares ones (SSR / (n - p), sqrt(P_ii var_o)).
 */
#ifndef OCTO_RLS_H
#define OCTO_RLS_H

#include "scalar.h"

#include <stdbool.h>
#include <stdint.h>

/* The largest problem the firmware solves (ident.h: k_f and k_tau on one regressor, the lag
 * check's two parameters on one output); every struct rls holds this much, so it is kept to
 * what is used */
#define RLS_MAX_PARAMS 2
#define RLS_MAX_OUTPUTS 2
/* limits of the shared exponent of D (D = d 2^-d_exp): P in about [2^-22, 2^40] */
#define RLS_EXP_MIN (-40)
#define RLS_EXP_MAX 22
/* fixed build: the covariance ceiling when p_max is 0 or larger (a multiple of p0) */
#define RLS_FIXED_P_CEIL 65536.0f

#if OCTO_FIXED
typedef int32_t rls_sig_t;  /* Q7.24: normalised signals, parameters, U, errors */
typedef int32_t rls_unit_t; /* Q1.30: D mantissas, lambda, ratios */
typedef int64_t rls_acc_t;  /* Q23.40: innovations, covariance diagonal, residual sums */
typedef int64_t rls_wide_t; /* Q1.62: D mantissas */
typedef int64_t rls_inn_t;  /* Q9.54: D f, gain numerators, innovation */
typedef int64_t rls_par_t;  /* Q15.48: theta_n */
#else
typedef float rls_par_t;
typedef float rls_wide_t;
typedef float rls_inn_t;
typedef float rls_sig_t;
typedef float rls_unit_t;
typedef float rls_acc_t;
#endif

struct rls_config {
	uint8_t n_params;                              /* 1..RLS_MAX_PARAMS (clamped) */
	uint8_t n_outputs;                             /* 1..RLS_MAX_OUTPUTS (clamped) */
	float lambda;                                  /* forgetting factor, clamped to [0.5, 1] */
	float p0;                                      /* initial and reset covariance: P = p0 I (> 0) */
	float p_min;                                   /* floor on diag(P); 0 = none */
	float p_max;                                   /* ceiling on diag(P) through forgetting; 0 = none */
	float phi_min;                                 /* gate: no update when |phi|_2 < phi_min; 0 = none */
	float theta0[RLS_MAX_OUTPUTS][RLS_MAX_PARAMS]; /* initial estimate */
	int8_t phi_shift[RLS_MAX_PARAMS];              /* phi_n_i = phi_i 2^-phi_shift_i; clamped to [-16, 16] */
};

enum rls_result {
	RLS_UPDATED = 0,
	RLS_GATED = 1,    /* not excited or |phi| < phi_min: nothing changed */
	RLS_REJECTED = 2, /* non-finite input: nothing changed */
	RLS_RESET = 3,    /* numerical failure: estimate kept, covariance reset to p0 I */
};

/* What the update and the getters need of the configuration, as rls_init clamped it; the
 * rest of rls_config is kept below in the normalised form the update uses. */
struct rls_shape {
	uint8_t n_params;
	uint8_t n_outputs;
	int8_t phi_shift[RLS_MAX_PARAMS];
};

/* All numbers below are normalised (see above); read them through the functions. Members
 * are ordered by size (no padding), and only what the update reads is kept: U's strict upper
 * part (u[RLS_U_IDX(i, j)], i < j; the diagonal is 1 and the rest 0) and p0 I as one mantissa. */
#define RLS_U_N (RLS_MAX_PARAMS * (RLS_MAX_PARAMS - 1) / 2)
#define RLS_U_IDX(i, j) ((j) * ((j) - 1u) / 2u + (i))
struct rls {
	struct rls_shape cfg;
	int8_t y_shift[RLS_MAX_OUTPUTS];                  /* y_n_o = y_o 2^-y_shift_o */
	int8_t d_exp;                                     /* D_n_i = d_i 2^-d_exp, in [RLS_EXP_MIN, RLS_EXP_MAX] */
	int8_t d0_exp;                                    /* p0 I in the same form (resets): */
	rls_par_t theta[RLS_MAX_OUTPUTS][RLS_MAX_PARAMS]; /* theta_n */
	rls_wide_t d[RLS_MAX_PARAMS];
	rls_wide_t d0;                  /* D0_n_i = d0 4^(phi_shift_i - m) 2^-d0_exp, m the
						   * largest phi_shift of the n_params */
	rls_acc_t ssr[RLS_MAX_OUTPUTS]; /* forgotten sum of normalised residuals^2 (y_n) */
	rls_acc_t n_eff;                /* forgotten sample count */
	rls_acc_t p_min_n, p_max_n;     /* floor and ceiling on P_n_ii (d_exp = 0) of a
						   * parameter with phi_shift 0: 2^(2 phi_shift_i) times
						   * them for parameter i */
	rls_acc_t phi_min2;             /* phi_min^2: Q16.16 squared (Q32) when fixed */
	rls_sig_t u[RLS_U_N];           /* U_n_ij = u[RLS_U_IDX(i, j)], i < j */
	rls_unit_t lambda;              /* cfg.lambda */
	uint32_t n_updates, n_gated, n_rejected, n_resets;
};

/* cfg: n_params 1, n_outputs 1, lambda 1, p0 1e4, no floor/ceiling/gate, theta0 = 0 */
void rls_default_config(struct rls_config *cfg);

void rls_init(struct rls *r, const struct rls_config *cfg);

/* P = p0 I, keeps theta (and the counters); integer in the fixed build (rls.c) */
void rls_reset_covariance(struct rls *r);

/* One sample: phi[n_params], y[n_outputs]. rls_update is the 90 Hz path; rls_update_f
 * (rls_setup.c) takes float, which in the fixed build it rounds to the normalised format
 * (Q7.24) directly, rejecting non-finite values. */
enum rls_result rls_update(struct rls *r, const scalar_t *phi, const scalar_t *y, bool excited);
enum rls_result rls_update_f(struct rls *r, const float *phi, const float *y, bool excited);
/* the update on normalised signals (phi_n, y_n), which both entry points above call */
enum rls_result rls_update_n(struct rls *r, const rls_sig_t *phi_n, const rls_sig_t *y_n, rls_acc_t phi2, bool excited);

/* theta[out][param] (rls_setup.c) */
float rls_estimate_f(const struct rls *r, unsigned out, unsigned param);

/* P_n_ii 2^d_exp (normalised units, the form rls.c computes in) */
rls_acc_t rls_cov_diag_n(const struct rls *r, unsigned param);

/* P_ii (unscaled covariance; multiply by the residual variance for parameter variance) */
float rls_cov_diag(const struct rls *r, unsigned param);

/* running residual variance of output out */
float rls_residual_var(const struct rls *r, unsigned out);

/* standard deviation of theta[out][param]: sqrt(P_ii * residual variance) */
float rls_std(const struct rls *r, unsigned out, unsigned param);

#endif /* OCTO_RLS_H */
