/*
 * step.c - cost of octo-fw's 90 Hz step without I/O, for `make bench` (tests/bench/bench.py).
 *
 * Links the real app (every firmware/app C file: modes, guidance, control, allocation, throttle map,
 * experiment hook, log record) and the core with a stub HAL (no sockets, no LCM, no clock:
 * the clock advances 1/90 s per frame). A small synthetic plant closes the loop well enough
 * to fly the app's own mode logic: the height follows the app's setpoint, the attitude wobbles
 * by a few tenths of a degree, the measured rotor thrusts are the commanded throttles through
 * a 30 ms lag times the paper's k_f with 1 % noise. Sequence:
 *   boot (disarmed frames) -> arm -> take-off to 10 m -> HOLD (measured: N_HOLD steps; half way
 *   a parameter change between frames, so that one of them is a parameter change's step)
 *   -> experiments 1 (rotor coefficients), 2 (validation), 3 (inertia Ixx), each started
 *      from HOLD as MAV_CMD_USER_1 does (measured: up to N_EXP steps each, and the app_tick
 *      after each: the between-frames work, counted apart; "step: exp_steps_N" per experiment)
 *   -> the allocator alone on the app's mixer: the step's allocation (mixer_step) of the
 *      last hover demand (unsaturated) and of N_ALLOC seeded demands (many saturating; every
 *      other one a repeat after its exact search between frames), then the exact search
 *      (mixer_update, as mixer_refresh runs it between frames) of the demand that needed the
 *      most allocator steps (its worst case)
 *   -> the steps that say something (each measured with the app_tick after it, which says
 *      it): a parameter change, the plant's origin shift, frames missing, experiment 1
 *      aborted by frames missing and by the attitude limit, the link lost (the app_tick that
 *      finds it) and back, back after FS_LAND_AFTER (landing), the landing's steps and its
 *      touch-down, a take-off's first step, climb and HOLD entry, and a take-off and a
 *      landing that run out of their time limits. "step: ev NAME step|tick" names each
 *      measured region of this part, in order.
 * One measured call = app_on_frame() (or mixer_update()) between bench_mark_begin/end
 * (tests/arm/bench_mark.h): on Cortex-M the QEMU plugin prints one count per call; on the
 * host, valgrind's callgrind counts the inclusive cost of the wrappers below (bench.py
 * reads the call counts and costs of bench_hold_step, bench_exp_step, bench_exp_tick,
 * bench_alloc_hover, bench_alloc_call, bench_alloc_worst, bench_ev_step and bench_ev_tick
 * from callgrind's output).
 *
 * Prints (semihosting stdout on ARM): "step: KEY VALUE" lines (mode reached, steps measured,
 * allocator steps of the worst demand, etc.). Argument-free; sizes below, or -DBENCH_QUICK.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "app.h"
#include "bench_mark.h"
#include "mav.h"
#include "params.h"
#include "stub_hal.h"

#ifdef BENCH_QUICK
#define N_HOLD 20
#define N_EXP 20
#define N_ALLOC 20
#else
#define N_HOLD 300
#define N_EXP 1800
#define N_ALLOC 300
#endif

#define RATE_HZ 90.0
#define KF_TRUE 28.0269f
#define KTAU_TRUE 0.3869f

/* ---------------------------------------------------------------- stub HAL */
static struct stub_hal H; /* tests/app/stub_hal.c: clock advanced 1/90 s per frame */

/* ---------------------------------------------------------------- synthetic plant */
static struct app A; /* global: the compiler cannot see through it across the markers */
static struct mav M; /* its MAVLink endpoint, ticked after the app as the platform does */
static struct hal_sensor_frame F;
static float s_rotor[HAL_ROTORS];
static uint32_t rng = 12345u;
static uint32_t n_frame;
static float pos_shift_x; /* the plant's origin moved by this (m, north) */
static float roll_extra;  /* added to the frame's roll (rad) */

