/* Tests of firmware/core/kf_track.h: a thrust coefficient drifting like a sagging battery
 * (random rate 0 ... -4 %/min, plus a -3 % step at a random time), 8 rotors in hover with
 * small random throttle motion through a first-order motor lag, per-rotor thrust noise
 * 0.5 ... 1.5 % of the hover thrust (random). The estimate is compared with the truth at
 * the same time. */
#include "unit_scalar.h"
#include "kf_track.h"
#include "unit.h"

#include <math.h>
#ifdef TEST_VERBOSE
#include <stdio.h>
#endif

#define FS 90.0
#define NR 8

static scalar_t s(double x) { return sc_from_float((float)x); }

/* One frame of the test plant: eight rotors through a first-order lag (coefficient al) at
 * thrust coefficient kf, white thrust noise of noise kf0 u_h per rotor; the tracker takes the
 * frame, and the next commands are drawn 3 % about the hover throttle u_h. */
static void plant_frame(struct kf_track *kt, struct unit_rng *r, double lag[NR], double thr[NR], double al, double kf,
			double kf0, double u_h, double noise, double dt)
{
	double y = 0;
	scalar_t th[NR];
	for (int j = 0; j < NR; j++) {
		lag[j] += al * (thr[j] - lag[j]);
		y += kf * lag[j] + noise * kf0 * u_h * unit_rand_normal(r);
		th[j] = s(thr[j]);
	}
	kf_track_update(kt, th, NR, s(y), s(dt), true);
	for (int j = 0; j < NR; j++)
		thr[j] = u_h * (1 + 0.03 * unit_rand_normal(r));
}

/* After 5 s, outside the 3 T* that follow the step: within 0.3 % of the truth at the same
 * time; the error within 5 reported sd most of the time; the memory near the formula's. */
UNIT_TEST(kf_track_follows_drift_and_step)
{
	struct unit_rng r = {0x6b66ULL};
	for (int trial = 0; trial < TRIALS(12); trial++) {
		double kf0 = unit_rand_uniform(&r, 5.0, 60.0), u_h = unit_rand_uniform(&r, 0.05, 0.5);
		double rate = unit_rand_uniform(&r, -0.04, 0.0); /* per minute */
		double t_step = unit_rand_uniform(&r, 20.0, 60.0), noise = unit_rand_uniform(&r, 0.005, 0.015);
		double tau = unit_rand_uniform(&r, 0.01, 0.05);
		struct kf_track_params p = kf_track_params_default();
		p.drift_per_min = SC(0.04);
		p.tau_lag_s = s(tau);
		struct kf_track kt;
		kf_track_init(&kt, &p, s(kf0 * 0.8));
		double al = 1 - exp(-1.0 / (FS * tau)), lag[NR], thr[NR] = {0}, dt = 1.0 / FS, worst = 0, sum2 = 0,
		       mem = 0, t_worst = 0;
		int n = 0, outside = 0;
		for (int j = 0; j < NR; j++)
			lag[j] = thr[j] = u_h; /* in hover when tracking starts */
		for (int k = 0; k < (int)(90.0 * FS); k++) {
			double t = k * dt;
			double kf = kf0 * (1 + rate * t / 60.0) * (t >= t_step ? 0.97 : 1.0);
			/* this frame's thrust answers the command sent last frame, through the lag */
			plant_frame(&kt, &r, lag, thr, al, kf, kf0, u_h, noise, dt);
			double est = d(kt.k), err = est / kf - 1;
			if (t > 5.0 && !(t >= t_step && t < t_step + 3 * d(kt.mem_s) + 0.5)) {
				if (fabs(err) > worst)
					t_worst = t;
				worst = fmax(worst, fabs(err));
				sum2 += err * err;
				n++;
				if (fabs(est - kf) > 5 * d(kf_track_sd(&kt)))
					outside++;
				mem = d(kt.mem_s);
			}
		}
		/* the formula's memory for this noise: s = noise sqrt(8) u_h kf0 / (8 u_h kf0) */
		double s_rel = noise / sqrt(8.0), r_rel = 0.04 / 60;
		double t_star = cbrt(s_rel * s_rel / (4 * r_rel * r_rel * FS));
#ifdef TEST_VERBOSE
		printf("step at %.1f s, worst at %.2f s: ", t_step, t_worst);
		printf("kf %.1f u_h %.2f rate %.1f %%/min noise %.1f %%: worst %.3f %% rms %.3f %% mem %.2f s "
		       "(formula %.2f) outside 5 sd %.2f %%\n",
		       kf0, u_h, 100 * rate, 100 * noise, 100 * worst, 100 * sqrt(sum2 / n), mem, t_star,
		       100.0 * outside / n);
#endif
		(void)t_worst;
		CHECK(worst < 0.003);
		CHECK(outside < n / 100);
		CHECK(mem > 0.7 * t_star && mem < 1.4 * t_star);
	}
}

