/*
 * Tests of firmware/core/rls.h in whichever build this is (float, or integer Q formats in the
 * fixed build); the scalar_t entry point is exercised in each build.
 */
#include "rls.h"
#include "unit.h"

#include <math.h>
#include <string.h>

/* batch least squares, eq. (20): theta = (X^T X)^-1 X^T Y in double, from the accumulated
 * normal equations (no sample storage: the tests also run in 16 KB of RAM on Cortex-M0) */
struct batch {
	int p, no;
	double xx[4][4], xy[4][3], yy[3];
	long n;
};

static void batch_add(struct batch *b, const float *phi, const float *y)
{
	for (int i = 0; i < b->p; i++) {
		for (int j = 0; j < b->p; j++)
			b->xx[i][j] += (double)phi[i] * (double)phi[j];
		for (int o = 0; o < b->no; o++)
			b->xy[i][o] += (double)phi[i] * (double)y[o];
	}
	for (int o = 0; o < b->no; o++)
		b->yy[o] += (double)y[o] * (double)y[o];
	b->n++;
}

/* theta[o][i]; returns nothing, ssr[o] = Y^T Y - theta^T X^T Y */
static void batch_solve(const struct batch *b, double theta[][4], double *ssr)
{
	const int p = b->p, no = b->no;
	double a[4][4 + 3];
	for (int i = 0; i < p; i++) {
		for (int j = 0; j < p; j++)
			a[i][j] = b->xx[i][j];
		for (int o = 0; o < no; o++)
			a[i][p + o] = b->xy[i][o];
	}
	for (int c = 0; c < p; c++) {
		int piv = c;
		for (int r = c + 1; r < p; r++)
			if (fabs(a[r][c]) > fabs(a[piv][c]))
				piv = r;
		for (int j = 0; j < p + no; j++) {
			double t = a[c][j];
			a[c][j] = a[piv][j];
			a[piv][j] = t;
		}
		double pv = a[c][c];
		for (int j = 0; j < p + no; j++)
			a[c][j] /= pv;
		for (int r = 0; r < p; r++)
			if (r != c) {
				double f = a[r][c];
				for (int j = 0; j < p + no; j++)
					a[r][j] -= f * a[c][j];
			}
	}
	for (int o = 0; o < no; o++) {
		ssr[o] = b->yy[o];
		for (int i = 0; i < p; i++) {
			theta[o][i] = a[i][p + o];
			ssr[o] -= theta[o][i] * b->xy[i][o];
		}
	}
}

static bool pos_def(const struct rls *r)
{
	for (unsigned i = 0; i < r->cfg.n_params; i++)
		if (!((double)r->d[i] > 0.0) || !isfinite((double)r->d[i]))
			return false;
	for (unsigned i = 0; i < r->cfg.n_params; i++)
		for (unsigned j = i + 1; j < r->cfg.n_params; j++) /* the strict upper part U keeps */
			if (!isfinite((double)r->u[RLS_U_IDX(i, j)]))
				return false;
	return true;
}

#define N_LS 600