static float urand(void) /* [-1, 1) */
{
	rng ^= rng << 13;
	rng ^= rng >> 17;
	rng ^= rng << 5;
	return (float)(rng >> 8) * (2.0f / 16777216.0f) - 1.0f;
}

static void next_frame(void)
{
	n_frame++;
	H.now_us += 11111u;
	double t = (double)n_frame / RATE_HZ;
	float tf = (float)t;
	hal_frame_time(&F, n_frame, (uint64_t)llround(t * 1e6));
	F.seq = n_frame;
	F.valid = HAL_FRAME_NEEDED | HAL_FRAME_THRUST | HAL_FRAME_TORQUE;
	/* attitude: roll/pitch wobble of 0.3 deg, heading 0 */
	float roll = 0.3f * 0.01745f * sinf(2.0f * 3.14159f * 0.7f * tf) + roll_extra;
	float pitch = 0.3f * 0.01745f * cosf(2.0f * 3.14159f * 0.45f * tf);
	float cr = cosf(0.5f * roll), sr = sinf(0.5f * roll), cp = cosf(0.5f * pitch), sp = sinf(0.5f * pitch);
	F.q_ib[0] = cr * cp;
	F.q_ib[1] = sr * cp;
	F.q_ib[2] = cr * sp;
	F.q_ib[3] = -sr * sp;
	F.rate_b_rps[0] =
		0.3f * 0.01745f * 2.0f * 3.14159f * 0.7f * cosf(2.0f * 3.14159f * 0.7f * tf) + 0.005f * urand();
	F.rate_b_rps[1] =
		-0.3f * 0.01745f * 2.0f * 3.14159f * 0.45f * sinf(2.0f * 3.14159f * 0.45f * tf) + 0.005f * urand();
	F.rate_b_rps[2] = 0.005f * urand();
	/* height follows the app's setpoint; horizontal position within a few cm */
	bool flying = A.mode != APP_DISARMED && A.mode != APP_IDLE;
	F.pos_i_m[0] = 0.02f * sinf(0.3f * tf) + pos_shift_x;
	F.pos_i_m[1] = 0.02f * cosf(0.2f * tf);
	F.pos_i_m[2] = flying ? sc_to_float(A.guid.z_sp_m) + 0.01f * sinf(1.3f * tf) : 0.0f;
	bool ground = F.pos_i_m[2] <= 0.0f; /* never below the ground: a landing touches down */
	if (ground)
		F.pos_i_m[2] = 0.0f;
	F.vel_i_mps[0] = 0.006f * cosf(0.3f * tf);
	F.vel_i_mps[1] = -0.004f * sinf(0.2f * tf);
	F.vel_i_mps[2] = flying && !ground ? sc_to_float(A.guid.vz_ff_mps) + 0.013f * cosf(1.3f * tf) : 0.0f;
	/* rotors: the last throttles through a 30 ms lag, k_f, 1 % noise */
	float alpha = 1.0f - expf(-(float)(1.0 / RATE_HZ) / 0.03f);
	float sigma = 0.01f * 2.132f * 9.796f / 8.0f;
	for (int j = 0; j < HAL_ROTORS; j++) {
		s_rotor[j] += alpha * (H.thr[j] - s_rotor[j]);
		F.rotor_thrust_n[j] = KF_TRUE * s_rotor[j] + sigma * 1.732f * urand();
		F.rotor_torque_nm[j] = (j % 2 ? -KTAU_TRUE : KTAU_TRUE) * s_rotor[j];
	}
}

/* ---------------------------------------------------------------- measured calls */
/* a distinct store in each wrapper, so that the compiler does not merge them (ICF) */
static volatile int bench_phase;

__attribute__((noinline)) static void bench_hold_step(void)
{
	bench_phase = 1;
	bench_mark_begin();
	app_on_frame(&A, &F);
	bench_mark_end();
}

