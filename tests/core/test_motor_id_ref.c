/* test_motor_id_ref.c - the joint rotor-model estimator (motor_id.h) of this build (float, or
 * integers on the 90 Hz path in the fixed build) against its float64 build
 * (test_motor_id_ref64.c) on identical inputs: random vehicles (delay 0-3 frames, lag
 * 10-100 ms, curve 0-0.5, one rotor at 0.8-1.0, k_f and k_tau +/-30 %), the same quantised
 * commands, thrusts and torques fed to both. k_f, k_tau, the lag, the curve and the scales
 * agree within 0.02 %, the delay and the acceptance exactly.
 * Then the long runs: inputs at the ends of their formats for many frames (no sum wraps, the
 * result is a rejection), and a long excited run past the whiteness series' capacity.
 * Build with -DTEST_VERBOSE to print the figures. */
#include "motor_id.h"
#include "motor_id_q.h"
#include "motor_id_ref64.h"
#include "unit.h"

#include <math.h>
#ifdef TEST_VERBOSE
#include <stdio.h>
#endif

#define DT (1.0 / 90.0)
#define NR 8
#define REL_BOUND 2e-4 /* 0.02 % */

static double g_curve(double c, double x) { return (1.0 - c) * x + c * x * x; }
static const double P1[NR] = {1, 0, -1, 0, 1, 0, -1, 0};
static const double P2[NR] = {0, 1, 0, -1, 0, 1, 0, -1};

struct vehicle {
	double kf, ktau, tau, curve, scale[NR], sig_f, sig_t, L;
	unsigned delay;
};

static inline void random_vehicle(struct unit_rng *g, struct vehicle *v)
{
	v->kf = 28.0269 * unit_rand_uniform(g, 0.7, 1.3);
	v->ktau = 0.3869 * unit_rand_uniform(g, 0.7, 1.3);
	v->tau = unit_rand_uniform(g, 0.010, 0.100);
	v->delay = (unsigned)unit_rand_uniform(g, 0.0, 3.999);
	v->curve = unit_rand_uniform(g, 0.0, 0.5);
	for (int j = 0; j < NR; j++)
		v->scale[j] = 1.0;
	v->scale[(int)unit_rand_uniform(g, 0.0, 7.999)] = unit_rand_uniform(g, 0.8, 1.0);
	double hf = 2.132 * 9.796 / 8.0, uu = hf / v->kf, c = v->curve;
	v->sig_f = 0.01 * hf;
	v->sig_t = 0.01 * hf * v->ktau / v->kf;
	v->L = 2.0 * uu / ((1.0 - c) + sqrt((1.0 - c) * (1.0 - c) + 4.0 * c * uu));
}

/* One experiment (settle frames still, then n excited frames) fed to this build's estimator m
 * and, if ref, to the float64 one (the same scalar_t inputs, as double) */
static inline void experiment(struct unit_rng *g, const struct vehicle *v, int settle, int n, double kf0, bool ref,
			      struct motor_id *m, struct motor_id_result *res, struct mid64_res *r64)
{
	double a = exp(-DT / v->tau), st[NR], hist[8][NR], tprev[NR], d1 = 0, d2 = 0;
	for (int j = 0; j < NR; j++) {
		st[j] = tprev[j] = v->L;
		for (int i = 0; i < 8; i++)
			hist[i][j] = v->L;
	}
	scalar_t dt = sc_from_float((float)DT), thr0[NR];
	struct motor_id_cfg cfg = {.dt_s = dt,
				   .tau0_s = 0.03f,
				   .kf0 = (float)kf0,
				   .curve0 = 0.0f,
				   .est_curve = true,
				   .n_frames = (uint32_t)n};
	double thr0d[NR];
	for (int j = 0; j < NR; j++) {
		thr0[j] = sc_from_float((float)v->L);
		thr0d[j] = (double)sc_to_float(thr0[j]);
	}
	motor_id_init(m, &cfg, thr0);
#if MID64_HAVE
	struct mid64_cfg c64 = {.dt_s = (double)sc_to_float(dt),
				.tau0_s = 0.03,
				.kf0 = (double)(float)kf0,
				.curve0 = 0.0,
				.est_curve = true,
				.n_frames = (uint32_t)n};
	if (ref)
		mid64_init(&c64, thr0d);
#else
	(void)ref;
	(void)thr0d;
	(void)r64;
#endif
	for (int k = 0; k < settle + n; k++) {
		scalar_t tp[NR], f[NR], tq[NR];
		double tpd[NR], fd[NR], tqd[NR];
		for (int j = 0; j < NR; j++) {
			double gg = v->scale[j] * g_curve(v->curve, st[j]);
			tp[j] = sc_from_float((float)tprev[j]);
			f[j] = sc_from_float((float)(v->kf * gg + v->sig_f * unit_rand_normal(g)));
			tq[j] = sc_from_float((float)(v->ktau * gg + v->sig_t * unit_rand_normal(g)));
			tpd[j] = (double)sc_to_float(tp[j]);
			fd[j] = (double)sc_to_float(f[j]);
			tqd[j] = (double)sc_to_float(tq[j]);
		}
		bool exc = k >= settle;
		motor_id_step(m, tp, f, tq, exc);
		motor_id_refine(m);
#if MID64_HAVE
		if (ref) {
			mid64_step(tpd, fd, tqd, exc);
			mid64_refine();
		}
#else
		(void)tpd;
		(void)fd;
		(void)tqd;
#endif
		int ke = k - settle;
		double o = 0.0;
		if (exc) {
			if (ke % 9 == 0) {
				d1 = unit_rand_uniform(g, 0, 1) < 0.5 ? -0.04 : 0.04;
				d2 = unit_rand_uniform(g, 0, 1) < 0.5 ? -0.04 : 0.04;
			}
			static const double lv[4] = {1, 0, -1, 0};
			o = 0.03 * lv[(ke / 45) % 4];
		}
		for (int j = 0; j < NR; j++) {
			double cmd = exc ? v->L + (d1 + o) * P1[j] + (d2 + o) * P2[j] : v->L;
			for (int i = (int)v->delay; i > 0; i--)
				hist[i][j] = hist[i - 1][j];
			hist[0][j] = cmd;
			st[j] = a * st[j] + (1.0 - a) * hist[v->delay][j];
			tprev[j] = cmd;
		}
	}
	motor_id_process(m);
	motor_id_solve(m, 1.3f, res);
#if MID64_HAVE
	if (ref)
		mid64_solve(1.3, r64);
#endif
}

