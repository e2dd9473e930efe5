/*
 * estim.c - Monte Carlo of the core's k_f estimator on simulated data, for `make bench`.
 *
 *   bench-estim [RUNS [SEED [KIND AMP DIV]]]     (default 1000 runs, seed 1, excite.h's default)
 *       KIND 0 uniform, 1 PRBS (order 9, as experiment.c), 2 multisine; AMP throttle; DIV frames
 *       per value / bit. octo-fw's experiment 1 default: 1 0.04 9 (ID_EXC_KIND/AMP/DIV), in the
 *       mixer's null space, so that rotor 1 sees T_h + d exactly as here.
 *
 * Data (per run, 90 Hz, 10 s), as octo-sim and the 90 Hz UDP loop produce it with the
 * default vehicle: rotor 1's command T_k = T_h + d_k (T_h = m g / (8 k_f) = 0.0932, d = the
 * core's excitation (excite.h), by default uniform +/-0.05 every frame, the paper's dither;
 * seed per run), applied from frame k to k+1 (the loop's one frame) after a transport delay
 * of DELAY_FR more frames, through the 30 ms first-order lag (exact ZOH discretisation,
 * double precision): s_(k+1) = s_k + a (T_(k-D) - s_k), a = 1 - exp(-dt/tau); frame k
 * reports f_1 = k_f s_k + e_k, e ~ N(0, sigma^2), sigma = 1 % of hover thrust (0.0261 N).
 *
 * Estimators, all fed the same data:
 *   ident    the core's lag-aware estimator (firmware/core/ident.h ident_rotor_*: RLS on the
 *            lag-filtered regressor), when the core has it;
 *   own      the same built here from filt.h + rls.h as docs/identification.md describes
 *            (filt_delay + filt_lag of the previous throttle, 1-parameter RLS, lambda 1);
 *   plain    the paper's eq. 18-20: f_1 regressed on the command of its own frame, no
 *            intercept (ident's plain estimator when available, else RLS here).
 * Figures at 5 s and 10 s: relative bias and std of k_f over the runs, the Cramer-Rao bound
 * sigma^2 / sum(phi_true^2) (conditional on each run's true regressor, averaged), var/CRLB,
 * and the plain estimator's bias with its closed form
 *     bias = -(E[d^2] - E[d d_lag]) / (T_h^2 + E[d^2])
 * (E over all samples and runs; d_lag = s_k - T_h, what frame k's thrust sees of the dither).
 * Output: one JSON object on stdout.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "excite.h"
#include "filt.h"
#include "rls.h"

#if defined(__has_include)
#if __has_include("ident.h")
#include "ident.h"
#define HAVE_IDENT 1
#endif
#endif
#ifndef HAVE_IDENT
#define HAVE_IDENT 0
#endif

#define RATE_HZ 90.0
#define MASS 2.132
#define GRAV 9.796
#define KF 28.0269
#define KTAU 0.3869
#define MOT_TAU 0.03
#define DELAY_FR 0
#define N_CHECK 2
static const int check_frames[N_CHECK] = {450, 900}; /* 5 s, 10 s */

