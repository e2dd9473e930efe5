/* rls_setup.c - recursive least squares: configuration, the float entry point and the float
 * getters (off the 90 Hz path; float in both builds). The update is rls.c; see rls.h. */
#include "rls.h"
#include "fbits.h"
#include "qfmt.h"

/* float to the normalised formats and back (rls.h); the float build keeps float */
#if OCTO_FIXED
static int64_t i64_of_f(float x, int frac, int64_t lim)
{
	float s = x * sc_pow2f(frac);
	if (!(s == s))
		return 0;
	if (s >= (float)lim)
		return lim;
	if (s <= -(float)lim)
		return -lim;
	return (int64_t)(s >= 0.0f ? s + 0.5f : s - 0.5f);
}
static rls_sig_t sig_of_f(float x) { return (rls_sig_t)i64_of_f(x, QF_SIG_FRAC, INT32_MAX); }
static rls_unit_t unit_of_f(float x) { return (rls_unit_t)i64_of_f(x, QF_UNIT_FRAC, INT32_MAX); }
static rls_acc_t acc_of_f(float x) { return i64_of_f(x, QF_ACC_FRAC, INT64_MAX >> 1); }
static rls_wide_t wide_of_f(float x) { return i64_of_f(x, QF_WIDE_FRAC, INT64_MAX >> 1); }
static rls_par_t par_of_f(float x) { return i64_of_f(x, QF_PAR_FRAC, INT64_MAX >> 1); }
static float f_of_par(rls_par_t x) { return (float)x * sc_pow2f(-QF_PAR_FRAC); }
static float f_of_acc(rls_acc_t x) { return (float)x * sc_pow2f(-QF_ACC_FRAC); }
/* |phi|^2 for the gate, in the form rls_update computes it: Q16.16 squared (Q32) */
static rls_acc_t phi2_of_f(float x) { return i64_of_f(x, 2 * QF_SC_FRAC, INT64_MAX >> 1); }
#else
static rls_unit_t unit_of_f(float x) { return x; }
static rls_acc_t acc_of_f(float x) { return x; }
static rls_wide_t wide_of_f(float x) { return x; }
static rls_par_t par_of_f(float x) { return x; }
static float f_of_par(rls_par_t x) { return x; }
static float f_of_acc(rls_acc_t x) { return x; }
static rls_acc_t phi2_of_f(float x) { return x; }
#endif

void rls_default_config(struct rls_config *cfg)
{
	struct rls_config c = {0};
	c.n_params = 1;
	c.n_outputs = 1;
	c.lambda = 1.0f;
	c.p0 = 1e4f;
	*cfg = c;
}

/* the power of two nearest to m > 0 (m 2^-s in [0.71, 1.41)), within [lo, hi] */
static int8_t shift_of(float m, int lo, int hi)
{
	int s = 0;
	/* m is positive, not NaN: compared by its bits */
	while (fb_bits(m) >= fb_bits(1.41421356f) && s < hi) {
		m *= 0.5f;
		s++;
	}
	while (fb_bits(m) < fb_bits(0.70710678f) && s > lo) {
		m *= 2.0f;
		s--;
	}
	return (int8_t)s;
}

/* x if finite and not negative, else 0 */
__attribute__((noinline)) static float nonneg_f(float x)
{
	/* x >= 0 and finite: the sign clear and the exponent not all ones, or -0 */
	const uint32_t u = fb_bits(x);
	return u < 0x7f800000u || u == 0x80000000u ? x : 0.0f;
}

