/* test_imu_scale.c - each rotor's effectiveness from the accelerometer and the gyro against
 * the measured rotor speeds (firmware/core/imu_scale.h), on a simulated octocopter: random
 * truth (one or two rotors at 0.8-1.0, the gains 1 / I +/-30 %, k_tau / k_f), the speeds
 * excited by a collective step sequence, the two null-space patterns and an independent
 * differential on every rotor (a closed loop's corrections), each held for 9 frames; the
 * force with white noise, the rates integrated from the torques (trapezoid between frames)
 * with white gyro noise.
 * Build with -DTEST_VERBOSE to print the figures. */
#include "imu_scale.h"
#include "unit.h"

#include <math.h>
#include <string.h>
#ifdef TEST_VERBOSE
#include <stdio.h>
#endif

#define DT (1.0 / 90.0)
#define NR IMU_SCALE_ROTORS
#define W_REF 800.0 /* rad/s at x = 1 */

struct truth {
	double c[NR], scale[NR], speed[NR], gain[3], sig_f, sig_w, ofs;
	float geo[3][NR];
	int n_weak;
};

/* an octocopter on a circle of 0.5 m (rotor j at 45 j degrees plus a random turn), the spin
 * directions alternating, k_tau / k_f 0.014 */
static void random_truth(struct unit_rng *g, struct truth *t, int n_weak)
{
	memset(t, 0, sizeof *t);
	double turn = unit_rand_uniform(g, 0.0, 0.785), kf = 3.5 * unit_rand_uniform(g, 0.7, 1.3);
	for (int j = 0; j < NR; j++) {
		double a = turn + 0.785398 * j;
		t->geo[0][j] = (float)(0.5 * sin(a));
		t->geo[1][j] = (float)(-0.5 * cos(a));
		t->geo[2][j] = (float)(j % 2 ? -0.014 : 0.014);
		t->scale[j] = 1.0;
	}
	for (int k = 0; k < n_weak; k++) {
		int j = (int)unit_rand_uniform(g, 0.0, 7.999);
		t->scale[j] = unit_rand_uniform(g, 0.8, 1.0);
	}
	t->n_weak = n_weak;
	for (int j = 0; j < NR; j++)
		t->speed[j] = 1.0;
	if (n_weak > 1) /* and a motor that turns slower at the same throttle */
		t->speed[(int)unit_rand_uniform(g, 0.0, 7.999)] = unit_rand_uniform(g, 0.85, 1.0);
	for (int j = 0; j < NR; j++)
		t->c[j] = kf * t->scale[j];
	t->gain[0] = 1.0 / (0.0628 * unit_rand_uniform(g, 0.7, 1.3));
	t->gain[1] = 1.0 / (0.0762 * unit_rand_uniform(g, 0.7, 1.3));
	t->gain[2] = 1.0 / (0.1014 * unit_rand_uniform(g, 0.7, 1.3));
	t->sig_f = 0.2;
	t->sig_w = 0.004;
	t->ofs = 0.4;
}

/* the truth's scales over their median (the estimator's normalisation): per w^2, or per
 * throttle (times the speed share) */
static void truth_norm(const struct truth *t, bool per_throttle, double out[NR])
{
	double v[NR], s[NR];
	for (int j = 0; j < NR; j++)
		s[j] = t->scale[j] * (per_throttle ? t->speed[j] : 1.0);
	memcpy(v, s, sizeof v);
	for (int i = 1; i < NR; i++)
		for (int k = i; k > 0 && v[k - 1] > v[k]; k--) {
			double s = v[k];
			v[k] = v[k - 1];
			v[k - 1] = s;
		}
	double med = 0.5 * (v[NR / 2 - 1] + v[NR / 2]);
	for (int j = 0; j < NR; j++)
		out[j] = s[j] / med;
}

static void torques(const struct truth *t, const double x[NR], double tq[3])
{
	for (int i = 0; i < 3; i++) {
		tq[i] = 0.0;
		for (int j = 0; j < NR; j++)
			tq[i] += t->gain[i] * t->geo[i][j] * t->c[j] * x[j];
	}
}

/* The estimator's state (struct imu_scale) is most of the Cortex-M0 image's 16 KB of RAM:
 * its flights run on the host and in the M4F image, and the M0 images leave them out. */
