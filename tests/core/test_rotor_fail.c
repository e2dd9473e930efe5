/* Tests of firmware/core/rotor_fail.h on a synthetic octocopter in hover: random k_f (the
 * detector is never told it), random throttle motion around a random hover throttle through a
 * motor lag the model knows only roughly, per-rotor thrust noise, a weak rotor the model does
 * not know of, ESC speeds with their own noise. One rotor fails at a random time. */
#include "unit_scalar.h"
#include "rotor_fail.h"
#include "unit.h"

#include <math.h>

#define FS 90.0
#define NR 8

static scalar_t s(double x) { return sc_from_float((float)x); }

struct plant {
	double kf, u_h, tau, noise, speed_max, speed_noise;
	double eff[NR]; /* true effectiveness */
	double lag[NR]; /* true lagged throttle */
	double thr[NR]; /* commanded (last step) */
};

static void plant_draw(struct plant *p, struct unit_rng *r, double weak)
{
	p->kf = unit_rand_uniform(r, 15.0, 40.0);
	p->u_h = unit_rand_uniform(r, 0.08, 0.5);
	p->tau = unit_rand_uniform(r, 0.02, 0.05);
	p->noise = unit_rand_uniform(r, 0.005, 0.02) * p->kf * p->u_h; /* N per rotor */
	p->speed_max = unit_rand_uniform(r, 700.0, 1200.0);
	p->speed_noise = 0.005 * p->speed_max * sqrt(p->u_h);
	int w = (int)unit_rand_uniform(r, 0.0, 7.999);
	for (int j = 0; j < NR; j++) {
		p->eff[j] = j == w ? weak : 1.0;
		p->lag[j] = p->thr[j] = p->u_h;
	}
}

/* one frame: throttles around hover (a slow wander per rotor and a little jitter), the lag
 * advanced, thrusts and speeds measured */
static void plant_step(struct plant *p, struct unit_rng *r, int k, scalar_t thr_sc[NR], scalar_t thrust[NR],
		       scalar_t speed[NR])
{
	const double dt = 1.0 / FS, al = 1.0 - exp(-dt / p->tau);
	for (int j = 0; j < NR; j++) {
		p->lag[j] += al * (p->thr[j] - p->lag[j]);
		double g = p->eff[j] * p->lag[j];
		thrust[j] = s(p->kf * g + p->noise * unit_rand_normal(r));
		speed[j] = s(p->speed_max * sqrt(g > 0 ? g : 0) + p->speed_noise * unit_rand_normal(r));
	}
	for (int j = 0; j < NR; j++) {
		double t = p->u_h * (1.0 + 0.15 * sin(0.7 * k * dt * (j + 1) + j) + 0.02 * unit_rand_normal(r));
		p->thr[j] = t < 0 ? 0 : t > 1 ? 1 : t;
		thr_sc[j] = s(p->thr[j]);
	}
}

static void init_det(struct rotor_fail *d, double tau_model)
{
	struct rotor_fail_params p = rotor_fail_params_default();
	rotor_fail_init(d, &p);
	struct rotor_fail_model m = {s(tau_model), SC(0.0), {0}};
	for (int j = 0; j < NR; j++)
		m.scale[j] = SC(1.0);
	rotor_fail_set_model(d, &m);
}

/* Each rotor failing to 0 or to a random partial effectiveness, seen by the thrusts or by
 * the speeds alone: the right rotor within 0.5 s (the target; the decision's low-pass takes
 * about 0.1 s), its effectiveness within 0.06, nothing
 * before; land raised once, hold_s later. */