__attribute__((noinline)) static void bench_exp_step(void)
{
	bench_phase = 2;
	bench_mark_begin();
	app_on_frame(&A, &F);
	bench_mark_end();
}

/* the app's between-frames work after each experiment step (app_tick: results applied,
 * mixer rebuilt, parameter file saved, status lines formatted, telemetry): not part of the
 * step, measured to show where that work went */
__attribute__((noinline)) static void bench_exp_tick(void)
{
	bench_phase = 6;
	bench_mark_begin();
	app_tick(&A);
	mav_tick(&M, H.now_us);
	bench_mark_end();
}

static scalar_t demand[MIXER_N_AXES];
static struct mixer_output mix_out;

static struct mixer_warm warm; /* the step's allocation state, as the app keeps it */

/* the step's allocation (mixer_step), its exact search after it, unmeasured (mixer_refresh:
 * between frames) */
__attribute__((noinline)) static void bench_alloc_call(void)
{
	bench_phase = 3;
	bench_mark_begin();
	mixer_step(&A.mix, &warm, demand, &mix_out);
	bench_mark_end();
}

__attribute__((noinline)) static void bench_alloc_hover(void)
{
	bench_phase = 5;
	bench_mark_begin();
	mixer_step(&A.mix, &warm, demand, &mix_out);
	bench_mark_end();
}

__attribute__((noinline)) static void bench_alloc_worst(void)
{
	bench_phase = 4;
	bench_mark_begin();
	mixer_update(&A.mix, demand, &mix_out);
	bench_mark_end();
}

/* the steps that say something, and the app_tick after each (between frames: it says it) */
__attribute__((noinline)) static void bench_ev_step(void)
{
	bench_phase = 7;
	bench_mark_begin();
	app_on_frame(&A, &F);
	bench_mark_end();
}

__attribute__((noinline)) static void bench_ev_tick(void)
{
	bench_phase = 8;
	bench_mark_begin();
	app_tick(&A);
	mav_tick(&M, H.now_us);
	bench_mark_end();
}

/* The step just measured named, the app_tick after it measured and named, and the last line
 * they said (the stub's console) when they said any. */
static void ev_print(const char *name)
{
	uint32_t reports = H.n_reports;
	printf("step: ev %s step\n", name);
	bench_ev_tick();
	printf("step: ev %s tick\n", name);
	if (H.n_reports != reports)
		printf("step: ev_said %s: %u lines, the last \"%s\"\n", name, (unsigned)(H.n_reports - reports),
		       H.last_report);
}

/* The next frame (skip: plant frames lost before it) measured as a step named `name`, or,
 * when the step changed the mode, `changed` (NULL: still `name`); then the app_tick after
 * it, measured. */
static void ev_frame(uint32_t skip, const char *name, const char *changed)
{
	n_frame += skip;
	next_frame();
	enum app_mode before = A.mode;
	bench_ev_step();
	ev_print(changed && A.mode != before ? changed : name);
}

static void frame_unmeasured(void)
{
	next_frame();
	app_on_frame(&A, &F);
	app_tick(&A);
	mav_tick(&M, H.now_us);
}

/* seeded demands around the app's hover: thrust 0..1.6 hover x 8 at random, torques up to
 * about twice what the box allows, every eighth (i = 6 mod 8) with a roll/pitch up to eight
 * times it (k is the app's yaw moment arm) */
static void alloc_demand(uint32_t i, scalar_t d[MIXER_N_AXES])
{
	uint32_t saved = rng;
	rng = 0x9E3779B9u * (i + 1u);
	float kf = A.p.veh_kf, l = A.p.veh_arm_l, k = A.p.veh_ktau / A.p.veh_kf;
	float hover = A.p.veh_mass * A.p.veh_grav;
	float fmax = 8.0f * kf * A.p.mot_thr_max;
	float f = hover * (1.0f + 0.8f * urand());
	if (i % 4 == 3)
		f = fmax * (0.5f + 0.5f * urand()); /* some near the top of the box */
	/* some with a roll/pitch no thrust allows (the fallback's other path) */
	float rp = i % 8 == 6 ? 2.4f : 0.6f;
	d[0] = sc_from_float(f);
	d[1] = sc_from_float(urand() * rp * f * l);
	d[2] = sc_from_float(urand() * rp * f * l);
	d[3] = sc_from_float(urand() * 0.6f * f * k);
	rng = saved;
}