/* A drift within the bound (-1 ... -2 %/min, KFT_DRIFT 2 %/min), thrust noise 0.5 ... 1.5 %:
 * an exponential memory's estimate (kr) lags it by one memory T*, an error of the sign of
 * the drift's and the size of the rate times T*, the same on every sample. k is corrected
 * for it: from 30 s (after the first long windows) its mean error over the trials is within
 * a fifth of that lag (kr's is the lag), and its error over the reported sd has a mean
 * within +/- 0.3 (kr's near +1). */
UNIT_TEST(kf_track_no_lag_behind_a_drift)
{
	struct unit_rng r = {0x6b68ULL};
	double zsum = 0, e_all = 0, lag_all = 0, er_all = 0;
	int zn = 0;
	for (int trial = 0; trial < TRIALS(12); trial++) {
		double kf0 = unit_rand_uniform(&r, 5.0, 60.0), u_h = unit_rand_uniform(&r, 0.05, 0.5);
		double rate = unit_rand_uniform(&r, -0.02, -0.01), noise = unit_rand_uniform(&r, 0.005, 0.015);
		struct kf_track_params p = kf_track_params_default();
		p.tau_lag_s = SC(0.03);
		struct kf_track kt;
		kf_track_init(&kt, &p, s(kf0));
		double al = 1 - exp(-1.0 / (FS * 0.03)), lag[NR], thr[NR], dt = 1.0 / FS, esum = 0, lagsum = 0,
		       ersum = 0;
		int n = 0;
		for (int j = 0; j < NR; j++)
			lag[j] = thr[j] = u_h;
		for (int k = 0; k < (int)(120.0 * FS); k++) {
			double t = k * dt, kf = kf0 * (1 + rate * t / 60.0);
			plant_frame(&kt, &r, lag, thr, al, kf, kf0, u_h, noise, dt);
			if (t > 30.0 && k % 9 == 0) {
				esum += d(kt.k) / kf - 1;
				ersum += d(kt.kr) / kf - 1;
				lagsum += -rate / 60.0 * d(kt.mem_s);
				zsum += (d(kt.k) - kf) / d(kf_track_sd(&kt));
				n++;
				zn++;
			}
		}
#ifdef TEST_VERBOSE
		printf("rate %.2f %%/min noise %.2f %%: mean error %+.4f %% (kr %+.4f %%), lag of one memory %.4f %%\n",
		       100 * rate, 100 * noise, 100 * esum / n, 100 * ersum / n, 100 * lagsum / n);
#endif
		e_all += esum / n;
		er_all += ersum / n;
		lag_all += lagsum / n;
	}
#ifdef TEST_VERBOSE
	printf("mean error %+.4f %% (kr %+.4f %%), lag %.4f %%, mean z %+.3f\n", 100 * e_all / TRIALS(12),
	       100 * er_all / TRIALS(12), 100 * lag_all / TRIALS(12), zsum / zn);
#endif
	(void)er_all;
	CHECK(fabs(e_all) < 0.2 * lag_all);
	CHECK(fabs(zsum / zn) < 0.3);
}

/* No wind-up: 120 s gated off (on the ground) and 120 s with throttles below phi_min
 * leave P bounded and the estimate where it was; tracking resumes at once. */