UNIT_TEST(rotor_fail_found_fast_and_right)
{
	struct unit_rng r = {0x726f746fULL};
	for (int trial = 0; trial < TRIALS(32); trial++) {
		struct plant p;
		plant_draw(&p, &r, 1.0);
		const int by_speed = trial & 1, jf = trial % NR;
		const double S = (trial / NR) % 2 ? unit_rand_uniform(&r, 0.15, 0.45) : 0.0;
		struct rotor_fail d;
		init_det(&d, p.tau * unit_rand_uniform(&r, 0.8, 1.25));
		const int k_fail = (int)unit_rand_uniform(&r, 200, 600);
		scalar_t thr[NR], thrust[NR], speed[NR];
		for (int j = 0; j < NR; j++)
			thr[j] = s(p.u_h);
		int found_k = -1, land_k = -1, lands = 0;
		scalar_t found_scale = SC(-1);
		for (int k = 0; k < k_fail + 400; k++) {
			if (k == k_fail)
				p.eff[jf] = S;
			scalar_t sent[NR];
			for (int j = 0; j < NR; j++)
				sent[j] = thr[j];
			plant_step(&p, &r, k, thr, thrust, speed);
			struct rotor_fail_input in = {
				sent, by_speed ? NULL : thrust, by_speed ? speed : NULL, s(1.0 / FS), true, false,
				false};
			struct rotor_fail_output o = rotor_fail_step(&d, &in);
			if (o.rotor >= 0) {
				CHECK(found_k < 0); /* once */
				CHECK(o.rotor == jf);
				CHECK(o.source == (by_speed ? ROTOR_FAIL_SRC_SPEED : ROTOR_FAIL_SRC_THRUST));
				found_k = k;
				found_scale = o.scale;
			}
			if (o.land) {
				lands++;
				land_k = k;
			}
		}
		CHECK(found_k >= k_fail && found_k <= k_fail + (int)(0.5 * FS));
		CHECK_NEAR(sc_to_float(found_scale), S < 0.1 ? 0.0 : S, 0.06);
		CHECK(lands == 1 && land_k - found_k >= (int)(2.0 * FS) - 1 && land_k - found_k <= (int)(2.0 * FS) + 1);
		CHECK(d.failed == (uint8_t)(1u << jf));
	}
}

/* No failure: a weak rotor (0.85) the model calls 1, k_f unknown, the motor lag 25 % off,
 * thrust noise up to 2 % of hover, 60 s of throttle motion: never a detection. */
UNIT_TEST(rotor_fail_no_false_alarm)
{
	struct unit_rng r = {0x6661ULL};
	for (int trial = 0; trial < TRIALS(16); trial++) {
		struct plant p;
		plant_draw(&p, &r, 0.85);
		struct rotor_fail d;
		init_det(&d, p.tau * (trial & 1 ? 0.75 : 1.25));
		scalar_t thr[NR], thrust[NR], speed[NR];
		for (int j = 0; j < NR; j++)
			thr[j] = s(p.u_h);
		int found = 0;
		for (int k = 0; k < (int)(60 * FS); k++) {
			scalar_t sent[NR];
			for (int j = 0; j < NR; j++)
				sent[j] = thr[j];
			plant_step(&p, &r, k, thr, thrust, speed);
			struct rotor_fail_input in = {
				sent, trial & 2 ? NULL : thrust, trial & 2 ? speed : NULL, s(1.0 / FS), true, false,
				false};
			struct rotor_fail_output o = rotor_fail_step(&d, &in);
			found += o.rotor >= 0;
		}
		CHECK(found == 0);
		CHECK(d.failed == 0);
	}
}

/* Thrust noise of a wide envelope's vehicle: a sd of 0.15-0.3 of a rotor's hover thrust (12
 * times the plant's default on a light vehicle), a weak rotor (0.8, the weakest a working rotor
 * may be before its scale is identified) the model calls 1, 120 s of throttle motion: never a
 * detection (with `confirm` frames alone, a streak below 0.6 comes within seconds); the same
 * noise with a rotor cut to 0: the right one, within 0.5 s. */
