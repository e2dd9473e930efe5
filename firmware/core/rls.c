/* rls.c - Bierman UD recursive least squares; see rls.h. float32 internally. */
#include "rls.h"

static bool finite_f(float x) { return isfinite(x); }

/* bierman() below is inlined at both of its calls so that the one with n = 1 is specialised */
#if defined(__GNUC__)
#define RLS_INLINE static inline __attribute__((always_inline))
#else
#define RLS_INLINE static inline
#endif

void rls_default_config(struct rls_config *cfg)
{
	struct rls_config c = { 0 };
	c.n_params = 1;
	c.n_outputs = 1;
	c.lambda = 1.0f;
	c.p0 = 1e4f;
	*cfg = c;
}

void rls_reset_covariance(struct rls *r)
{
	for (unsigned i = 0; i < RLS_MAX_PARAMS; i++) {
		for (unsigned j = 0; j < RLS_MAX_PARAMS; j++)
			r->u[i][j] = i == j ? 1.0f : 0.0f;
		r->d[i] = r->cfg.p0;
	}
}

void rls_init(struct rls *r, const struct rls_config *cfg)
{
	struct rls z = { 0 };
	*r = z;
	r->cfg = *cfg;
	if (r->cfg.n_params < 1)
		r->cfg.n_params = 1;
	if (r->cfg.n_params > RLS_MAX_PARAMS)
		r->cfg.n_params = RLS_MAX_PARAMS;
	if (r->cfg.n_outputs < 1)
		r->cfg.n_outputs = 1;
	if (r->cfg.n_outputs > RLS_MAX_OUTPUTS)
		r->cfg.n_outputs = RLS_MAX_OUTPUTS;
	if (!(r->cfg.lambda >= 0.5f))
		r->cfg.lambda = 0.5f;
	if (!(r->cfg.lambda <= 1.0f))
		r->cfg.lambda = 1.0f;
	if (!(r->cfg.p0 > 0.0f) || !finite_f(r->cfg.p0))
		r->cfg.p0 = 1e4f;
	if (!(r->cfg.p_min >= 0.0f) || !finite_f(r->cfg.p_min))
		r->cfg.p_min = 0.0f;
	if (!(r->cfg.p_max >= 0.0f) || !finite_f(r->cfg.p_max))
		r->cfg.p_max = 0.0f;
	if (!(r->cfg.phi_min >= 0.0f) || !finite_f(r->cfg.phi_min))
		r->cfg.phi_min = 0.0f;
	for (unsigned o = 0; o < RLS_MAX_OUTPUTS; o++)
		for (unsigned i = 0; i < RLS_MAX_PARAMS; i++)
			r->theta[o][i] = finite_f(cfg->theta0[o][i]) ? cfg->theta0[o][i] : 0.0f;
	rls_reset_covariance(r);
}

void rls_set_estimate(struct rls *r, unsigned out, const float *theta)
{
	if (out >= r->cfg.n_outputs)
		return;
	for (unsigned i = 0; i < r->cfg.n_params; i++)
		if (finite_f(theta[i]))
			r->theta[out][i] = theta[i];
}

/* P_ii = sum_{k >= i} U_ik^2 D_k */
static float pdiag(const struct rls *r, unsigned i)
{
	float s = 0.0f;
	for (unsigned k = i; k < r->cfg.n_params; k++)
		s += r->u[i][k] * r->u[i][k] * r->d[k];
	return s;
}

/* One Bierman step of n = cfg.n_params parameters with the effective forgetting lambda:
 * f = U^T phi, v = D f, then U, D and theta column by column. On a numerical failure the
 * estimate is kept and the covariance reset. */