#if defined(__ARM_ARCH_6M__)
#define FLIGHTS 0
#else
#define FLIGHTS 1
#endif

/* n frames of flight into the estimator; lose_at: a frame whose speed reads NaN (-1: none) */
static void fly(struct unit_rng *g, const struct truth *t, unsigned n, bool geometry, int lose_at, bool per_throttle,
		struct imu_scale_result *r)
{
	static struct imu_scale m; /* large: off the stack */
	struct imu_scale_cfg cfg = {.dt_s = (float)DT, .block_frames = 90u, .sd_max = 0.02f};
	if (geometry)
		memcpy(cfg.geo, t->geo, sizeof cfg.geo);
	imu_scale_init(&m, &cfg);
	static const double p1[NR] = {1, 0, -1, 0, 1, 0, -1, 0}, p2[NR] = {0, 1, 0, -1, 0, 1, 0, -1};
	double x[NR], w[3] = {0, 0, 0}, tq_prev[3] = {0, 0, 0}, col = 0.0, d1 = 0.0, d2 = 0.0, dj[NR] = {0};
	for (unsigned k = 0; k < n; k++) {
		if (k % 9u == 0u) { /* new excitation levels, held 9 frames */
			col = (k / 45u) % 4u == 0u ? unit_rand_uniform(g, 0.1, 0.3) : unit_rand_uniform(g, -0.05, 0.05);
			d1 = unit_rand_uniform(g, -0.08, 0.08);
			d2 = unit_rand_uniform(g, -0.08, 0.08);
			for (int j = 0; j < NR; j++)
				dj[j] = unit_rand_uniform(g, -0.02, 0.02);
		}
		float wr[NR];
		scalar_t thr[NR];
		for (int j = 0; j < NR; j++) { /* throttle y, a linear curve: w^2 = W_REF^2 speed_j 2 y */
			double y = 0.5 * (1.0 + col + d1 * p1[j] + d2 * p2[j] + dj[j]);
			thr[j] = sc_from_float((float)y);
			x[j] = 2.0 * y * t->speed[j];
			wr[j] = (float)(W_REF * sqrt(x[j]));
		}
		if ((int)k == lose_at)
			wr[3] = NAN;
		double tq[3], f = t->ofs + t->sig_f * unit_rand_normal(g);
		for (int j = 0; j < NR; j++)
			f += t->c[j] * x[j];
		torques(t, x, tq);
		scalar_t rate[3];
		for (int i = 0; i < 3; i++) {
			if (k > 0u)
				w[i] += 0.5 * DT * (tq[i] + tq_prev[i]);
			tq_prev[i] = tq[i];
			rate[i] = sc_from_float((float)(w[i] + t->sig_w * unit_rand_normal(g)));
		}
		imu_scale_step(&m, thr, wr, sc_from_float((float)f), rate, k > 30u);
		imu_scale_process(&m);
	}
	imu_scale_solve(&m, r);
	if (per_throttle)
		imu_scale_per_throttle(&m, 0.0f, 0.0f, NULL, NULL, r);
}

/* Random vehicles with one or two weak rotors (with two, a motor turning slower too; the
 * scales per w^2 on every third, per throttle on the others): every scale within 1 % and 4
 * of its sds, the sds below 1.5 %, the roll and pitch gains within 2 %; over all the error /
 * sd has an rms in [0.7, 1.4] (a 240-sample rms of a unit normal lies outside with
 * probability below 1e-6). */