UNIT_TEST(rls_equals_batch_ls)
{
	static const double truth[3][4] = {{28.0, -1.5, 0.7, 3.0}, {0.39, 2.0, -4.0, 0.1}, {-7.0, 0.0, 1.0, 12.0}};
	/* every shape the firmware's RLS holds (RLS_MAX_PARAMS x RLS_MAX_OUTPUTS) */
	for (int shape = 0; shape < RLS_MAX_PARAMS * RLS_MAX_OUTPUTS; shape++) {
		int p = 1 + shape / RLS_MAX_OUTPUTS, no = 1 + shape % RLS_MAX_OUTPUTS;
		struct rls_config c;
		rls_default_config(&c);
		c.n_params = (uint8_t)p;
		c.n_outputs = (uint8_t)no;
		c.lambda = 1.0f;
		c.p0 = 1e8f;
		struct rls r;
		rls_init(&r, &c);
		struct batch b;
		memset(&b, 0, sizeof b);
		b.p = p;
		b.no = no;
		struct unit_rng g = {0x1000ULL + (unsigned)shape};
		for (int k = 0; k < N_LS; k++) {
			float phi[4], y[3];
			for (int i = 0; i < p; i++) {
				phi[i] = (float)unit_rand_uniform(&g, -1.0, 1.0);
				if (i == 0)
					phi[i] = (float)(0.093 + 0.05 * unit_rand_uniform(&g, -1, 1)); /* like T_1 */
			}
			for (int o = 0; o < no; o++) {
				double v = 0;
				for (int i = 0; i < p; i++)
					v += truth[o][i] * phi[i];
				y[o] = (float)(v + 0.05 * unit_rand_normal(&g));
			}
			batch_add(&b, phi, y);
			CHECK(rls_update_f(&r, phi, y, true) == RLS_UPDATED);
		}
		double th[3][4], ssr[3];
		batch_solve(&b, th, ssr);
		/* within 1e-5; the fixed build rounds f = U^T phi to Q7.24 (absolute 2^-24), which
		 * with p0 = 1e8 leaves up to ~3e-9 of the output's largest parameter on each
		 * parameter: a parameter near zero gets that floor */
		for (int o = 0; o < no; o++) {
			double big = 0;
			for (int i = 0; i < p; i++)
				big = fabs(th[o][i]) > big ? fabs(th[o][i]) : big;
			for (int i = 0; i < p; i++)
				CHECK_NEAR(rls_estimate_f(&r, (unsigned)o, (unsigned)i), th[o][i],
					   1e-5 * fabs(th[o][i]) + (OCTO_FIXED ? 4e-9 * big : 0.0));
		}
		CHECK(r.n_updates == N_LS);
		/* residual variance = batch SSR / (n - p) */
		for (int o = 0; o < no; o++)
			CHECK_REL(rls_residual_var(&r, (unsigned)o), ssr[o] / (N_LS - p), 1e-3);
	}
}

/* the paper's problem: one regressor T_1, outputs f_1 and tau_1 (one P, one gain) */
UNIT_TEST(rls_two_outputs_share_regressor)
{
	struct rls_config c;
	rls_default_config(&c);
	c.n_outputs = 2;
	c.p0 = 1e6f;
	struct rls both, kf, kt;
	rls_init(&both, &c);
	c.n_outputs = 1;
	rls_init(&kf, &c);
	rls_init(&kt, &c);
	struct unit_rng g = {0xbeefULL};
	double sxx = 0, sxf = 0, sxt = 0;
	for (int k = 0; k < 900; k++) {
		double t = 0.093 + unit_rand_uniform(&g, -0.05, 0.05);
		double f = 28.0269 * t + 0.026 * unit_rand_normal(&g);
		double tau = 0.3869 * t + 0.0004 * unit_rand_normal(&g);
		float phi = (float)t, y[2] = {(float)f, (float)tau};
		rls_update_f(&both, &phi, y, true);
		rls_update_f(&kf, &phi, &y[0], true);
		rls_update_f(&kt, &phi, &y[1], true);
		double tq = (double)phi;
		sxx += tq * tq;
		sxf += tq * (double)y[0];
		sxt += tq * (double)y[1];
	}
	CHECK_REL(rls_estimate_f(&both, 0, 0), sxf / sxx, 1e-5);
	CHECK_REL(rls_estimate_f(&both, 1, 0), sxt / sxx, 1e-5);
	CHECK(rls_estimate_f(&both, 0, 0) == rls_estimate_f(&kf, 0, 0));
	CHECK(rls_estimate_f(&both, 1, 0) == rls_estimate_f(&kt, 0, 0));
	CHECK_REL(rls_estimate_f(&both, 0, 0), 28.0269, 5e-3);
	CHECK_REL(rls_estimate_f(&both, 1, 0), 0.3869, 5e-3);
}