UNIT_TEST(kf_track_no_windup_without_excitation)
{
	struct kf_track_params p = kf_track_params_default();
	struct kf_track kt;
	kf_track_init(&kt, &p, SC(20.0));
	/* the plant: 8 rotors through the same 30 ms lag as the tracker assumes */
	double lagged = 0.1, kf = 25.0, dt = 1 / FS, al = 1 - exp(-dt / 0.03);
	scalar_t th[NR];
	int ok_gated = 1;
	for (int phase = 0; phase < 4; phase++) {
		double thr = phase == 2 ? 0.005 : 0.1, secs = phase == 0 || phase == 3 ? 10.0 : 120.0;
		if (phase == 3)
			kf = 24.0;
		for (int j = 0; j < NR; j++)
			th[j] = s(thr);
		for (int k = 0; k < (int)(secs * FS); k++) {
			lagged += al * (thr - lagged);
			bool used = kf_track_update(&kt, th, NR, s(8 * lagged * kf), s(dt), phase != 1);
			if (phase == 1 && used)
				ok_gated = 0;
		}
		if (phase == 0)
			CHECK_REL(d(kt.k), 25.0, 1e-3);
		if (phase == 2) {
			CHECK_REL(d(kt.k), 25.0, 1e-3);
			CHECK(d(kt.P) <= d(sc_div(sc_div(s(dt), p.t_min_s), s(0.8 * 0.8))) * 1.01);
		}
	}
	CHECK(ok_gated);
	CHECK_REL(d(kt.k), 24.0, 1e-3);
}

/* The rotor model counts: rotors with a random thrust curve (0.1-0.5) and one weak rotor
 * (0.8-0.95), constant k_f. A tracker told the curve and the scales ends within 0.3 % of the
 * truth; one that assumes linear, equal rotors is off by more (what a stale model would
 * make it "refresh" VEH_KF with). */
UNIT_TEST(kf_track_uses_curve_and_rotor_scales)
{
	struct unit_rng r = {0x5ca1eULL};
	for (int trial = 0; trial < TRIALS(8); trial++) {
		double kf = unit_rand_uniform(&r, 5.0, 60.0), u_h = unit_rand_uniform(&r, 0.05, 0.4);
		double c = unit_rand_uniform(&r, 0.1, 0.5), tau = unit_rand_uniform(&r, 0.01, 0.05);
		double sc[NR];
		for (int j = 0; j < NR; j++)
			sc[j] = 1.0;
		sc[(int)unit_rand_uniform(&r, 0.0, 7.999)] = unit_rand_uniform(&r, 0.8, 0.95);
		struct kf_track_params p = kf_track_params_default(), q = p;
		p.tau_lag_s = q.tau_lag_s = s(tau);
		p.curve = s(c);
		for (int j = 0; j < NR; j++)
			p.scale[j] = s(sc[j]);
		struct kf_track told, naive;
		kf_track_init(&told, &p, s(kf * 0.8));
		kf_track_init(&naive, &q, s(kf * 0.8));
		double al = 1 - exp(-1.0 / (FS * tau)), lag[NR], thr[NR], dt = 1.0 / FS;
		for (int j = 0; j < NR; j++)
			lag[j] = thr[j] = u_h;
		for (int k = 0; k < (int)(30.0 * FS); k++) {
			double y = 0;
			scalar_t th[NR];
			for (int j = 0; j < NR; j++) {
				lag[j] += al * (thr[j] - lag[j]);
				y += kf * sc[j] * ((1 - c) * lag[j] + c * lag[j] * lag[j]) +
				     0.005 * kf * u_h * unit_rand_normal(&r);
				th[j] = s(thr[j]);
			}
			kf_track_update(&told, th, NR, s(y), s(dt), true);
			kf_track_update(&naive, th, NR, s(y), s(dt), true);
			for (int j = 0; j < NR; j++)
				thr[j] = u_h * (1 + 0.03 * unit_rand_normal(&r));
		}
		CHECK(fabs(d(told.k) / kf - 1) < 0.003);
		CHECK(fabs(d(naive.k) / kf - 1) > 0.003);
	}
}

/* The accelerometer's rig: the tracker on 9-frame means (its memory at least 1 s), the rotors
 * following throttles jittered by 1 % about u_h through a 30 ms lag. */
struct imu_rig {
	struct kf_track kt;
	double dt, al, u_h, lag[NR], thr[NR];
};

static void imu_rig_init(struct imu_rig *g, double kf0, double u_h)
{
	struct kf_track_params p = kf_track_params_default();
	p.avg_n = 9;
	p.t_min_s = SC(1.0);
	kf_track_init(&g->kt, &p, s(kf0));
	g->dt = 1.0 / FS;
	g->al = 1 - exp(-g->dt / 0.03);
	g->u_h = u_h;
	for (int j = 0; j < NR; j++)
		g->lag[j] = g->thr[j] = u_h;
}

