/*
 * motor.c - Monte Carlo of the core's joint rotor-model estimator (firmware/core/motor_id.h)
 * for `make bench`.
 *
 *   bench-motor [RUNS [SEED]]     (default 200 runs, seed 1)
 *
 * Each run draws a vehicle as the flight tests do: k_f, k_tau +/-30 % of the paper's, motor
 * lag 10-100 ms, transport delay 0-3 frames, thrust curve 0-0.5, one rotor at 0.8-1.0;
 * thrust and torque noise 1 % of hover. Eight rotors at the hover throttle, 1 s still (the
 * noise measurement), then the rotor experiment's excitation (experiment.c): two PRBS-like
 * dithers +/-0.04 every 9 frames on the null-space patterns and the offset cycle +/-0.03 on
 * their sum; exact ZOH lag and delay in double precision. The estimator runs for 5 s and for
 * 10 s of excitation (separate runs, each planning its own length).
 * Figures: k_f relative bias and std, and the ratio of its variance to the mean reported sd^2
 * (also of the lag, the curve and the scales)
 * (1 when the sds are honest), with the curve estimated and, on linear rotors, with the curve
 * known (where the reported sd is the least-squares bound of the model); the lag's relative
 * bias and std; how often the delay is chosen right (all runs); the curve's bias and std;
 * how often the run is rejected (cause not OK; the accuracy figures are over the accepted
 * runs, as only those are applied); how often a run is accepted with a wrong delay or a lag
 * more than 5 % off, or with k_f beyond 4 of its reported sds (the silent errors: percent of
 * all runs); and the curve-estimated case once more with another vehicle's lag (85 ms) as the
 * prior of a 10-20 ms one (a parameter file kept across a motor swap); how often the whiteness test of the one-step prediction
 * errors fails on these well-modelled vehicles (its false rejections) and its statistic over
 * its degrees of freedom (1 when white). One JSON object on stdout.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "motor_id.h"

#define NR 8
#define DT (1.0 / 90.0)

static unsigned long long rng_s = 1;
static double urand(void)
{
	rng_s ^= rng_s >> 12;
	rng_s ^= rng_s << 25;
	rng_s ^= rng_s >> 27;
	return (double)((rng_s * 2685821657736338717ULL) >> 11) * (1.0 / 9007199254740992.0);
}
static double uni(double a, double b) { return a + (b - a) * urand(); }
static double gauss(void)
{
	double u = urand(), v = urand();
	return sqrt(-2.0 * log(u > 1e-300 ? u : 1e-300)) * cos(6.283185307179586 * v);
}

struct acc {
	double n, s, s2, sd2, right, rej, white, wq, bad_delay, bad_lag, bad_kf;
};
static void add(struct acc *a, double e, double sd)
{
	a->n++;
	a->s += e;
	a->s2 += e * e;
	a->sd2 += sd * sd;
}
static double mean(const struct acc *a) { return a->n > 0 ? a->s / a->n : 0; }
static double sdev(const struct acc *a)
{
	double m = mean(a);
	return a->n > 1 ? sqrt((a->s2 - a->n * m * m) / (a->n - 1)) : 0;
}

static const double P1[NR] = {1, 0, -1, 0, 1, 0, -1, 0};
static const double P2[NR] = {0, 1, 0, -1, 0, 1, 0, -1};

static bool stale_prior; /* the case of a stale lag prior (main) */