/* a parameter set as PARAM_SET sets it (app_param_write: applied between frames) */
static void param_set(const char *name, float v)
{
	int i = params_find(name, strlen(name));
	const char *no = i < 0 ? "unknown" : app_param_write(&A, (size_t)i, v);
	if (no)
		printf("step: param_%s %s\n", name, no);
}

static float param(const char *name)
{
	int i = params_find(name, strlen(name));
	return i < 0 ? 0.0f : params_get(&A.p, (size_t)i);
}

/* Between frames only, for `seconds` of wall time (no frames: the link goes silent); the
 * app_tick that finds the link lost measured. */
static void silence(float seconds)
{
	uint64_t to = (uint64_t)(A.p.fs_link_to * 1e6f);
	for (int i = 0; i < (int)(seconds * 90.0f); i++) {
		H.now_us += 11111u;
		if (A.link_ok && H.now_us - A.wall_last_frame_us > to) {
			bench_ev_tick();
			printf("step: ev link_lost tick\n");
		} else {
			app_tick(&A);
			mav_tick(&M, H.now_us);
		}
	}
}

/* The steps that say something (status lines, a command's final answer, a mode), each with
 * the app_tick after it, from a settled HOLD. */
static void events(void)
{
	char why[96];
	for (int i = 0; i < 90; i++)
		frame_unmeasured();
	if (A.mode != APP_HOLD) {
		printf("step: events_skipped mode %s\n", app_mode_name(A.mode));
		return;
	}
	/* a parameter change (the gains, the inertia and the rotor model rebuilt between frames) */
	param_set("ATT_WN_RP", param("ATT_WN_RP") * 1.01f);
	param_set("VEH_IXX", param("VEH_IXX") * 1.01f);
	param_set("ID_MOT_TAU", param("ID_MOT_TAU") * 1.01f);
	app_tick(&A);
	ev_frame(0, "param_change", NULL);
	/* the plant moves its origin by a kilometre */
	pos_shift_x = 1000.0f;
	ev_frame(0, "origin_shift", NULL);
	for (int i = 0; i < 90; i++)
		frame_unmeasured();
	/* frames missing: 0.5 s of plant frames lost (the link up) */
	ev_frame(45, "frames_missing", NULL);
	for (int i = 0; i < 2 * 90; i++)
		frame_unmeasured();
	/* experiment 1 aborted by frames missing, then by the attitude limit */
	if (exp_available(1) && app_cmd_experiment(&A, 1.0f, 0x0A0B, why, sizeof why) == APP_IN_PROGRESS) {
		for (int i = 0; i < 30; i++)
			frame_unmeasured();
		ev_frame(45, "exp_abort_frames_missing", NULL);
		for (int i = 0; i < 2 * 90; i++)
			frame_unmeasured();
	} else {
		printf("step: ev_exp_abort unavailable\n");
	}
	if (exp_available(1) && app_cmd_experiment(&A, 1.0f, 0x0A0C, why, sizeof why) == APP_IN_PROGRESS) {
		for (int i = 0; i < 30; i++)
			frame_unmeasured();
		roll_extra = 20.0f * 0.01745f;
		ev_frame(0, "exp_abort_attitude", NULL);
		roll_extra = 0.0f;
		for (int i = 0; i < 2 * 90; i++)
			frame_unmeasured();
	}
	/* the link silent for 0.5 s (a lockstep plant waits: no plant frames lost), back */
	silence(0.5f);
	ev_frame(0, "link_back", NULL);
	for (int i = 0; i < 2 * 90; i++)
		frame_unmeasured();
	/* silent for longer than FS_LAND_AFTER: back, landing; the landing to its touch-down */
	silence(A.p.fs_land_after + 0.5f);
	ev_frame(0, "link_back_landing", NULL);
	for (int i = 0; i < 90 * 60 && A.mode == APP_LAND; i++)
		ev_frame(0, "landing", "landed");
	/* take-off: its first step, the climb, the HOLD entry */
	for (int i = 0; i < 10; i++)
		frame_unmeasured();
	app_cmd_arm(&A, true, false, why, sizeof why);
	for (int i = 0; i < 10; i++)
		frame_unmeasured();
	app_cmd_takeoff(&A, 10.0f, 0x0A0D, why, sizeof why);
	ev_frame(0, "takeoff", NULL);
	for (int i = 0; i < 90 * 60 && A.mode == APP_TAKEOFF; i++)
		ev_frame(0, "climb", "hold_reached");
	for (int i = 0; i < 90; i++)
		frame_unmeasured();
	/* a take-off (from HOLD, 2 m higher) and its landing that run out of their limits */
	param_set("NAV_TKO_TO", 1.0f);
	param_set("NAV_LAND_TO", 1.0f);
	app_tick(&A);
	app_cmd_takeoff(&A, 12.0f, 0x0A0E, why, sizeof why);
	for (int i = 0; i < 90 * 5 && A.mode == APP_TAKEOFF; i++)
		ev_frame(0, "climb", "takeoff_timeout");
	for (int i = 0; i < 90 * 60 && A.mode == APP_LAND; i++) {
		bool said = A.env_limits.phase_s < 0.0f; /* the landing's limit: said once */
		next_frame();
		enum app_mode before = A.mode;
		bench_ev_step();
		ev_print(A.mode != before                       ? "landed"
			 : !said && A.env_limits.phase_s < 0.0f ? "landing_timeout"
								: "landing");
	}
	printf("step: events_mode_after %s\n", app_mode_name(A.mode));
}

