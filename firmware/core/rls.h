/*
 * rls.h - recursive least squares, Bierman UD form, several outputs sharing one regressor.
 *
 * Model: y_o = phi^T theta_o + e_o, o = 0..n_outputs-1, phi in R^n_params (n_params <= 4,
 * n_outputs <= 3). All outputs share one regressor, hence one covariance P and one gain K:
 * e.g. the paper's eq. (18) with phi = [T_1], y = [f_1, tau_1], theta = [k_f, k_tau] is two
 * scalar problems sharing P (one gain updates k_f and k_tau).
 *
 * Internals are float32 in both builds (this issue allows it): P = U D U^T with U unit upper
 * triangular, updated by Bierman's algorithm with forgetting factor lambda:
 *     K = P phi / (lambda + phi^T P phi),  P <- (P - K phi^T P) / lambda,  theta_o += K e_o.
 * The interface does not force float on callers: rls_update takes scalar_t (converted with
 * sc_to_float), rls_update_f takes float; getters exist in both types.
 *
 * Robustness options (rls_config):
 *   - gating: an update runs only if the caller says `excited` and |phi|_2 >= phi_min;
 *     a gated sample changes nothing (no forgetting either, so no covariance wind-up);
 *   - covariance ceiling p_max: forgetting is limited so that no diagonal entry of P exceeds
 *     p_max (effective lambda = max(lambda, max_i P_ii / p_max) <= 1);
 *   - covariance floor p_min: after an update, a diagonal entry of P below p_min is raised to
 *     p_min (D_i += p_min - P_ii, keeps P positive definite; keeps tracking alive);
 *   - NaN/Inf guard: a non-finite input sample is rejected (RLS_REJECTED); if an update
 *     produces a non-finite value or D_i <= 0, the previous estimate is kept and the
 *     covariance is reset to p0 I (RLS_RESET).
 * Residual variance (per output): s_o <- lambda s_o + e_o^2 / (1 + phi^T P phi) with the a
 * priori error e_o, n_eff <- lambda n_eff + 1, var_o = s_o / max(n_eff - n_params, 1); with
 * lambda = 1 and a large p0 this is the batch residual variance SSR / (n - p).
 * Parameter std: sqrt(P_ii var_o) (the batch LS standard error when lambda = 1).
 */
#ifndef OCTO_RLS_H
#define OCTO_RLS_H

#include "scalar.h"

#include <stdbool.h>
#include <stdint.h>

#define RLS_MAX_PARAMS  4
#define RLS_MAX_OUTPUTS 3

struct rls_config {
	uint8_t n_params;   /* 1..RLS_MAX_PARAMS (clamped) */
	uint8_t n_outputs;  /* 1..RLS_MAX_OUTPUTS (clamped) */
	float lambda;       /* forgetting factor, clamped to [0.5, 1] */
	float p0;           /* initial and reset covariance: P = p0 I (> 0) */
	float p_min;        /* floor on diag(P); 0 = none */
	float p_max;        /* ceiling on diag(P) through forgetting; 0 = none */
	float phi_min;      /* gate: no update when |phi|_2 < phi_min; 0 = none */
	float theta0[RLS_MAX_OUTPUTS][RLS_MAX_PARAMS]; /* initial estimate */
};

enum rls_result {
	RLS_UPDATED = 0,
	RLS_GATED = 1,     /* not excited or |phi| < phi_min: nothing changed */
	RLS_REJECTED = 2,  /* non-finite input: nothing changed */
	RLS_RESET = 3,     /* numerical failure: estimate kept, covariance reset to p0 I */
};

struct rls {
	struct rls_config cfg;
	float theta[RLS_MAX_OUTPUTS][RLS_MAX_PARAMS];
	float u[RLS_MAX_PARAMS][RLS_MAX_PARAMS]; /* unit upper triangular */
	float d[RLS_MAX_PARAMS];
	float ssr[RLS_MAX_OUTPUTS];              /* forgotten sum of normalised residuals^2 */
	float n_eff;                             /* forgotten sample count */
	uint32_t n_updates, n_gated, n_rejected, n_resets;
};

/* cfg: n_params 1, n_outputs 1, lambda 1, p0 1e4, no floor/ceiling/gate, theta0 = 0 */
void rls_default_config(struct rls_config *cfg);

void rls_init(struct rls *r, const struct rls_config *cfg);

/* P = p0 I, keeps theta (and the counters) */
void rls_reset_covariance(struct rls *r);

/* Sets theta_o (all outputs, n_params each) without touching P. */
void rls_set_estimate(struct rls *r, unsigned out, const float *theta);

/* One sample: phi[n_params], y[n_outputs]. */
enum rls_result rls_update(struct rls *r, const scalar_t *phi, const scalar_t *y, bool excited);
enum rls_result rls_update_f(struct rls *r, const float *phi, const float *y, bool excited);

/* theta[out][param] */
float rls_estimate_f(const struct rls *r, unsigned out, unsigned param);
scalar_t rls_estimate(const struct rls *r, unsigned out, unsigned param);

/* P_ii (unscaled covariance; multiply by the residual variance for parameter variance) */
float rls_cov_diag(const struct rls *r, unsigned param);

/* running residual variance of output out */
float rls_residual_var(const struct rls *r, unsigned out);

/* standard deviation of theta[out][param]: sqrt(P_ii * residual variance) */
float rls_std(const struct rls *r, unsigned out, unsigned param);

#endif /* OCTO_RLS_H */