static inline double rel(double a, double b) { return fabs(a / b - 1.0); }

/* this build against float64 over random vehicles, 5 s and 10 s of excitation */
UNIT_TEST(motor_id_ref_float64_random_vehicles)
{
#if MID64_HAVE
	struct unit_rng g = {0x3d1dULL};
	/* worst and rms differences: k_f, k_tau, lag (relative), curve, scales (absolute) */
	double worst[5] = {0, 0, 0, 0, 0}, ss[5] = {0, 0, 0, 0, 0};
	int n_cmp = 0, n_acc = 0;
	const int runs = TRIALS(24);
	for (int run = 0; run < runs; run++) {
		struct vehicle v;
		random_vehicle(&g, &v);
		struct motor_id m;
		struct motor_id_result r;
		struct mid64_res r64;
		experiment(&g, &v, 90, run % 2 ? 900 : 450, 28.0269, true, &m, &r, &r64);
		CHECK(r.delay == r64.delay);
		CHECK(r.free_delay == r64.free_delay);
		CHECK((int)r.cause == r64.cause);
		if (r.delay != r64.delay || r64.tau <= 0.0)
			continue;
		double e[5] = {rel(r.kf, r64.kf), rel(r.ktau, r64.ktau), rel(r.tau, r64.tau), fabs(r.curve - r64.curve),
			       0.0};
		for (int j = 0; j < NR; j++)
			e[4] = fmax(e[4], fabs(r.scale[j] - r64.scale[j]));
		for (int i = 0; i < 5; i++) {
			worst[i] = fmax(worst[i], e[i]);
			ss[i] += e[i] * e[i];
		}
		n_cmp++;
		if (r64.cause == 0) {
			n_acc++;
			/* the reference itself found the vehicle (the experiment is informative) */
			CHECK_REL(r64.kf, v.kf, 0.01);
			CHECK_REL(r64.tau, v.tau, 0.1);
			CHECK(r64.delay == v.delay);
		}
#ifdef TEST_VERBOSE
		printf("  run %2d n %d: D %u/%u cause %d/%d kf %.6f/%.6f tau %.6f/%.6f c %.5f/%.5f "
		       "diff kf %.2e ktau %.2e lag %.2e curve %.2e scale %.2e\n",
		       run, run % 2 ? 900 : 450, r.delay, r64.delay, (int)r.cause, r64.cause, (double)r.kf, r64.kf,
		       (double)r.tau, r64.tau, (double)r.curve, r64.curve, e[0], e[1], e[2], e[3], e[4]);
#endif
	}
	CHECK(n_cmp >= runs - 1);
	CHECK(n_acc >= runs / 2);
	for (int i = 0; i < 5; i++)
		ss[i] = n_cmp > 0 ? sqrt(ss[i] / n_cmp) : 0.0;
#ifdef TEST_VERBOSE
	printf("  %d compared (%d accepted): max kf %.2e ktau %.2e lag %.2e curve %.2e scale %.2e; "
	       "rms kf %.2e ktau %.2e lag %.2e curve %.2e scale %.2e\n",
	       n_cmp, n_acc, worst[0], worst[1], worst[2], worst[3], worst[4], ss[0], ss[1], ss[2], ss[3], ss[4]);
#endif
	if (!(worst[0] < REL_BOUND && worst[1] < REL_BOUND && worst[2] < REL_BOUND && worst[3] < REL_BOUND &&
	      worst[4] < REL_BOUND))
		unit_fail(u, __FILE__, __LINE__,
			  "worst differences to float64: k_f %.2e, k_tau %.2e, lag %.2e, curve %.2e, scales %.2e",
			  worst[0], worst[1], worst[2], worst[3], worst[4]);
#else
	(void)u;
#endif
}