void rls_init(struct rls *r, const struct rls_config *cfg)
{
	struct rls z = {0};
	*r = z;
	struct rls_config cc = *cfg; /* clamped below; r keeps its shape (rls_shape) */
	struct rls_config *c = &cc;
	if (c->n_params < 1)
		c->n_params = 1;
	if (c->n_params > RLS_MAX_PARAMS)
		c->n_params = RLS_MAX_PARAMS;
	if (c->n_outputs < 1)
		c->n_outputs = 1;
	if (c->n_outputs > RLS_MAX_OUTPUTS)
		c->n_outputs = RLS_MAX_OUTPUTS;
	if (!(c->lambda >= 0.5f))
		c->lambda = 0.5f;
	if (!(c->lambda <= 1.0f))
		c->lambda = 1.0f;
	if (fb_bits(c->p0) - 1u >= 0x7f7fffffu) /* not (positive and finite) */
		c->p0 = 1e4f;
	c->p_min = nonneg_f(c->p_min);
	c->p_max = nonneg_f(c->p_max);
	c->phi_min = nonneg_f(c->phi_min);
	for (unsigned i = 0; i < RLS_MAX_PARAMS; i++) {
		if (c->phi_shift[i] > 16)
			c->phi_shift[i] = 16;
		if (c->phi_shift[i] < -16)
			c->phi_shift[i] = -16;
	}
	r->cfg.n_params = c->n_params;
	r->cfg.n_outputs = c->n_outputs;
	for (unsigned i = 0; i < RLS_MAX_PARAMS; i++)
		r->cfg.phi_shift[i] = c->phi_shift[i];
	const unsigned n = c->n_params;
	/* outputs: theta0 (k_f by its nominal) sets each output's scale */
	for (unsigned o = 0; o < RLS_MAX_OUTPUTS; o++) {
		float m = 0.0f, th[RLS_MAX_PARAMS];
		for (unsigned i = 0; i < RLS_MAX_PARAMS; i++) {
			float t = fb_finite(cfg->theta0[o][i]) ? cfg->theta0[o][i] : 0.0f, a;
			th[i] = t;
			a = fabsf(t) * sc_pow2f(c->phi_shift[i]);
			if (i < n && o < c->n_outputs)
				m = a > m ? a : m;
		}
		r->y_shift[o] = fb_pos(m) ? shift_of(m, -20, 20) : 0;
		for (unsigned i = 0; i < RLS_MAX_PARAMS; i++)
			r->theta[o][i] = par_of_f(th[i] * sc_pow2f(c->phi_shift[i] - r->y_shift[o]));
	}
	r->lambda = unit_of_f(c->lambda);
	/* P_n = p0 S^2, S = diag(2^phi_shift): the mantissa of the largest in [0.5, 1), the
	 * others 4^-k times it (rls_reset_covariance) */
	int m = c->phi_shift[0];
	for (unsigned i = 1; i < n; i++)
		m = c->phi_shift[i] > m ? c->phi_shift[i] : m;
	const float pm = c->p0 * sc_pow2f(2 * m);
	int e = 0;
#if OCTO_FIXED
	float pmax = pm;
	while (pmax >= 1.0f && e > RLS_EXP_MIN) {
		pmax *= 0.5f;
		e--;
	}
	while (pmax < 0.5f && e < RLS_EXP_MAX) {
		pmax *= 2.0f;
		e++;
	}
#endif
	r->d0_exp = (int8_t)e;
	r->d0 = wide_of_f(pm * sc_pow2f(e));
	r->p_min_n = acc_of_f(c->p_min);
	float pmx = c->p_max;
#if OCTO_FIXED
	/* the fixed build always keeps P under RLS_FIXED_P_CEIL p0: beyond that, an
	 * unexcited direction's gain is the difference of numbers 2^31 times larger */
	if (!fb_pos(pmx) || pmx > c->p0 * RLS_FIXED_P_CEIL)
		pmx = c->p0 * RLS_FIXED_P_CEIL;
#endif
	r->p_max_n = acc_of_f(pmx);
	r->phi_min2 = phi2_of_f(c->phi_min * c->phi_min);
	rls_reset_covariance(r);
}

enum rls_result rls_update_f(struct rls *r, const float *phi, const float *y, bool excited)
{
#if OCTO_FIXED
	rls_sig_t pn[RLS_MAX_PARAMS], yn[RLS_MAX_OUTPUTS];
	float nphi = 0.0f;
	for (unsigned i = 0; i < r->cfg.n_params; i++) {
		if (!fb_finite(phi[i])) {
			r->n_rejected++;
			return RLS_REJECTED;
		}
		pn[i] = sig_of_f(phi[i] * sc_pow2f(-r->cfg.phi_shift[i]));
		nphi += phi[i] * phi[i];
	}
	for (unsigned o = 0; o < r->cfg.n_outputs; o++) {
		if (!fb_finite(y[o])) {
			r->n_rejected++;
			return RLS_REJECTED;
		}
		yn[o] = sig_of_f(y[o] * sc_pow2f(-r->y_shift[o]));
	}
	return rls_update_n(r, pn, yn, phi2_of_f(nphi), excited);
#else
	return rls_update(r, phi, y, excited); /* scalar_t is float */
#endif
}

float rls_estimate_f(const struct rls *r, unsigned out, unsigned param)
{
	if (out >= RLS_MAX_OUTPUTS || param >= RLS_MAX_PARAMS)
		return 0.0f;
	return f_of_par(r->theta[out][param]) * sc_pow2f(r->y_shift[out] - r->cfg.phi_shift[param]);
}

float rls_cov_diag(const struct rls *r, unsigned param)
{
	if (param >= r->cfg.n_params)
		return 0.0f;
	return f_of_acc(rls_cov_diag_n(r, param)) * sc_pow2f(-r->d_exp - 2 * r->cfg.phi_shift[param]);
}

float rls_residual_var(const struct rls *r, unsigned out)
{
	if (out >= r->cfg.n_outputs)
		return 0.0f;
	float dof = f_of_acc(r->n_eff) - (float)r->cfg.n_params;
	if (dof < 1.0f)
		dof = 1.0f;
	return f_of_acc(r->ssr[out]) / dof * sc_pow2f(2 * r->y_shift[out]);
}

float rls_std(const struct rls *r, unsigned out, unsigned param)
{
	float v = rls_cov_diag(r, param) * rls_residual_var(r, out);
	return fb_pos(v) ? sqrtf(v) : 0.0f;
}