UNIT_TEST(imu_scale_random_vehicles)
{
	if (!FLIGHTS)
		return;
	struct unit_rng g = {0x5eed0027ULL};
	double zz = 0.0;
	int nz = 0;
	for (int v = 0; v < TRIALS(30); v++) {
		struct truth t;
		random_truth(&g, &t, 1 + v % 2);
		struct imu_scale_result r;
		fly(&g, &t, 2700u, true, -1, v % 3 != 0, &r);
		CHECK(r.cause == IMU_SCALE_OK);
		double tn[NR];
		truth_norm(&t, v % 3 != 0, tn);
		for (int j = 0; j < NR; j++) {
			double e = r.scale[j] - tn[j];
			CHECK_NEAR(r.scale[j], tn[j], 0.01);
			CHECK(fabs(e) < 4.0 * r.scale_sd[j]);
			CHECK(r.scale_sd[j] > 0.0f && r.scale_sd[j] < 0.015f);
			zz += e * e / ((double)r.scale_sd[j] * r.scale_sd[j]);
			nz++;
		}
		for (int i = 0; i < 2; i++) /* yaw's gain, a nuisance parameter, is the least determined */
			CHECK_REL(r.gain[i], t.gain[i], 0.02);
#ifdef TEST_VERBOSE
		printf("vehicle %d: scales", v);
		for (int j = 0; j < NR; j++)
			printf(" %.4f/%.4f (%.4f)", (double)r.scale[j], tn[j], (double)r.scale_sd[j]);
		printf(" blocks %u iters %u noise %g %g %g %g gains %g/%g %g/%g %g/%g\n", r.blocks, r.iters,
		       (double)r.noise_sd[0], (double)r.noise_sd[1], (double)r.noise_sd[2], (double)r.noise_sd[3],
		       (double)r.gain[0], t.gain[0], (double)r.gain[1], t.gain[1], (double)r.gain[2], t.gain[2]);
#endif
	}
	double rms = sqrt(zz / nz);
#ifdef TEST_VERBOSE
	printf("error / sd rms %.3f over %d\n", rms, nz);
#endif
	if (nz >= 100)
		CHECK(rms > 0.7 && rms < 1.4);
}

/* The force alone (no geometry: no gyro axis) sees the rotors' sum and the null-space
 * patterns' pairs, not each rotor: not separated, and the rotor named. */
UNIT_TEST(imu_scale_force_alone_does_not_separate)
{
	if (!FLIGHTS)
		return;
	struct unit_rng g = {0x5eed0028ULL};
	struct truth t;
	random_truth(&g, &t, 1);
	struct imu_scale_result r;
	fly(&g, &t, 2700u, false, -1, false, &r);
	CHECK(r.cause == IMU_SCALE_NOT_SEPARATED);
	CHECK(r.worst >= 0 && r.worst < NR);
	CHECK(r.scale_sd[r.worst] > 0.02f);
}

/* A speed lost in an excited frame, too few frames: named, no scales. */
UNIT_TEST(imu_scale_causes)
{
	if (!FLIGHTS)
		return;
	struct unit_rng g = {0x5eed0029ULL};
	struct truth t;
	random_truth(&g, &t, 1);
	struct imu_scale_result r;
	fly(&g, &t, 2700u, true, 500, false, &r);
	CHECK(r.cause == IMU_SCALE_SPEED_LOST);
	fly(&g, &t, 60u, true, -1, false, &r);
	CHECK(r.cause == IMU_SCALE_NO_DATA);
	CHECK(imu_scale_cause_text(IMU_SCALE_NOT_SEPARATED)[0] != '?');
}

/* The ratio's sd: a quantity that goes with the scales' sum has the sum's relative sd, one
 * over the same weights has none, and the sd follows the covariance the result carries. */
UNIT_TEST(imu_scale_ratio_sd)
{
	if (!FLIGHTS)
		return;
	struct unit_rng g = {0x5eed002aULL};
	struct truth t;
	random_truth(&g, &t, 2);
	struct imu_scale_result r;
	fly(&g, &t, 2700u, true, -1, false, &r);
	CHECK(r.cause == IMU_SCALE_OK);
	float one[NR], sum = 0.0f;
	double vw = 0.0, vc = 0.0;
	for (int j = 0; j < NR; j++) {
		one[j] = 1.0f;
		sum += r.scale[j];
	}
	for (int i = 0; i < NR; i++)
		for (int k = 0; k < NR; k++) {
			vw += r.cov_w[i][k];
			vc += r.cov_c[i][k];
		}
	double want = sqrt(vw > vc ? vw : vc) / sum;
	CHECK_REL(imu_scale_ratio_rsd(&r, one, NULL), want, 1e-4);
	CHECK_NEAR(imu_scale_ratio_rsd(&r, one, one), 0.0, 1e-6);
	CHECK(imu_scale_ratio_rsd(&r, one, NULL) > 0.0f);
}