int main(void)
{
	char why[96] = "";
	stub_hal_init(&H);
	app_init(&A, &H.hal);
	mav_init(&M, &A, &H.hal, H.now_us);
	for (int i = 0; i < 20; i++)
		frame_unmeasured();
	int r = app_cmd_arm(&A, true, false, why, sizeof why);
	printf("step: arm %d\n", r);
	for (int i = 0; i < 10; i++)
		frame_unmeasured();
	r = app_cmd_takeoff(&A, 10.0f, APP_ORIGIN_NONE, why, sizeof why);
	printf("step: takeoff %d\n", r);
	int n = 0;
	while (A.mode != APP_HOLD && n++ < 90 * 60)
		frame_unmeasured();
	for (int i = 0; i < 90; i++) /* settle a second in HOLD */
		frame_unmeasured();
	printf("step: mode %s after %d frames\n", app_mode_name(A.mode), n);

	int hold = 0;
	for (; hold < N_HOLD && A.mode == APP_HOLD; hold++) {
		if (hold == N_HOLD / 2) {
			/* a parameter change between frames (as a PARAM_SET: the gains, the inertia and
			 * the rotor model rebuilt in app_tick): the next measured step is its step */
			static const char *const names[] = {"ATT_WN_RP", "VEH_IXX", "ID_MOT_TAU"};
			for (size_t k = 0; k < sizeof names / sizeof names[0]; k++) {
				int i = params_find(names[k], strlen(names[k]));
				const char *no =
					i < 0 ? "unknown"
					      : app_param_write(&A, (size_t)i, params_get(&A.p, (size_t)i) * 1.01f);
				printf("step: param_change_%s %s\n", names[k], no ? no : "ok");
			}
			app_tick(&A);
		}
		next_frame();
		bench_hold_step();
		app_tick(&A);
		mav_tick(&M, H.now_us);
	}
	printf("step: hold_steps %d\n", hold);

	/* experiments 1 (rotor coefficients), 2 (validation), 3 (inertia Ixx), one after the
	 * other, each from a settled HOLD: up to N_EXP measured steps each */
	static const int exp_ids[] = {1, 2, 3};
	int exp_total = 0;
	for (size_t k = 0; k < sizeof exp_ids / sizeof exp_ids[0]; k++) {
		int id = exp_ids[k], exp = 0;
		if (k > 0) {
			for (int i = 0; i < 90 && A.mode == APP_HOLD; i++) /* a second of HOLD between */
				frame_unmeasured();
		}
		if (exp_available(id) && A.mode == APP_HOLD) {
			r = app_cmd_experiment(&A, (float)id, 0, why, sizeof why);
			printf("step: experiment_%d %d %s\n", id, r, r != APP_IN_PROGRESS ? why : "");
			for (; exp < N_EXP && A.mode == APP_EXPERIMENT; exp++) {
				next_frame();
				bench_exp_step();
				bench_exp_tick();
			}
			if (A.mode == APP_EXPERIMENT) { /* cut at N_EXP: stop it, unmeasured */
				app_cmd_experiment(&A, 0.0f, 0, why, sizeof why);
				frame_unmeasured();
			}
			printf("step: experiment_%d_mode_after %s\n", id, app_mode_name(A.mode));
		} else {
			printf("step: experiment_%d unavailable\n", id);
		}
		/* one measured app_tick after each experiment step: 2 regions per step */
		printf("step: exp_steps_%d %d\n", id, exp);
		exp_total += exp;
	}
	printf("step: exp_steps %d\n", exp_total);
	printf("step: exp_ticks %d\n", exp_total);

	/* the allocator alone: the last hover demand of the app (unsaturated), a seeded set of
	 * demands, then the one that needed the most allocator steps again */
	for (int i = 0; i < MIXER_N_AXES; i++)
		demand[i] = sc_from_float(A.wrench_dem[i]);
	mixer_warm_reset(&warm);
	bench_alloc_hover();
	printf("step: alloc_hover_steps %u limits %u\n", (unsigned)mix_out.steps, (unsigned)mix_out.limits);
	/* odd calls: the previous demand again, after its exact search (the face path); even
	 * calls: a new one (a jump: the fallback when it saturates) */
	unsigned worst_i = 0, worst_steps = 0, n_sat = 0, paths[5] = {0};
	for (uint32_t i = 0; i < N_ALLOC; i++) {
		alloc_demand(i & ~1u, demand);
		bench_alloc_call();
		paths[warm.path < 5 ? warm.path : 0]++;
		mixer_refresh(&A.mix, &warm);
		if (mix_out.limits)
			n_sat++;
		struct mixer_output ex;
		mixer_update(&A.mix, demand, &ex);
		if (ex.steps > worst_steps) {
			worst_steps = ex.steps;
			worst_i = i & ~1u;
		}
	}
	printf("step: alloc_paths pinv %u face %u fallback %u fallback_rp %u clip %u\n", paths[0], paths[1], paths[2],
	       paths[3], paths[4]);
	/* the exact search of the demand that needed the most steps (mixer_update: what
	 * mixer_refresh runs between frames) */
	alloc_demand(worst_i, demand);
	bench_alloc_worst();
	printf("step: alloc_calls %d saturated %u\n", N_ALLOC, n_sat);
	printf("step: alloc_worst_steps %u demand %u\n", (unsigned)mix_out.steps, worst_i);
	printf("step: alloc_step_bound %d\n", 2 * MIXER_ALPHA_ITERS + (A.mix.n_active - 4) + MIXER_QP_ITERS);
	printf("step: mix_mode %d\n", (int)A.mix.p.mode);
	events();
	printf("step: done\n");
	return 0;
}