UNIT_TEST(rotor_fail_heavy_thrust_noise)
{
	struct unit_rng r = {0x6e6f697365ULL};
	for (int trial = 0; trial < TRIALS(12); trial++) {
		struct plant p;
		plant_draw(&p, &r, 0.8);
		p.noise = unit_rand_uniform(&r, 0.15, 0.3) * p.kf * p.u_h;
		const int cut = trial & 1, k_fail = (int)(unit_rand_uniform(&r, 20.0, 100.0) * FS);
		int jf = -1;
		for (int j = 0; j < NR && jf < 0; j++)
			if (p.eff[j] == 1.0)
				jf = j + (int)unit_rand_uniform(&r, 0.0, 0.999);
		struct rotor_fail d;
		init_det(&d, p.tau * unit_rand_uniform(&r, 0.8, 1.25));
		scalar_t thr[NR], thrust[NR], speed[NR];
		for (int j = 0; j < NR; j++)
			thr[j] = s(p.u_h);
		int found = 0, found_k = -1, found_j = -1;
		for (int k = 0; k < (int)(120 * FS); k++) {
			if (cut && k == k_fail)
				p.eff[jf] = 0.0;
			scalar_t sent[NR];
			for (int j = 0; j < NR; j++)
				sent[j] = thr[j];
			plant_step(&p, &r, k, thr, thrust, speed);
			struct rotor_fail_input in = {sent, thrust, NULL, s(1.0 / FS), true, false, false};
			struct rotor_fail_output o = rotor_fail_step(&d, &in);
			if (o.rotor >= 0 && found++ == 0) {
				found_k = k;
				found_j = o.rotor;
			}
		}
		if (!cut) {
			CHECK(found == 0);
		} else {
			CHECK(found == 1 && found_j == jf);
			CHECK(found_k >= k_fail && found_k <= k_fail + (int)(0.5 * FS));
		}
	}
}

/* The model's side: a scale of 0 is a failed rotor, not judged; a failed rotor set anew is
 * cleared; nothing is judged on the ground (judge false) or without measurements. */
UNIT_TEST(rotor_fail_model_and_gates)
{
	struct rotor_fail d;
	init_det(&d, 0.03);
	struct rotor_fail_model m = d.m;
	m.scale[4] = SC(0.0);
	rotor_fail_set_model(&d, &m);
	CHECK(d.failed == 0x10);
	m.scale[4] = SC(1.0);
	rotor_fail_set_model(&d, &m);
	CHECK(d.failed == 0);

	scalar_t thr[NR], thrust[NR];
	for (int j = 0; j < NR; j++) {
		thr[j] = SC(0.2);
		thrust[j] = j == 2 ? SC(0.0) : SC(5.0);
	}
	for (int k = 0; k < 20; k++) {
		struct rotor_fail_input off = {thr, thrust, NULL, s(1.0 / FS), false, false, false};
		CHECK(rotor_fail_step(&d, &off).rotor < 0);
		struct rotor_fail_input none = {thr, NULL, NULL, s(1.0 / FS), true, false, false};
		CHECK(rotor_fail_step(&d, &none).rotor < 0);
	}
	/* rotor 3 gives nothing from the first frame judged: found on the confirm-th */
	int k_found = -1;
	for (int k = 0; k < 40 && k_found < 0; k++) {
		struct rotor_fail_input in = {thr, thrust, NULL, s(1.0 / FS), true, false, false};
		struct rotor_fail_output o = rotor_fail_step(&d, &in);
		if (o.rotor >= 0) {
			CHECK(o.rotor == 2 && o.scale == SC_ZERO);
			k_found = k;
		}
	}
	CHECK(k_found == d.p.confirm - 1);
	/* the app then writes the scale: the model keeps it failed, not judged again */
	m = d.m;
	CHECK(m.scale[2] == SC_ZERO);
	rotor_fail_set_model(&d, &m);
	CHECK(d.failed == 0x04);
	for (int k = 0; k < 20; k++) {
		struct rotor_fail_input in = {thr, thrust, NULL, s(1.0 / FS), true, false, false};
		CHECK(rotor_fail_step(&d, &in).rotor < 0);
	}
}

/* A rotor giving 0.45 of what the model says: a failure in hover, not during an experiment's
 * excitation, where the model may be another vehicle's and only a deeper drop counts. */
UNIT_TEST(rotor_fail_excited_takes_a_deeper_drop)
{
	for (int excited = 0; excited <= 1; excited++) {
		struct rotor_fail d;
		init_det(&d, 0.03);
		scalar_t thr[NR], thrust[NR];
		for (int j = 0; j < NR; j++) {
			thr[j] = SC(0.2);
			thrust[j] = j == 5 ? SC(0.45 * 5.0) : SC(5.0);
		}
		int found = -1;
		for (int k = 0; k < 40; k++) {
			struct rotor_fail_input in = {thr, thrust, NULL, s(1.0 / FS), true, false, excited != 0};
			struct rotor_fail_output o = rotor_fail_step(&d, &in);
			if (o.rotor >= 0 && found < 0)
				found = o.rotor;
		}
		CHECK(found == (excited ? -1 : 5));
	}
}