/* 120 s at 90 Hz of a constant regressor with forgetting 0.99, then excitation again */
static void windup_run(struct unit_ctx *u, float p_max, bool gate, int expect_resets)
{
	struct rls_config c;
	rls_default_config(&c);
	c.n_params = 2; /* f = k_f T + c (intercept): the constant regressor leaves one direction unexcited */
	c.lambda = 0.99f;
	c.p0 = 100.0f;
	c.p_max = p_max;
	c.theta0[0][0] = 20.0f;
	struct rls r;
	rls_init(&r, &c);
	struct unit_rng g = {0x42ULL};
	const double kf = 28.0269, sig = 0.005;
	/* 5 s of excitation, 120 s without, 10 s with */
	for (int k = 0; k < 90 * 135; k++) {
		bool exc = k < 90 * 5 || k >= 90 * 125;
		double t = 0.093 + (exc ? unit_rand_uniform(&g, -0.05, 0.05) : 0.0);
		float phi[2] = {(float)t, 1.0f};
		float y = (float)(kf * t + sig * unit_rand_normal(&g));
		enum rls_result res = rls_update_f(&r, phi, &y, gate ? exc : true);
		CHECK(res != RLS_REJECTED);
		if (!pos_def(&r)) {
			unit_fail(u, __FILE__, __LINE__, "not positive definite at sample %d", k);
			return;
		}
		for (int i = 0; i < 2; i++)
			CHECK(isfinite(rls_estimate_f(&r, 0, (unsigned)i)) && isfinite(rls_cov_diag(&r, (unsigned)i)));
		if (p_max > 0.0f)
			for (int i = 0; i < 2; i++)
				CHECK(rls_cov_diag(&r, (unsigned)i) <= 1.001f * p_max);
	}
	CHECK((int)r.n_resets == expect_resets);
	CHECK_REL(rls_estimate_f(&r, 0, 0), kf, 5e-3);
	CHECK_NEAR(rls_estimate_f(&r, 0, 1), 0.0, 0.005 * kf * 0.093);
}

UNIT_TEST(rls_windup_ceiling) { windup_run(u, 1e4f, false, 0); /* covariance ceiling: finite, no reset */ }

UNIT_TEST(rls_windup_gated) { windup_run(u, 0.0f, true, 0); /* updates gated on the excitation flag: no wind-up */ }

UNIT_TEST(rls_windup_unprotected_guard)
{
	/* neither: standard RLS would grow P like 0.99^-n (1e47 after 120 s, beyond float32) and
	 * die; the UD form winds up (to ~1e10 here, where rounding stops it) but stays finite and
	 * positive definite, needs no reset, and recovers once excitation returns */
	windup_run(u, 0.0f, false, 0);
}

UNIT_TEST(rls_nan_guard)
{
	struct rls_config c;
	rls_default_config(&c);
	c.n_params = 2;
	c.n_outputs = 2;
	c.p0 = 10.0f;
	struct rls r;
	rls_init(&r, &c);
	float phi[2] = {1.0f, 0.5f}, y[2] = {2.0f, -1.0f};
	for (int k = 0; k < 20; k++) {
		phi[1] = (float)k * 0.1f;
		rls_update_f(&r, phi, y, true);
	}
	float th0 = rls_estimate_f(&r, 0, 0), th1 = rls_estimate_f(&r, 1, 1), p0 = rls_cov_diag(&r, 0);
	uint32_t n = r.n_updates;
	float bad[2] = {__builtin_nanf(""), 1.0f};
	CHECK(rls_update_f(&r, bad, y, true) == RLS_REJECTED);
	float inf_y[2] = {__builtin_inff(), 0.0f};
	CHECK(rls_update_f(&r, phi, inf_y, true) == RLS_REJECTED);
	CHECK(rls_estimate_f(&r, 0, 0) == th0 && rls_estimate_f(&r, 1, 1) == th1);
	CHECK(rls_cov_diag(&r, 0) == p0 && r.n_updates == n && r.n_rejected == 2);
	/* a numerical failure inside the update (here a corrupted factor: D_0 = 0, which no
	 * update can produce): estimate kept, covariance reset to p0 I */
	r.d[0] = 0;
	CHECK(rls_update_f(&r, phi, y, true) == RLS_RESET);
	CHECK(rls_estimate_f(&r, 0, 0) == th0 && rls_estimate_f(&r, 1, 1) == th1);
	CHECK(rls_cov_diag(&r, 0) == 10.0f && rls_cov_diag(&r, 1) == 10.0f);
	CHECK(r.n_resets == 1 && pos_def(&r));
	/* and it keeps working */
	CHECK(rls_update_f(&r, phi, y, true) == RLS_UPDATED);
	CHECK(pos_def(&r));
}