/* splitmix64 + Box-Muller: Gaussian noise independent of the core's generators */
static uint64_t sm_state;
static uint64_t splitmix(void)
{
	uint64_t z = (sm_state += 0x9E3779B97F4A7C15ull);
	z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
	z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
	return z ^ (z >> 31);
}
static double gauss(void)
{
	double u1 = ((double)(splitmix() >> 11) + 0.5) * (1.0 / 9007199254740992.0);
	double u2 = (double)(splitmix() >> 11) * (1.0 / 9007199254740992.0);
	return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

struct acc { /* running sums over runs of the relative error */
	double s, ss, crlb;
	long n;
};
static void acc_add(struct acc *a, double rel_err, double crlb_rel_var)
{
	a->s += rel_err;
	a->ss += rel_err * rel_err;
	a->crlb += crlb_rel_var;
	a->n++;
}
static void acc_print(const char *name, const struct acc *a, int last)
{
	double n = (double)a->n, mean = a->s / n;
	double var = (a->ss - n * mean * mean) / (n - 1.0);
	double crlb = a->crlb / n;
	printf("    \"%s\": {\"bias_pct\": %.5f, \"std_pct\": %.5f, \"crlb_std_pct\": %.5f, "
	       "\"var_over_crlb\": %.4f}%s\n",
	       name, 100.0 * mean, 100.0 * sqrt(var), 100.0 * sqrt(crlb), var / crlb, last ? "" : ",");
}

int main(int argc, char **argv)
{
	long runs = argc > 1 ? atol(argv[1]) : 1000;
	uint64_t seed = argc > 2 ? (uint64_t)atoll(argv[2]) : 1u;
	const double dt = 1.0 / RATE_HZ;
	const double t_h = MASS * GRAV / (8.0 * KF);
	const double sigma = 0.01 * MASS * GRAV / 8.0;
	const double sigma_tau = 0.01 * KTAU * t_h;
	const double a = 1.0 - exp(-dt / MOT_TAU);
	const int n_frames = check_frames[N_CHECK - 1];

	struct acc ident_a[N_CHECK], own_a[N_CHECK], plain_a[N_CHECK];
	memset(ident_a, 0, sizeof ident_a);
	memset(own_a, 0, sizeof own_a);
	memset(plain_a, 0, sizeof plain_a);
	double e_d2 = 0, e_ddlag = 0;
	long n_samples = 0;
	struct excite_params ep = excite_params_default();
	if (argc > 5) {
		int kind = atoi(argv[3]);
		ep.kind = kind == 0 ? EXCITE_UNIFORM : (kind == 1 ? EXCITE_PRBS : EXCITE_MULTISINE);
		ep.amplitude = sc_from_float((float)atof(argv[4]));
		ep.clock_div = (uint32_t)atol(argv[5]);
		ep.prbs_order = 9u;
	}
	static const char *const kind_name[] = {"off", "uniform", "PRBS", "multisine"};

	for (long run = 0; run < runs; run++) {
		sm_state = seed * 0x100000001B3ull + (uint64_t)run;
		ep.seed = (uint32_t)(seed * 7919u + (uint64_t)run * 104729u + 1u);
		struct excite ex;
		excite_init(&ex, &ep);

#if HAVE_IDENT
		struct ident_rotor id;
		struct ident_rotor_cfg ic = {.dt_s = sc_from_float((float)dt),
					     .mot_tau_s = sc_from_float((float)MOT_TAU),
					     .delay_frames = DELAY_FR,
					     .curve = SC_ZERO,
					     .thr0 = sc_from_float((float)t_h),
					     .kf0 = 20.0f,
					     .ktau0 = 0.3f,
					     .p0 = 0.0f};
		ident_rotor_init(&id, &ic);
#endif
		/* own: delay + lag of the previous throttle, RLS with 1 parameter */
		struct filt_delay dl;
		struct filt_lag lg;
		filt_delay_init(&dl, DELAY_FR, sc_from_float((float)t_h));
		filt_lag_init(&lg, sc_from_float((float)MOT_TAU), sc_from_float((float)dt), sc_from_float((float)t_h));
		struct rls_config rc;
		rls_default_config(&rc);
		rc.p0 = 1e6f;
		rc.theta0[0][0] = 20.0f;
		struct rls own, plain;
		rls_init(&own, &rc);
		rls_init(&plain, &rc);

		double s = t_h; /* true actuator state s_k */
		double hist[FILT_DELAY_MAX + 1];
		for (int i = 0; i <= FILT_DELAY_MAX; i++)
			hist[i] = t_h;
		double t_prev = t_h; /* T_(k-1): the throttle sent on the previous frame */
		double y_prev = 0;
		double sum_phi2 = 0;
		int ci = 0;
		for (int k = 0; k <= n_frames; k++) {
			/* frame k: measurement of s_k */
			double y = KF * s + sigma * gauss();
			double ytau = KTAU * s + sigma_tau * gauss();
			if (k > 0) {
				sum_phi2 += s * s;
#if HAVE_IDENT
				ident_rotor_update(&id, sc_from_float((float)t_prev), sc_from_float((float)y),
						   sc_from_float((float)ytau), true);
#endif
				scalar_t phi =
					filt_lag_update(&lg, filt_delay_update(&dl, sc_from_float((float)t_prev)));
				scalar_t yy = sc_from_float((float)y);
				rls_update(&own, &phi, &yy, true);
#if !HAVE_IDENT
				/* plain: the previous measurement against its own frame's command */
				if (k > 1) {
					scalar_t phr = sc_from_float((float)t_prev), ypr = sc_from_float((float)y_prev);
					rls_update(&plain, &phr, &ypr, true);
				}
#endif
			}
			y_prev = y;
			/* the firmware's command for this frame */
			double d = (double)sc_to_float(excite_update(&ex));
			double t_cmd = t_h + d;
			e_d2 += d * d;
			e_ddlag += d * (s - t_h);
			n_samples++;
			if (ci < N_CHECK && k == check_frames[ci]) {
				double crlb = sigma * sigma / sum_phi2 / (KF * KF);
#if HAVE_IDENT
				acc_add(&ident_a[ci], (double)ident_rotor_est(&id, 0) / KF - 1.0, crlb);
				acc_add(&plain_a[ci], (double)ident_rotor_plain(&id, 0) / KF - 1.0, crlb);
#else
				acc_add(&plain_a[ci], (double)rls_estimate_f(&plain, 0, 0) / KF - 1.0, crlb);
#endif
				acc_add(&own_a[ci], (double)rls_estimate_f(&own, 0, 0) / KF - 1.0, crlb);
				ci++;
			}
			/* plant: T_k acts over [t_k, t_(k+1)] after DELAY_FR more frames, through the lag */
			for (int i = FILT_DELAY_MAX; i > 0; i--)
				hist[i] = hist[i - 1];
			hist[0] = t_cmd;
			s += a * (hist[DELAY_FR] - s);
			t_prev = t_cmd;
		}
		(void)y_prev;
	}
	e_d2 /= (double)n_samples;
	e_ddlag /= (double)n_samples;
	double closed = -(e_d2 - e_ddlag) / (t_h * t_h + e_d2);

	printf("{\n  \"runs\": %ld, \"seed\": %llu, \"rate_hz\": %.0f, \"t_hover\": %.5f, \"sigma_f_n\": %.5f,\n", runs,
	       (unsigned long long)seed, RATE_HZ, t_h, sigma);
	printf("  \"mot_tau_s\": %.3f, \"delay_frames\": %d, \"excitation\": \"%s +/-%.3f, clock_div %u\",\n", MOT_TAU,
	       DELAY_FR, kind_name[ep.kind], (double)sc_to_float(ep.amplitude), (unsigned)ep.clock_div);
	printf("  \"have_ident\": %s,\n", HAVE_IDENT ? "true" : "false");
	printf("  \"plain_bias_closed_form_pct\": %.4f, \"e_d2\": %.6g, \"e_d_dlag\": %.6g,\n", 100.0 * closed, e_d2,
	       e_ddlag);
	for (int c = 0; c < N_CHECK; c++) {
		printf("  \"t%d\": {\n", (int)(check_frames[c] / RATE_HZ + 0.5));
		printf("    \"seconds\": %.1f,\n", check_frames[c] / RATE_HZ);
		if (HAVE_IDENT)
			acc_print("ident", &ident_a[c], 0);
		acc_print("own", &own_a[c], 0);
		acc_print("plain", &plain_a[c], 1);
		printf("  }%s\n", c + 1 < N_CHECK ? "," : "");
	}
	printf("}\n");
	return 0;
}