/* One frame at k_f kf: the thrust measured times 1 + mod, with 0.2 % of white noise. */
static void imu_rig_frame(struct imu_rig *g, struct unit_rng *r, double kf, double mod)
{
	double y = 0;
	scalar_t th[NR];
	for (int j = 0; j < NR; j++) {
		g->lag[j] += g->al * (g->thr[j] - g->lag[j]);
		y += kf * g->lag[j];
		th[j] = s(g->thr[j]);
	}
	y *= 1 + mod + 0.002 * unit_rand_normal(r);
	kf_track_update(&g->kt, th, NR, s(y), s(g->dt), true);
	for (int j = 0; j < NR; j++)
		g->thr[j] = g->u_h * (1 + 0.01 * unit_rand_normal(r));
}

/* An accelerometer's total thrust m a_z: per-frame noise mostly near half the frame rate (a
 * rotor's vibration folded to 40-45 Hz, 2-3 % of y) plus a slow fold (a rotor turning near
 * the frame rate: 0.1-0.5 Hz, 0-0.7 % of y), k_f drifting 0 ... -3 %/min. The tracker on 9-frame
 * means: after 30 s (its first windows are long while the memory settles), the error over the reported sd has an rms within [0.5, 1.5] and stays
 * within 4 sd; with a slow fold of 0.5 % or more the sd is at least a quarter of the fold
 * (the differences alone would report about a tenth of it). */
UNIT_TEST(kf_track_coloured_noise_sd)
{
	struct unit_rng r = {0x6b67ULL};
	double z2 = 0;
	int n = 0, outside = 0;
	for (int trial = 0; trial < TRIALS(12); trial++) {
		double kf0 = unit_rand_uniform(&r, 5.0, 60.0), u_h = unit_rand_uniform(&r, 0.06, 0.4);
		double rate = unit_rand_uniform(&r, -0.03, 0.0), fast = unit_rand_uniform(&r, 0.02, 0.03);
		double f_fast = unit_rand_uniform(&r, 40.0, 45.0), f_slow = unit_rand_uniform(&r, 0.1, 0.5);
		double a_slow = unit_rand_uniform(&r, 0.0, 0.007), ph = unit_rand_uniform(&r, 0.0, 6.283);
		struct imu_rig g;
		struct kf_track *const kt = &g.kt;
		imu_rig_init(&g, kf0, u_h);
		double sd_min = 1.0;
		for (int k = 0; k < (int)(90.0 * FS); k++) {
			double t = k * g.dt, kf = kf0 * (1 + rate * t / 60.0);
			imu_rig_frame(&g, &r, kf,
				      fast * sin(6.283185 * f_fast * t + ph) +
					      a_slow * sin(6.283185 * f_slow * t + 2 * ph));
			if (t > 30.0 && k % 45 == 0) {
				double sd = d(kf_track_sd(kt)), z = (d(kt->k) - kf) / sd;
				z2 += z * z;
				n++;
				outside += fabs(z) > 4.0;
				sd_min = fmin(sd_min, sd / kf);
#ifdef TEST_VERBOSE
				if (fabs(z) > 3.0 || sd / kf < 0.2 * a_slow)
					printf("  trial %d t %.1f z %+.2f err %+.3f %% sd %.3f %% mem %.2f w_count %u\n",
					       trial, t, z, 100 * (d(kt->k) / kf - 1), 100 * sd / kf, d(kt->mem_s),
					       (unsigned)kt->w_count);
#endif
			}
		}
#ifdef TEST_VERBOSE
		printf("kf %.1f u_h %.2f rate %.1f %%/min fold %.2f %% at %.2f Hz: sd >= %.3f %%\n", kf0, u_h,
		       100 * rate, 100 * a_slow, f_slow, 100 * sd_min);
#endif
		if (a_slow >= 0.005)
			CHECK(sd_min > 0.25 * a_slow);
	}
#ifdef TEST_VERBOSE
	printf("rms z %.3f over %d, %d beyond 4 sd\n", sqrt(z2 / n), n, outside);
#endif
	CHECK(sqrt(z2 / n) > 0.5 && sqrt(z2 / n) < 1.5);
	CHECK(outside == 0);
}