UNIT_TEST(rls_gating_and_floor)
{
	struct rls_config c;
	rls_default_config(&c);
	c.n_params = 1;
	c.p0 = 1.0f;
	c.phi_min = 0.01f;
	c.p_min = 1e-3f;
	c.lambda = 0.999f;
	struct rls r;
	rls_init(&r, &c);
	float phi = 0.005f, y = 1.0f;
	CHECK(rls_update_f(&r, &phi, &y, true) == RLS_GATED); /* |phi| < phi_min */
	phi = 1.0f;
	CHECK(rls_update_f(&r, &phi, &y, false) == RLS_GATED); /* caller: not excited */
	CHECK(r.n_gated == 2 && r.n_updates == 0 && rls_cov_diag(&r, 0) == 1.0f);
	for (int k = 0; k < 5000; k++)
		rls_update_f(&r, &phi, &y, true);
	CHECK(rls_cov_diag(&r, 0) >= 1e-3f * 0.999f);
	CHECK_NEAR(rls_estimate_f(&r, 0, 0), 1.0, 1e-4);
}

/* the std estimate against the Monte Carlo spread (200 runs) */
UNIT_TEST(rls_std_matches_monte_carlo)
{
	enum { RUNS = 200, N = 300 };
	const double truth[2] = {28.0269, -0.8}, sig = 0.05;
	double sum[2] = {0}, sum2[2] = {0}, var_pred[2] = {0}, rv = 0;
	struct unit_rng g = {0xc0ffeeULL};
	for (int run = 0; run < RUNS; run++) {
		struct rls_config c;
		rls_default_config(&c);
		c.n_params = 2;
		c.p0 = 1e6f;
		struct rls r;
		rls_init(&r, &c);
		for (int k = 0; k < N; k++) {
			float phi[2] = {(float)(0.093 + unit_rand_uniform(&g, -0.05, 0.05)),
					(float)unit_rand_uniform(&g, -1, 1)};
			float y = (float)(truth[0] * phi[0] + truth[1] * phi[1] + sig * unit_rand_normal(&g));
			rls_update_f(&r, phi, &y, true);
		}
		for (int i = 0; i < 2; i++) {
			double e = rls_estimate_f(&r, 0, (unsigned)i);
			sum[i] += e;
			sum2[i] += e * e;
			double s = rls_std(&r, 0, (unsigned)i);
			var_pred[i] += s * s;
		}
		rv += rls_residual_var(&r, 0);
	}
	for (int i = 0; i < 2; i++) {
		double mean = sum[i] / RUNS, var = sum2[i] / RUNS - mean * mean;
		var *= (double)RUNS / (RUNS - 1);
		double ratio = var / (var_pred[i] / RUNS);
		if (!(ratio > 0.8 && ratio < 1.2))
			unit_fail(u, __FILE__, __LINE__, "param %d: MC var / predicted var = %.3f", i, ratio);
		CHECK_REL(mean, truth[i], 0.01);
	}
	CHECK_REL(rv / RUNS, sig * sig, 0.05);
}

/* the scalar_t entry point gives what the float one gives for the same (representable) data */
UNIT_TEST(rls_scalar_interface)
{
	struct rls_config c;
	rls_default_config(&c);
	c.n_params = 2;
	c.n_outputs = 2;
	struct rls a, b;
	rls_init(&a, &c);
	rls_init(&b, &c);
	struct unit_rng g = {0x5ULL};
	for (int k = 0; k < 200; k++) {
		scalar_t phi[2] = {sc_from_float((float)unit_rand_uniform(&g, 0.04, 0.14)),
				   sc_from_float((float)unit_rand_uniform(&g, -1, 1))};
		scalar_t y[2] = {sc_from_float((float)unit_rand_uniform(&g, 0, 4)),
				 sc_from_float((float)unit_rand_uniform(&g, -0.1, 0.1))};
		float pf[2] = {sc_to_float(phi[0]), sc_to_float(phi[1])};
		float yf[2] = {sc_to_float(y[0]), sc_to_float(y[1])};
		CHECK(rls_update(&a, phi, y, true) == rls_update_f(&b, pf, yf, true));
	}
	for (unsigned o = 0; o < 2; o++)
		for (unsigned i = 0; i < 2; i++)
			CHECK(rls_estimate_f(&a, o, i) == rls_estimate_f(&b, o, i));
}