RLS_INLINE enum rls_result bierman(struct rls *r, const float *phi, const float *y, float lambda,
				      unsigned n)
{
	const unsigned no = r->cfg.n_outputs;
	float f[RLS_MAX_PARAMS], v[RLS_MAX_PARAMS], b[RLS_MAX_PARAMS];
	float u[RLS_MAX_PARAMS][RLS_MAX_PARAMS], d[RLS_MAX_PARAMS];
	for (unsigned j = 0; j < n; j++) {
		float s = 0.0f;
		for (unsigned i = 0; i <= j; i++)
			s += r->u[i][j] * phi[i];
		f[j] = s;
		v[j] = r->d[j] * s;
		for (unsigned i = 0; i < n; i++)
			u[i][j] = r->u[i][j];
	}
	float alpha = lambda;
	bool ok = true;
	for (unsigned j = 0; j < n; j++) {
		float alpha_prev = alpha;
		alpha = alpha_prev + f[j] * v[j];
		d[j] = r->d[j] * alpha_prev / (alpha * lambda);
		b[j] = v[j];
		float mu = -f[j] / alpha_prev;
		for (unsigned i = 0; i < j; i++) {
			float uij = u[i][j];
			u[i][j] = uij + b[i] * mu;
			b[i] += uij * v[j];
		}
		if (!(d[j] > 0.0f) || !finite_f(d[j]))
			ok = false;
	}
	/* a priori errors and new estimates */
	float th[RLS_MAX_OUTPUTS][RLS_MAX_PARAMS], e[RLS_MAX_OUTPUTS];
	float innov = alpha / lambda; /* 1 + phi^T P phi / lambda */
	for (unsigned o = 0; o < no; o++) {
		float yhat = 0.0f;
		for (unsigned i = 0; i < n; i++)
			yhat += phi[i] * r->theta[o][i];
		e[o] = y[o] - yhat;
		for (unsigned i = 0; i < n; i++) {
			th[o][i] = r->theta[o][i] + b[i] / alpha * e[o];
			if (!finite_f(th[o][i]))
				ok = false;
		}
	}
	for (unsigned i = 0; ok && i < n; i++)
		for (unsigned j = i + 1; j < n; j++)
			if (!finite_f(u[i][j]))
				ok = false;
	if (!ok || !finite_f(alpha) || !(alpha > 0.0f)) {
		rls_reset_covariance(r);
		r->n_resets++;
		return RLS_RESET;
	}

	for (unsigned i = 0; i < n; i++) {
		r->d[i] = d[i];
		for (unsigned j = i + 1; j < n; j++)
			r->u[i][j] = u[i][j];
	}
	for (unsigned o = 0; o < no; o++) {
		for (unsigned i = 0; i < n; i++)
			r->theta[o][i] = th[o][i];
		float s = lambda * r->ssr[o] + e[o] * e[o] / innov;
		r->ssr[o] = finite_f(s) ? s : 0.0f;
	}
	r->n_eff = lambda * r->n_eff + 1.0f;

	/* covariance floor, from the last row up (raising D_i changes P_kk for k <= i only) */
	if (r->cfg.p_min > 0.0f) {
		for (unsigned ii = n; ii-- > 0;) {
			float p = pdiag(r, ii);
			if (p < r->cfg.p_min)
				r->d[ii] += r->cfg.p_min - p;
		}
	}
	r->n_updates++;
	return RLS_UPDATED;
}

enum rls_result rls_update_f(struct rls *r, const float *phi, const float *y, bool excited)
{
	const unsigned n = r->cfg.n_params, no = r->cfg.n_outputs;
	float nphi = 0.0f;
	for (unsigned i = 0; i < n; i++) {
		if (!finite_f(phi[i])) {
			r->n_rejected++;
			return RLS_REJECTED;
		}
		nphi += phi[i] * phi[i];
	}
	for (unsigned o = 0; o < no; o++) {
		if (!finite_f(y[o])) {
			r->n_rejected++;
			return RLS_REJECTED;
		}
	}
	if (!excited || !finite_f(nphi) || nphi < r->cfg.phi_min * r->cfg.phi_min) {
		r->n_gated++;
		return RLS_GATED;
	}

	/* effective forgetting: never wind any P_ii above the ceiling */
	float lambda = r->cfg.lambda;
	if (r->cfg.p_max > 0.0f && lambda < 1.0f) {
		float pmax = 0.0f;
		for (unsigned i = 0; i < n; i++) {
			float p = pdiag(r, i);
			pmax = p > pmax ? p : pmax;
		}
		float lmin = pmax / r->cfg.p_max;
		if (lmin > lambda)
			lambda = lmin < 1.0f ? lmin : 1.0f;
	}

	/* one parameter (the identification's common case) is a call with a constant n, which
	 * the compiler specialises: no loops, no copies, and the same arithmetic */
	if (n == 1)
		return bierman(r, phi, y, lambda, 1);
	return bierman(r, phi, y, lambda, n);
}

enum rls_result rls_update(struct rls *r, const scalar_t *phi, const scalar_t *y, bool excited)
{
#if !OCTO_FIXED
	return rls_update_f(r, phi, y, excited); /* scalar_t is float: nothing to convert */
#else
	float pf[RLS_MAX_PARAMS], yf[RLS_MAX_OUTPUTS];
	for (unsigned i = 0; i < r->cfg.n_params; i++)
		pf[i] = sc_to_float(phi[i]);
	for (unsigned o = 0; o < r->cfg.n_outputs; o++)
		yf[o] = sc_to_float(y[o]);
	return rls_update_f(r, pf, yf, excited);
#endif
}

float rls_estimate_f(const struct rls *r, unsigned out, unsigned param)
{
	if (out >= RLS_MAX_OUTPUTS || param >= RLS_MAX_PARAMS)
		return 0.0f;
	return r->theta[out][param];
}

scalar_t rls_estimate(const struct rls *r, unsigned out, unsigned param)
{
	return sc_from_float(rls_estimate_f(r, out, param));
}

float rls_cov_diag(const struct rls *r, unsigned param)
{
	if (param >= r->cfg.n_params)
		return 0.0f;
	return pdiag(r, param);
}

float rls_residual_var(const struct rls *r, unsigned out)
{
	if (out >= r->cfg.n_outputs)
		return 0.0f;
	float dof = r->n_eff - (float)r->cfg.n_params;
	if (dof < 1.0f)
		dof = 1.0f;
	return r->ssr[out] / dof;
}

float rls_std(const struct rls *r, unsigned out, unsigned param)
{
	float v = rls_cov_diag(r, param) * rls_residual_var(r, out);
	return v > 0.0f ? sqrtf(v) : 0.0f;
}