/* A fold slower than the long window (a rotor turning within a few hundredths of a hertz of
 * the frame rate): the accelerometer's y carries a sinusoid of 0.5-1.5 % and a period of
 * 20-40 s, beside 0.2 % of white noise per frame; k_f drifts 0 ... -2 %/min (within the
 * bound); the tracker on 9-frame means, its memory at its 1 s bound. k swings with the fold
 * by nearly its amplitude, and only the slow part of the sd (kr about its line over some
 * KF_TRACK_H_MEM windows) sees it: once the tracker has seen a period (from 50 s), every
 * sample's error is within 3.5 of its sd, their rms within [0.4, 1.2], and the sd at most
 * 1.2 times the fold's amplitude (the sinusoid's rms is 0.71 of it). Without the slow part
 * the rms is about 5. */
UNIT_TEST(kf_track_slow_fold_sd)
{
	struct unit_rng r = {0x5f01dULL};
	double z2 = 0, worst = 0, sd_over_a = 0;
	int n = 0;
	for (int trial = 0; trial < TRIALS(12); trial++) {
		double kf0 = unit_rand_uniform(&r, 5.0, 60.0), u_h = unit_rand_uniform(&r, 0.06, 0.4);
		double rate = unit_rand_uniform(&r, -0.02, 0.0), a = unit_rand_uniform(&r, 0.005, 0.015);
		double period = unit_rand_uniform(&r, 20.0, 40.0), ph = unit_rand_uniform(&r, 0.0, 6.283);
		struct imu_rig g;
		struct kf_track *const kt = &g.kt;
		imu_rig_init(&g, kf0, u_h);
		for (int k = 0; k < (int)(120.0 * FS); k++) {
			double t = k * g.dt, kf = kf0 * (1 + rate * t / 60.0);
			imu_rig_frame(&g, &r, kf, a * sin(6.283185 * t / period + ph));
			if (t > 50.0 && k % 45 == 0) {
				double sd = d(kf_track_sd(kt)), z = (d(kt->k) - kf) / sd;
				z2 += z * z;
				n++;
				worst = fmax(worst, fabs(z));
				sd_over_a = fmax(sd_over_a, sd / kf / a);
			}
		}
	}
#ifdef TEST_VERBOSE
	printf("slow fold: rms z %.3f over %d, largest |z| %.2f, sd at most %.2f of the amplitude\n", sqrt(z2 / n), n,
	       worst, sd_over_a);
#endif
	CHECK(worst < 3.5);
	CHECK(sqrt(z2 / n) > 0.4 && sqrt(z2 / n) < 1.2);
	CHECK(sd_over_a < 1.2);
}

/* A drift far beyond the one T* was sized for (k_f falling 20 %/min with the memory held at
 * 10 s: 3 % per window) keeps the slow part's sums in the fixed build's range (they start
 * again rather than saturate): its sum of squares stays below a quarter of the range; after
 * the first minute its sd is below 1 % (the drift is a line, which it takes out) and the
 * published sd covers the error (mostly the lag a 10 s memory leaves, which the long
 * windows carry). */
UNIT_TEST(kf_track_slow_part_under_a_fast_drift)
{
	struct kf_track_params p = kf_track_params_default();
	p.t_min_s = SC(10.0);
	struct kf_track kt;
	kf_track_init(&kt, &p, SC(20.0));
	struct unit_rng r = {0xfa57ULL};
	double dt = 1.0 / FS, u_h = 0.2, scc = 0, h_sd = 0;
	scalar_t th[NR];
	for (int j = 0; j < NR; j++)
		th[j] = s(u_h);
	int covered = 1;
	for (int k = 0; k < (int)(180.0 * FS); k++) {
		double t = k * dt, kf = 20.0 * (1 - 0.2 * t / 60.0);
		double y = 8 * kf * u_h * (1 + 0.002 * unit_rand_normal(&r));
		kf_track_update(&kt, th, NR, s(y), s(dt), true);
		scc = fmax(scc, d(kt.h_scc));
		if (t > 60.0 && k % 90 == 0) {
			h_sd = fmax(h_sd, sqrt(d(kt.h_var_pct2)));
			covered &= fabs(d(kt.k) - kf) < 3 * d(kf_track_sd(&kt));
		}
	}
#ifdef TEST_VERBOSE
	printf("fast drift: slow part's sum of squares at most %.0f, its sd at most %.3f %%\n", scc, h_sd);
#endif
	CHECK(scc < 8192.0);
	CHECK(h_sd < 1.0);
	CHECK(covered);
}
