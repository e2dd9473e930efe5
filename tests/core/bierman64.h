/*
 * bierman64.h - the float64 reference the fixed-point estimators are compared with
 * (test_rls_ref.c, test_ident_ref.c): Bierman's UD recursive least squares with
 * forgetting lambda, in its textbook form without safeguards, up to 4 parameters and 3
 * outputs sharing the regressor. Test code only.
 */
#ifndef OCTO_TEST_BIERMAN64_H
#define OCTO_TEST_BIERMAN64_H

#include <string.h>

struct ref {
	int n, no;
	double lambda, u[4][4], d[4], th[3][4];
};

/* P = p0 I, theta = th0 (rows: outputs) */
static inline void ref_init(struct ref *r, int n, int no, double p0, double lambda, const double th0[][4])
{
	memset(r, 0, sizeof *r);
	r->n = n;
	r->no = no;
	r->lambda = lambda;
	for (int i = 0; i < n; i++) {
		r->u[i][i] = 1.0;
		r->d[i] = p0;
		for (int o = 0; o < no; o++)
			r->th[o][i] = th0[o][i];
	}
}

/* one measurement y[no] with regressor phi[n] */
static inline void ref_update(struct ref *r, const double *phi, const double *y)
{
	int n = r->n;
	double f[4], v[4], b[4], a = r->lambda;
	for (int j = 0; j < n; j++) {
		double s = phi[j];
		for (int i = 0; i < j; i++)
			s += r->u[i][j] * phi[i];
		f[j] = s;
		v[j] = r->d[j] * s;
	}
	for (int j = 0; j < n; j++) {
		double ap = a;
		a = ap + f[j] * v[j];
		r->d[j] *= ap / (a * r->lambda);
		b[j] = v[j];
		double mu = -f[j] / ap;
		for (int i = 0; i < j; i++) {
			double uij = r->u[i][j];
			r->u[i][j] = uij + b[i] * mu;
			b[i] += uij * v[j];
		}
	}
	for (int o = 0; o < r->no; o++) {
		double e = y[o];
		for (int i = 0; i < n; i++)
			e -= phi[i] * r->th[o][i];
		for (int i = 0; i < n; i++)
			r->th[o][i] += b[i] / a * e;
	}
}

#endif /* OCTO_TEST_BIERMAN64_H */