static void one_run(int n_exc, bool est_curve, bool linear, struct acc *kf, struct acc *lag, struct acc *dly,
		    struct acc *crv, struct acc *scl)
{
	double kf_t = 28.0269 * uni(0.7, 1.3), kt_t = 0.3869 * uni(0.7, 1.3), tau = uni(0.01, 0.1);
	if (stale_prior) /* another vehicle's lag as the prior: 85 ms, the truth 10-20 ms */
		tau = uni(0.01, 0.02);
	unsigned delay = (unsigned)uni(0, 3.999);
	double c = linear ? 0.0 : uni(0, 0.5), sc[NR];
	for (int j = 0; j < NR; j++)
		sc[j] = 1.0;
	sc[(int)uni(0, 7.999)] = uni(0.8, 1.0);
	double hf = 2.132 * 9.796 / 8.0, u = hf / kf_t;
	double L = 2.0 * u / ((1.0 - c) + sqrt((1.0 - c) * (1.0 - c) + 4.0 * c * u));
	double sf = 0.01 * hf, st = 0.01 * hf * kt_t / kf_t, a = exp(-DT / tau);
	double s[NR], hist[8][NR], tp[NR], d1 = 0, d2 = 0;
	scalar_t thr0[NR];
	struct motor_id_cfg cfg = {.dt_s = sc_from_float((float)DT),
				   .tau0_s = stale_prior ? 0.085f : 0.03f,
				   .kf0 = 20.0f,
				   .curve0 = 0.0f,
				   .est_curve = est_curve,
				   .n_frames = (uint32_t)n_exc};
	for (int j = 0; j < NR; j++) {
		s[j] = tp[j] = L;
		for (int i = 0; i < 8; i++)
			hist[i][j] = L;
		thr0[j] = sc_from_float((float)L);
	}
	static struct motor_id m;
	motor_id_init(&m, &cfg, thr0);
	for (int k = 0; k < 90 + n_exc; k++) {
		scalar_t tps[NR], f[NR], tq[NR];
		for (int j = 0; j < NR; j++) {
			double g = sc[j] * ((1.0 - c) * s[j] + c * s[j] * s[j]);
			tps[j] = sc_from_float((float)tp[j]);
			f[j] = sc_from_float((float)(kf_t * g + sf * gauss()));
			tq[j] = sc_from_float((float)(kt_t * g + st * gauss()));
		}
		bool exc = k >= 90;
		motor_id_step(&m, tps, f, tq, exc);
		motor_id_refine(&m);
		int ke = k - 90;
		double o = 0.0;
		if (exc) {
			if (ke % 9 == 0) {
				d1 = urand() < 0.5 ? -0.04 : 0.04;
				d2 = urand() < 0.5 ? -0.04 : 0.04;
			}
			static const double lv[4] = {1, 0, -1, 0};
			o = 0.03 * lv[(ke / 45) % 4];
		}
		for (int j = 0; j < NR; j++) {
			double cmd = exc ? L + (d1 + o) * P1[j] + (d2 + o) * P2[j] : L;
			for (int i = (int)delay; i > 0; i--)
				hist[i][j] = hist[i - 1][j];
			hist[0][j] = cmd;
			s[j] = a * s[j] + (1.0 - a) * hist[delay][j];
			tp[j] = cmd;
		}
	}
	struct motor_id_result r;
	motor_id_process(&m);
	motor_id_solve(&m, 1.3f, &r);
	dly->right += r.delay == delay;
	dly->n++;
	dly->white += r.white_have && !r.white_ok;
	dly->wq += r.white_have ? (double)(r.white_q / r.white_dof) : 1.0;
	if (r.cause != MOTOR_ID_OK) { /* rejected: counted, not in the accuracy figures */
		dly->rej++;
		return;
	}
	dly->bad_delay += r.delay != delay;                     /* accepted, yet wrong: */
	dly->bad_lag += fabs((double)r.tau / tau - 1.0) > 0.05; /* the silent errors */
	dly->bad_kf += fabs((double)r.kf - kf_t) > 4.0 * (double)r.kf_sd;
	add(kf, (double)r.kf / kf_t - 1.0, (double)r.kf_sd / kf_t);
	add(lag, (double)r.tau / tau - 1.0, (double)r.tau_sd / tau);
	add(crv, (double)r.curve - c, (double)r.curve_sd);
	for (int j = 0; j < NR; j++)
		add(scl, (double)r.scale[j] / sc[j] - 1.0, (double)r.scale_sd[j] / sc[j]);
}

static void case_json(const char *name, int runs, int n_exc, bool est_curve, bool linear, bool last)
{
	struct acc kf = {0}, lag = {0}, dly = {0}, crv = {0}, scl = {0};
	for (int i = 0; i < runs; i++)
		one_run(n_exc, est_curve, linear, &kf, &lag, &dly, &crv, &scl);
	printf("  \"%s\": {\"seconds\": %g, \"runs\": %d, \"kf_bias_pct\": %.5f, \"kf_std_pct\": %.5f, "
	       "\"kf_var_over_reported\": %.4f, \"lag_bias_pct\": %.4f, \"lag_std_pct\": %.4f, "
	       "\"lag_var_over_reported\": %.4f, \"delay_right_pct\": %.2f, \"curve_bias\": %.5f, "
	       "\"curve_std\": %.5f, \"curve_var_over_reported\": %.4f, \"scale_var_over_reported\": %.4f, "
	       "\"rejected_pct\": %.2f, \"white_rejected_pct\": %.2f, \"white_q_over_dof\": %.3f, "
	       "\"accepted_wrong_delay_pct\": %.2f, \"accepted_lag_off_5pct\": %.2f, \"accepted_kf_over_4sd_pct\": %.2f}%s\n",
	       name, n_exc * DT, runs, 100 * mean(&kf), 100 * sdev(&kf), sdev(&kf) * sdev(&kf) / (kf.sd2 / kf.n),
	       100 * mean(&lag), 100 * sdev(&lag), lag.sd2 > 0 ? sdev(&lag) * sdev(&lag) / (lag.sd2 / lag.n) : 0.0,
	       100 * dly.right / dly.n, mean(&crv), sdev(&crv),
	       crv.sd2 > 0 ? sdev(&crv) * sdev(&crv) / (crv.sd2 / crv.n) : 0.0,
	       scl.sd2 > 0 ? sdev(&scl) * sdev(&scl) / (scl.sd2 / scl.n) : 0.0, 100 * dly.rej / dly.n,
	       100 * dly.white / dly.n, dly.wq / dly.n, 100 * dly.bad_delay / dly.n, 100 * dly.bad_lag / dly.n,
	       100 * dly.bad_kf / dly.n, last ? "" : ",");
}

int main(int argc, char **argv)
{
	int runs = argc > 1 ? atoi(argv[1]) : 200;
	rng_s = argc > 2 ? strtoull(argv[2], NULL, 10) * 2654435761ULL + 1 : 1;
	if (runs < 2) {
		fprintf(stderr, "bench-motor: RUNS must be at least 2 (got %s)\n", argc > 1 ? argv[1] : "?");
		return 2;
	}
	printf("{\n");
	case_json("curve_estimated_5s", runs, 450, true, false, false);
	case_json("curve_estimated_10s", runs, 900, true, false, false);
	case_json("curve_known_linear_5s", runs, 450, false, true, false);
	case_json("curve_known_linear_10s", runs, 900, false, true, false);
	stale_prior = true;
	case_json("stale_prior_10s", runs, 900, true, false, true);
	printf("}\n");
	return 0;
}