/* Frames after missing ones are not judged and restart the streaks: a rotor giving nothing is
 * not concluded from failing frames that are never `confirm` in a row without a gap between;
 * once they are, it is found on the confirm-th. */
UNIT_TEST(rotor_fail_gap_restarts_streaks)
{
	struct rotor_fail d;
	init_det(&d, 0.03);
	scalar_t thr[NR], thrust[NR];
	for (int j = 0; j < NR; j++) {
		thr[j] = SC(0.2);
		thrust[j] = j == 6 ? SC(0.0) : SC(5.0);
	}
	const int every = d.p.confirm;          /* a gap every confirm-th frame: at most confirm - 1 in a row */
	for (int k = 0; k <= 66 * every; k++) { /* ends with a gap */
		bool gap = k % every == 0;
		struct rotor_fail_input in = {thr, thrust, NULL, gap ? s(2.0 / FS) : s(1.0 / FS), true, gap, false};
		CHECK(rotor_fail_step(&d, &in).rotor < 0);
	}
	int k_found = -1;
	for (int k = 0; k < 20 && k_found < 0; k++) {
		struct rotor_fail_input in = {thr, thrust, NULL, s(1.0 / FS), true, false, false};
		if (rotor_fail_step(&d, &in).rotor == 6)
			k_found = k;
	}
	CHECK(k_found == d.p.confirm - 1);
}

/* A motor slower (80 ms) and later (4 frames: transport and link delay) than the model (30 ms,
 * none), each throttle stepping between 50 % and 150 % of hover every 0.2 s or so: no failure
 * read in 60 s (the output follows a step up about 0.1 s after the model); and a rotor cut to
 * 0 there is found within 0.5 s, the right one. */
UNIT_TEST(rotor_fail_slow_late_motor)
{
	struct unit_rng r = {0x736c6f77ULL};
	enum { DELAY = 4 };
	for (int trial = 0; trial < TRIALS(16); trial++) {
		struct plant p;
		plant_draw(&p, &r, 0.9);
		p.tau = 0.08;
		const int jf = trial % NR, k_fail = trial & 1 ? (int)(40 * FS) : -1;
		struct rotor_fail d;
		init_det(&d, 0.03);
		double line[DELAY + 1][NR];
		for (int i = 0; i <= DELAY; i++)
			for (int j = 0; j < NR; j++)
				line[i][j] = p.u_h;
		const double al = 1.0 - exp(-1.0 / FS / p.tau);
		int found = -1, found_k = -1;
		scalar_t sent[NR], thrust[NR];
		double lvl[NR];
		for (int j = 0; j < NR; j++) {
			sent[j] = s(p.u_h);
			lvl[j] = 1.0;
		}
		for (int k = 0; k < (int)(60 * FS); k++) {
			if (k == k_fail)
				p.eff[jf] = 0.0;
			for (int i = DELAY; i > 0; i--) /* the plant answers the command of DELAY frames ago */
				for (int j = 0; j < NR; j++)
					line[i][j] = line[i - 1][j];
			for (int j = 0; j < NR; j++) {
				line[0][j] = sc_to_float(sent[j]);
				p.lag[j] += al * (line[DELAY][j] - p.lag[j]);
				thrust[j] = s(p.kf * p.eff[j] * p.lag[j] + p.noise * unit_rand_normal(&r));
			}
			struct rotor_fail_input in = {sent, thrust, NULL, s(1.0 / FS), true, false, false};
			struct rotor_fail_output o = rotor_fail_step(&d, &in);
			if (o.rotor >= 0 && found < 0) {
				found = o.rotor;
				found_k = k;
			}
			for (int j = 0; j < NR; j++) { /* a step of +/-50 % now and then, each rotor its own */
				if (unit_rand_uniform(&r, 0.0, 1.0) < 0.06)
					lvl[j] = unit_rand_uniform(&r, 0.0, 1.0) < 0.5 ? 0.5 : 1.5;
				double t = p.u_h * (lvl[j] + 0.02 * unit_rand_normal(&r));
				sent[j] = s(t < 0 ? 0 : t > 1 ? 1 : t);
			}
		}
		if (k_fail < 0) {
			CHECK(found < 0);
		} else {
			CHECK(found == jf);
			CHECK(found_k >= k_fail && found_k <= k_fail + (int)(0.5 * FS));
		}
	}
}