/* the value of a sum of kind k (float build: itself) */
static double sumv(const struct motor_id *m, motor_id_sum_t v, unsigned k, int p)
{
	return (double)mid_sum_to_float(v, m->e[k], p, m->kexp);
}

/* Inputs at the ends of their formats (thrusts and torques at +/-30000 in turn, throttles 0
 * and 1) for many frames, still then excited: the sums of squares never go negative or
 * shrink within a stage (no wrap), and the result is a rejection, not an estimate. */
UNIT_TEST(motor_id_extreme_inputs_never_wrap)
{
	struct motor_id m;
	struct motor_id_cfg cfg = {
		.dt_s = sc_from_float((float)DT), .tau0_s = 0.03f, .kf0 = 28.0f, .est_curve = true, .n_frames = 3000};
	scalar_t thr0[NR];
	for (int j = 0; j < NR; j++)
		thr0[j] = sc_from_float(0.4f);
	motor_id_init(&m, &cfg, thr0);
	const int still = 500, n = TRIALS(6) > 2 ? 6000 : 1200;
	double prev_rr = 0.0, prev_nz = 0.0, prev_ff = 0.0;
	uint32_t prev_stat = 0;
	bool ok = true;
	for (int k = 0; k < still + n; k++) {
		scalar_t tp[NR], f[NR], tq[NR];
		for (int j = 0; j < NR; j++) {
			bool hi = ((k + j) & 1) != 0;
			tp[j] = sc_from_float(hi ? 1.0f : 0.0f);
			f[j] = sc_from_float(hi ? 30000.0f : -30000.0f);
			tq[j] = sc_from_float(hi ? -30000.0f : 30000.0f);
		}
		motor_id_step(&m, tp, f, tq, k >= still);
		motor_id_refine(&m);
		double rr = sumv(&m, m.st[1][1][3].rr, MID_E_RR, 2), nz = sumv(&m, m.nz_ss, MID_E_NZ, 2),
		       ff = sumv(&m, m.ff, MID_E_FF, 2), g11 = sumv(&m, m.st[4][2][7].g11, MID_E_G11, 0);
		bool restarted = m.n_stat < prev_stat;
		/* halving rounds: a sum may lose a part in 2^28 */
		if (rr < 0.0 || nz < 0.0 || ff < 0.0 || g11 < 0.0 || nz < prev_nz * (1.0 - 1e-8) ||
		    ff < prev_ff * (1.0 - 1e-8) || (!restarted && rr < prev_rr * (1.0 - 1e-8)))
			ok = false;
		prev_rr = rr;
		prev_nz = nz;
		prev_ff = ff;
		prev_stat = m.n_stat;
	}
	CHECK(ok);
	CHECK(prev_nz > 0.0 && prev_ff > 0.0 && prev_rr > 0.0);
	struct motor_id_result r;
	motor_id_process(&m);
	motor_id_solve(&m, 1.3f, &r);
	CHECK(r.cause != MOTOR_ID_OK);
}

/* A long run: 5 min still (the noise sums), then 2 h of excitation (past the whiteness
 * series' 65535 frames): the estimates still find the vehicle and, in the fixed build, agree
 * with float64 within 0.02 % (the float build's float32 sums of 5e6 torque terms drift: its
 * k_tau is 2.4e-3 off float64 here). Host only: on emulated Cortex-M it would take hours. */
UNIT_TEST(motor_id_long_run_holds)
{
#if defined(__arm__)
	(void)u;
#else
	struct unit_rng g = {0x1009ULL};
	struct vehicle v;
	random_vehicle(&g, &v);
	v.delay = 1;
	struct motor_id m;
	struct motor_id_result r;
	struct mid64_res r64;
	experiment(&g, &v, 27000, 640000, 28.0269, MID64_HAVE, &m, &r, &r64);
	CHECK(r.cause == MOTOR_ID_OK);
	CHECK(r.delay == v.delay);
	CHECK_REL(r.kf, v.kf, 0.003);
	CHECK_REL(r.tau, v.tau, 0.01);
	CHECK(r.white_have);
	bool full = false;
	for (int j = 0; j < NR; j++)
		for (int b = 0; b < MOTOR_ID_WBINS; b++)
			full = full || m.wh.n[j][b] == UINT16_MAX;
	CHECK(full); /* the run went past a series' capacity */
#if MID64_HAVE && OCTO_FIXED
	CHECK(r.delay == r64.delay);
	CHECK_REL(r.kf, r64.kf, REL_BOUND);
	CHECK_REL(r.ktau, r64.ktau, REL_BOUND);
	CHECK_REL(r.tau, r64.tau, REL_BOUND);
	CHECK_NEAR(r.curve, r64.curve, REL_BOUND);
#ifdef TEST_VERBOSE
	printf("  long run: kf %.6f / %.6f (truth %.6f), tau %.6f / %.6f, cause %d / %d\n", (double)r.kf, r64.kf, v.kf,
	       (double)r.tau, r64.tau, (int)r.cause, r64.cause);
#endif
#endif
#endif
}
