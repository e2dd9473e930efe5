/*
 * test_app.c - the autopilot (firmware/app) without sockets: modes, command
 * idempotency, failsafes, parameter locks and storage, the outbox. The app runs
 * on the stub HAL against a kinematic plant: the height follows the app's own
 * setpoint (never below the ground), attitude level, rotor thrust k_f times the
 * throttle. Built and run like the core's tests (float, Q16.16, sanitizers).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "app.h"
#include "mav.h"
#include "stub_hal.h"
#include "unit.h"

#define FRAME_US 11111u

struct rig {
	struct stub_hal h;
	struct app a;
	struct mav mav; /* the platform's MAVLink endpoint: drains the outbox after app_tick */
	struct hal_sensor_frame f;
	double t;
	bool stuck;         /* the vehicle stays at height z_stuck whatever the app asks */
	bool collect_ticks; /* fly_collect runs app_tick after each frame */
	float z_stuck;
	/* the roll rate, while roll_dps > 0: a 2 Hz sine of rms roll_dps, times roll_decay per
	 * second from roll_t0 */
	double roll_dps, roll_decay, roll_t0;
};

static struct rig R; /* large: kept off the stack */

static struct rig *rig_new(void)
{
	memset(&R, 0, sizeof R);
	stub_hal_init(&R.h);
	app_init(&R.a, &R.h.hal);
	mav_init(&R.mav, &R.a, &R.h.hal, R.h.now_us);
	R.f.q_ib[0] = 1.0f;
	return &R;
}

/* The main loop's pass after a frame: the app's work between frames, then MAVLink. */
static void tick(struct rig *r)
{
	app_tick(&r->a);
	mav_tick(&r->mav, r->h.now_us);
}

/* One plant frame at time t (not advanced), without app_tick. */
static void frame_at(struct rig *r, double t)
{
	struct app *a = &r->a;
	struct hal_sensor_frame *f = &r->f;
	bool flying = app_flying(a);
	hal_frame_time(f, (uint64_t)llround(t * 90.0), (uint64_t)llround(t * 1e6));
	f->seq++;
	if (r->roll_dps > 0.0) /* else the rate a test set stays */
		f->rate_b_rps[0] = (float)(r->roll_dps * sqrt(2.0) * pow(r->roll_decay, t - r->roll_t0) *
					   0.017453292519943295 * sin(2.0 * 3.141592653589793 * 2.0 * t));
	f->valid = HAL_FRAME_NEEDED | HAL_FRAME_THRUST | HAL_FRAME_TORQUE;
	f->pos_i_m[2] = flying ? fmaxf(sc_to_float(a->guid.z_sp_m), 0.0f) : 0.0f;
	f->vel_i_mps[2] = flying && f->pos_i_m[2] > 0.0f ? sc_to_float(a->guid.vz_ff_mps) : 0.0f;
	if (r->stuck) {
		f->pos_i_m[2] = r->z_stuck;
		f->vel_i_mps[2] = 0.0f;
	}
	for (int j = 0; j < HAL_ROTORS; j++)
		f->rotor_thrust_n[j] = a->p.veh_kf * r->h.thr[j];
	app_on_frame(a, f);
}

/* n frames at 90 Hz, each followed by the main loop's app_tick. */
static void fly(struct rig *r, int n)
{
	for (int i = 0; i < n; i++) {
		r->t += 1.0 / 90.0;
		r->h.now_us += FRAME_US;
		frame_at(r, r->t);
		tick(r);
	}
}

static void fly_until(struct rig *r, enum app_mode m, int max_frames)
{
	for (int i = 0; i < max_frames && r->a.mode != m; i++)
		fly(r, 1);
}

static struct rig *rig_hovering(struct unit_ctx *u)
{
	struct rig *r = rig_new();
	char why[64];
	fly(r, 5);
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED);
	CHECK(app_cmd_takeoff(&r->a, 3.0f, 7, why, sizeof why) == APP_ACCEPTED);
	fly_until(r, APP_HOLD, 90 * 60);
	CHECK(r->a.mode == APP_HOLD);
	fly(r, 30);
	CHECK(app_hovering(&r->a));
	return r;
}

static int param_index(const char *name) { return params_find(name, strlen(name)); }

/* The outbox's events of one kind, drained (a test looks before app_tick does). */
static int take_events(struct app *a, enum app_event_kind kind, struct app_event *last)
{
	struct app_event e;
	int n = 0;
	while (app_next_event(a, &e))
		if (e.kind == kind) {
			n++;
			if (last)
				*last = e;
		}
	return n;
}

UNIT_TEST(app_boots_disarmed_and_arms_only_with_frames)
{
	struct rig *r = rig_new();
	char why[64] = "";
	CHECK(r->a.mode == APP_DISARMED);
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_BUSY);
	CHECK(strstr(why, "no complete") != NULL);
	fly(r, 3);
	CHECK(r->h.n_actuate == 0); /* the throttles are not ours before arming */
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED);
	CHECK(r->a.mode == APP_IDLE);
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED); /* a retry */
	CHECK(r->a.mode == APP_IDLE);
	fly(r, 4);
	CHECK(r->h.n_actuate == 4);
}

UNIT_TEST(app_arm_refused_when_tilted_unless_forced)
{
	struct rig *r = rig_new();
	char why[64] = "";
	r->f.q_ib[0] = cosf(0.5f * 0.7f); /* 40 deg roll */
	r->f.q_ib[1] = sinf(0.5f * 0.7f);
	fly(r, 3);
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_BUSY);
	CHECK(strstr(why, "tilted") != NULL);
	CHECK(app_cmd_arm(&r->a, true, true, why, sizeof why) == APP_ACCEPTED);
	CHECK(r->a.mode == APP_IDLE);
}

UNIT_TEST(app_answers_each_new_frame_once)
{
	struct rig *r = rig_new();
	char why[64];
	fly(r, 3);
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED);
	fly(r, 1);
	uint32_t n = r->h.n_actuate;
	frame_at(r, r->t); /* a duplicate */
	CHECK(r->h.n_actuate == n);
	frame_at(r, r->t - 1.0 / 90.0); /* an older frame */
	CHECK(r->h.n_actuate == n);
	fly(r, 1);
	CHECK(r->h.n_actuate == n + 1);
}

UNIT_TEST(app_takeoff_hold_land_disarm)
{
	struct rig *r = rig_new();
	char why[64] = "";
	CHECK(app_cmd_takeoff(&r->a, 3.0f, 7, why, sizeof why) == APP_BUSY); /* not armed */
	fly(r, 3);
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED);
	CHECK(app_cmd_takeoff(&r->a, 200.0f, 7, why, sizeof why) == APP_DENIED);
	CHECK(r->a.mode == APP_IDLE);
	CHECK(app_cmd_takeoff(&r->a, 3.0f, 7, why, sizeof why) == APP_ACCEPTED);
	CHECK(r->a.mode == APP_TAKEOFF);
	fly(r, 20);
	scalar_t z_sp = r->a.guid.z_sp_m;
	CHECK(app_cmd_takeoff(&r->a, 3.0f, 7, why, sizeof why) == APP_ACCEPTED); /* a retry */
	CHECK(r->a.mode == APP_TAKEOFF && r->a.guid.z_sp_m == z_sp);
	fly_until(r, APP_HOLD, 90 * 60);
	CHECK(r->a.mode == APP_HOLD);
	CHECK_NEAR(r->f.pos_i_m[2], 3.0, 0.05);
	CHECK(app_cmd_arm(&r->a, false, false, why, sizeof why) == APP_BUSY); /* flying */
	CHECK(app_cmd_land(&r->a, 7, why, sizeof why) == APP_ACCEPTED);
	CHECK(r->a.mode == APP_LAND);
	CHECK(app_cmd_land(&r->a, 7, why, sizeof why) == APP_ACCEPTED); /* a retry */
	CHECK(r->a.mode == APP_LAND);
	fly_until(r, APP_DISARMED, 90 * 60);
	CHECK(r->a.mode == APP_DISARMED);
	CHECK(r->f.pos_i_m[2] == 0.0f);
	for (int j = 0; j < HAL_ROTORS; j++)
		CHECK(r->a.thr[j] == 0.0f);
}

UNIT_TEST(app_disarm_forced_while_flying)
{
	struct rig *r = rig_hovering(u);
	char why[64];
	CHECK(app_cmd_arm(&r->a, false, true, why, sizeof why) == APP_ACCEPTED);
	CHECK(r->a.mode == APP_DISARMED);
	CHECK(app_cmd_arm(&r->a, false, false, why, sizeof why) == APP_ACCEPTED); /* a retry */
}

UNIT_TEST(app_link_loss_reported_then_lands_on_recovery)
{
	struct rig *r = rig_hovering(u);
	/* silence on the plant link: the main loop keeps ticking on wall time */
	uint32_t events = r->h.n_events;
	for (int i = 0; i < 100; i++) { /* 1.1 s > FS_LINK_TO */
		r->h.now_us += FRAME_US;
		tick(r);
	}
	CHECK(!r->a.link_ok);
	CHECK(r->h.n_events > events);
	CHECK(r->a.mode == APP_HOLD); /* not yet: FS_LAND_AFTER not exceeded */
	r->h.now_us += (uint64_t)(r->a.p.fs_land_after * 1e6f);
	fly(r, 1);
	CHECK(r->a.link_ok);
	CHECK(r->a.mode == APP_LAND);
}

UNIT_TEST(app_short_link_loss_keeps_holding)
{
	struct rig *r = rig_hovering(u);
	for (int i = 0; i < 50; i++) { /* 0.55 s: lost, but shorter than FS_LAND_AFTER */
		r->h.now_us += FRAME_US;
		tick(r);
	}
	CHECK(!r->a.link_ok);
	fly(r, 1);
	CHECK(r->a.link_ok);
	CHECK(r->a.mode == APP_HOLD);
}

UNIT_TEST(app_plant_time_gap_lands)
{
	struct rig *r = rig_hovering(u);
	r->t += (double)r->a.p.fs_land_after + 0.5; /* frames missing in plant time */
	fly(r, 1);
	CHECK(r->a.mode == APP_LAND);
	CHECK(!strcmp(r->h.last_event, "Mode LAND"));
}

/* After frames missing in plant time (less than FS_LAND_AFTER) the controllers step by one
 * frame period, not by the gap: their integrators do not wind up over time in which their
 * last command was only held (integrating a 0.5 s gap as 0.2 s kicked the attitude loop,
 * whose held corrections then tipped the vehicle in the next blackout). */
UNIT_TEST(app_plant_time_gap_not_integrated)
{
	struct rig *r = rig_hovering(u);
	r->f.rate_b_rps[0] = 0.1f; /* a steady roll-rate error for the integral to act on */
	fly(r, 2);
	double i0 = (double)sc_to_float(r->a.att.int_r_rad.x);
	fly(r, 1);
	double step = (double)sc_to_float(r->a.att.int_r_rad.x) - i0;
	r->t += 0.5; /* 0.5 s of frames missing: longer than FS_LINK_TO, shorter than FS_LAND_AFTER */
	double i1 = (double)sc_to_float(r->a.att.int_r_rad.x);
	fly(r, 1);
	double gap_step = (double)sc_to_float(r->a.att.int_r_rad.x) - i1;
	CHECK(r->a.mode == APP_HOLD);
	CHECK(fabs(step) > 1e-4);
	CHECK_NEAR(gap_step, step, 0.25 * fabs(step));
	r->f.rate_b_rps[0] = 0.0f;
}

/* A burst storm in a fast lockstep run: one "frames missing" line a wall second, the gaps
 * between counted into the next line, so that other lines keep their place in the ground
 * station's STATUSTEXT rate. */
/* Frames without app_tick (which would hand the outbox to MAVLink); the status lines that
 * start with prefix among the outbox's events counted, the last one kept. */
static int said_lines(struct rig *r, int frames, const char *prefix, char *last, size_t cap)
{
	int n = 0;
	for (int i = 0; i < frames; i++) {
		r->t += 1.0 / 90.0;
		r->h.now_us += FRAME_US;
		frame_at(r, r->t);
		struct app_event e;
		while (app_next_event(&r->a, &e))
			if (e.kind == APP_EV_STATUS && !strncmp(e.text, prefix, strlen(prefix))) {
				n++;
				snprintf(last, cap, "%s", e.text);
			}
	}
	return n;
}

static int gap_lines(struct rig *r, int frames, char *last, size_t cap)
{
	return said_lines(r, frames, "X-Plane frames missing", last, cap);
}

UNIT_TEST(app_frames_missing_said_once_a_wall_second)
{
	struct rig *r = rig_hovering(u);
	char last[APP_EVENT_TEXT] = "";
	int lines = 0;
	for (int g = 0; g < 12; g++) { /* 12 gaps of 0.4 s, 3 frames apart: 0.4 s of wall time */
		r->t += 0.4;
		lines += gap_lines(r, 3, last, sizeof last);
	}
	CHECK(lines == 1);
	CHECK(r->a.mode == APP_HOLD);
	r->h.now_us += 1000000u;
	r->t += 0.45;
	CHECK(gap_lines(r, 1, last, sizeof last) == 1);
	CHECK(!strcmp(last, "X-Plane frames missing: 12 gaps, longest 0.46 s"));
}

UNIT_TEST(app_experiment_command_idempotent_and_locks_parameters)
{
	if (!exp_available(1))
		return;
	struct rig *r = rig_hovering(u);
	char why[64] = "";
	int kf = param_index("VEH_KF"), tko = param_index("NAV_TKO_ALT");
	CHECK(kf >= 0 && tko >= 0);
	CHECK(app_cmd_experiment(&r->a, 9.0f, 7, why, sizeof why) == APP_DENIED);
	CHECK(app_cmd_experiment(&r->a, 1.0f, 0x0102, why, sizeof why) == APP_IN_PROGRESS);
	CHECK(r->a.mode == APP_EXPERIMENT);
	CHECK(app_cmd_experiment(&r->a, 1.0f, 0x0102, why, sizeof why) == APP_IN_PROGRESS); /* a retry */
	CHECK(app_cmd_experiment(&r->a, 2.0f, 0x0102, why, sizeof why) == APP_BUSY);
	CHECK(app_cmd_takeoff(&r->a, 4.0f, 7, why, sizeof why) == APP_BUSY);
	fly(r, 10);
	CHECK(r->a.mode == APP_EXPERIMENT);

	float kf_before = params_get(&r->a.p, (size_t)kf);
	const char *no = app_param_write(&r->a, (size_t)kf, kf_before * 1.1f);
	CHECK(no != NULL && strstr(no, "locked") != NULL);
	CHECK(params_get(&r->a.p, (size_t)kf) == kf_before);
	CHECK(app_param_write(&r->a, (size_t)tko, 6.0f) == NULL); /* not a model parameter */

	take_events(&r->a, APP_EV_CMD_DONE, NULL);
	CHECK(app_cmd_experiment(&r->a, 0.0f, 0x0304, why, sizeof why) == APP_ACCEPTED); /* stop */
	CHECK(r->a.mode == APP_HOLD);
	struct app_event done = {0};
	CHECK(take_events(&r->a, APP_EV_CMD_DONE, &done) == 1);
	CHECK(done.cmd == APP_CMD_EXPERIMENT && done.result == APP_FAILED && done.origin == 0x0102);
	CHECK(app_cmd_experiment(&r->a, 0.0f, 0x0304, why, sizeof why) == APP_ACCEPTED); /* a retry */
	CHECK(app_param_write(&r->a, (size_t)kf, kf_before * 1.1f) == NULL);             /* unlocked */
}

UNIT_TEST(app_experiment_refused_unless_hovering)
{
	struct rig *r = rig_new();
	char why[64] = "";
	fly(r, 3);
	CHECK(app_cmd_experiment(&r->a, 1.0f, 1, why, sizeof why) == APP_DENIED);
	CHECK(!strcmp(why, "Experiment 1 refused: not hovering, mode DISARMED"));
	CHECK(r->a.mode == APP_DISARMED);
}

/* seconds of frames rolling at rms_dps (decaying by decay per second from now); the
 * "Attitude oscillation" lines counted, the last kept */
static int fly_rolling(struct rig *r, float seconds, double rms_dps, double decay, char *text, size_t cap)
{
	r->roll_dps = rms_dps;
	r->roll_decay = decay;
	r->roll_t0 = r->t;
	r->f.rate_b_rps[0] = 0.0f;
	return said_lines(r, (int)(seconds * 90.0f), "Attitude oscillation", text, cap);
}

/* The oscillation guard: a decaying roll oscillation (a take-off transient) leaves ATT_WN_RP
 * alone; a sustained one lowers it by 15 %, says so, and refuses experiments (BUSY: later)
 * until the rates are quiet again. */
UNIT_TEST(app_oscillation_guard_detunes_and_holds_experiments)
{
	struct rig *r = rig_hovering(u);
	char text[APP_EVENT_TEXT] = "", why[96] = "";
	CHECK(fly_rolling(r, 4.0f, 20.0, 0.3, text, sizeof text) == 0);
	CHECK(r->a.p.att_wn_rp == 7.0f);
	CHECK(fly_rolling(r, 3.0f, 30.0, 1.0, text, sizeof text) == 1);
	CHECK(fabsf(r->a.p.att_wn_rp - 5.95f) < 1e-5f);
	CHECK(!strncmp(text, "Attitude oscillation 30 deg/s: ATT_WN_RP 7.00 -> 5.95", sizeof text));
	CHECK(app_cmd_experiment(&r->a, 1.0f, 1, why, sizeof why) == APP_BUSY);
	CHECK(strstr(why, "attitude oscillating") != NULL);
	CHECK(r->a.mode == APP_HOLD);
	fly_rolling(r, 2.5f, 0.0, 1.0, text, sizeof text); /* quiet again */
	CHECK(fabsf(r->a.p.att_wn_rp - 5.95f) < 1e-5f);
	CHECK(app_cmd_experiment(&r->a, 1.0f, 1, why, sizeof why) == APP_IN_PROGRESS);
}

/* An oscillation at ATT_WN_RP's minimum: the guard cannot settle it, the vehicle lands. */
UNIT_TEST(app_oscillation_at_the_gains_minimum_lands)
{
	struct rig *r = rig_hovering(u);
	char text[APP_EVENT_TEXT] = "";
	CHECK(app_param_write(&r->a, (size_t)param_index("ATT_WN_RP"), 1.0f) == NULL);
	CHECK(fly_rolling(r, 3.0f, 30.0, 1.0, text, sizeof text) == 1);
	CHECK(!strncmp(text, "Attitude oscillation 30 deg/s: ATT_WN_RP at its minimum", sizeof text));
	CHECK(r->a.mode == APP_LAND);
	CHECK(r->a.p.att_wn_rp == 1.0f);
}

UNIT_TEST(app_identification_results_are_read_only)
{
	struct rig *r = rig_new();
	int est = param_index("ID_KF_EST");
	CHECK(est >= 0);
	const char *no = app_param_write(&r->a, (size_t)est, 1.0f);
	CHECK(no != NULL && strstr(no, "read-only") != NULL);
	CHECK(app_param_write(&r->a, param_count, 1.0f) != NULL); /* no such index */
}

/* The rotor model's settings and the priors it refines are settable on the ground and
 * locked in flight experiments; its results are read-only. */
UNIT_TEST(app_motor_model_parameters_settable_results_read_only)
{
	static const char *const settable[] = {
		"ID_MOT_TAU", "ID_DELAY_FR", "MOT_CURVE",  "ID_CRV_EST", "ID_EXC_OFS", "MOT_SCALE1", "MOT_SCALE2",
		"MOT_SCALE3", "MOT_SCALE4",  "MOT_SCALE5", "MOT_SCALE6", "MOT_SCALE7", "MOT_SCALE8", "MOT_SCALE_MIN",
	};
	static const char *const results[] = {"ID_TAU_SD", "ID_CRV_SD", "ID_MOT_NE", "ID_TAU_CHECK"};
	struct rig *r = rig_new();
	for (size_t i = 0; i < sizeof settable / sizeof settable[0]; i++) {
		int k = param_index(settable[i]);
		CHECK(k >= 0);
		if (k < 0)
			continue;
		const struct param_def *d = &param_defs[k];
		float v = 0.5f * (d->min + d->max);
		const char *no = app_param_write(&r->a, (size_t)k, v);
		if (no != NULL || params_get(&r->a.p, (size_t)k) != v)
			unit_fail(u, __FILE__, __LINE__, "%s not settable: %s", settable[i], no ? no : "value");
		CHECK(d->flags & PARAM_LOCKED);
	}
	for (size_t i = 0; i < sizeof results / sizeof results[0]; i++) {
		int k = param_index(results[i]);
		CHECK(k >= 0);
		if (k < 0)
			continue;
		const char *no = app_param_write(&r->a, (size_t)k, 0.5f);
		if (no == NULL || strstr(no, "read-only") == NULL)
			unit_fail(u, __FILE__, __LINE__, "%s writable", results[i]);
	}
}

/* A rotor's effectiveness (MOT_SCALEj) reaches the mixer and the throttle map: in a level
 * hover with rotor 3 at half effectiveness, the rotors' real thrusts (scale_j k_f T_j, the
 * curve being 0) still give the demanded wrench, the allocation is the least-throttle one
 * (rotor 3 gets less throttle than its neighbours, not twice theirs), and each rotor's thrust
 * command is what its throttle gives. */
UNIT_TEST(app_rotor_scale_reaches_the_mixer_and_throttle_map)
{
	struct rig *r = rig_hovering(u);
	CHECK(fabsf(r->h.thr[2] / r->h.thr[0] - 1.0f) < 0.02f);
	CHECK(app_param_write(&r->a, (size_t)param_index("MOT_SCALE3"), 0.5f) == NULL);
	fly(r, 3);
	const struct app *a = &r->a;
	float kf = a->p.veh_kf, l = a->p.veh_arm_l, k = a->p.veh_ktau / a->p.veh_kf, sq = 0.70710678f;
	static const float tx[8] = {0, -1, -1, -1, 0, 1, 1, 1}, ty[8] = {-1, -1, 0, 1, 1, 1, 0, -1};
	float w[4] = {0, 0, 0, 0};
	for (int j = 0; j < 8; j++) {
		float sc = j == 2 ? 0.5f : 1.0f, f = sc * kf * r->h.thr[j], dg = (j & 1) ? sq : 1.0f;
		CHECK_NEAR(f, sc_to_float(a->mix_out.f_n[j]), 2e-3f * f + 1e-3f);
		w[0] += f;
		w[1] += tx[j] * dg * l * f;
		w[2] += ty[j] * dg * l * f;
		w[3] += ((j & 1) ? -k : k) * f;
	}
	for (int i = 0; i < 4; i++)
		CHECK_NEAR(w[i], sc_to_float(a->mix_out.demanded[i]), i == 0 ? 0.02f : 2e-3f);
	CHECK(r->h.thr[2] < r->h.thr[1] && r->h.thr[2] < r->h.thr[3]);
}

UNIT_TEST(app_parameters_saved_and_loaded)
{
	struct rig *r = rig_new();
	char why[64] = "";
	int tko = param_index("NAV_TKO_ALT");
	CHECK(app_params_load(&r->a, why, sizeof why) == APP_FAILED); /* nothing stored */
	CHECK(app_param_write(&r->a, (size_t)tko, 7.5f) == NULL);
	CHECK(app_params_save(&r->a, why, sizeof why) == APP_ACCEPTED);
	CHECK(strstr(r->h.store, "NAV_TKO_ALT") != NULL);
	CHECK(app_param_write(&r->a, (size_t)tko, 4.0f) == NULL);
	CHECK(app_params_load(&r->a, why, sizeof why) == APP_ACCEPTED);
	CHECK(params_get(&r->a.p, (size_t)tko) == 7.5f);
	r->h.store_fails = true;
	CHECK(app_params_save(&r->a, why, sizeof why) == APP_FAILED);
	CHECK(why[0] != 0);
}

UNIT_TEST(app_status_lines_reach_log_console_and_outbox)
{
	struct rig *r = rig_new();
	char why[64];
	fly(r, 3);
	take_events(&r->a, APP_EV_STATUS, NULL);
	uint32_t events = r->h.n_events, reports = r->h.n_reports;
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED);
	struct app_event e;
	CHECK(take_events(&r->a, APP_EV_STATUS, &e) == 1);
	CHECK(!strcmp(e.text, "Mode IDLE") && e.severity == APP_SEV_INFO);
	CHECK(r->h.n_events == events + 1 && r->h.n_reports == reports + 1);
	CHECK(!strcmp(r->h.last_event, "Mode IDLE"));
}

UNIT_TEST(app_outbox_full_drops_newest)
{
	struct app_outbox o;
	memset(&o, 0, sizeof o);
	struct app_event e = {.kind = APP_EV_PARAM};
	for (int i = 0; i < APP_OUTBOX_LEN + 3; i++) {
		e.param_index = (uint16_t)i;
		outbox_post(&o, &e);
	}
	CHECK(o.dropped == 3);
	for (int i = 0; i < APP_OUTBOX_LEN; i++) {
		CHECK(outbox_pop(&o, &e));
		CHECK(e.param_index == i);
	}
	CHECK(!outbox_pop(&o, &e));
}

/* An experiment turn that posts the most results it can (the rotor model posts 24 at once)
 * together with a status line: every event reaches the ground station, none dropped. */
UNIT_TEST(app_outbox_holds_a_turn_of_results)
{
	struct rig *r = rig_hovering(u);
	int tko = param_index("NAV_TKO_ALT");
	CHECK(tko >= 0 && r->a.outbox.dropped == 0);
	for (int i = 0; i < EXP_MAX_RESULTS; i++)
		r->a.exp.results[i] = (struct exp_result){.param_index = tko, .value = 4.0f + 0.01f * (float)i};
	r->a.exp.n_results = EXP_MAX_RESULTS;
	snprintf(r->a.exp.msg, sizeof r->a.exp.msg, "ID test line");
	r->a.exp.msg_severity = APP_SEV_INFO;
	tick(r);
	CHECK(r->a.outbox.dropped == 0);
	CHECK(r->a.exp.n_results == 0 && r->a.exp.msg[0] == 0);
	CHECK(params_get(&r->a.p, (size_t)tko) == 4.0f + 0.01f * (float)(EXP_MAX_RESULTS - 1));
}

/* The table's flags, set per group of rows, against the rule they stand for:
 * the vehicle model, rotor, mixer and identification rows lock; what the app
 * writes itself (identification results, the hover throttle learned and the k_f
 * tracked in flight: described as such) is read-only. */
UNIT_TEST(app_parameter_flags_follow_their_groups)
{
	for (size_t i = 0; i < param_count; i++) {
		const struct param_def *d = &param_defs[i];
		bool model = !strncmp(d->name, "VEH_", 4) || !strncmp(d->name, "MOT_", 4) ||
			     !strncmp(d->name, "MIX_", 4) || !strncmp(d->name, "ID_", 3);
		bool result = !strncmp(d->desc, "Result (read-only)", 18) ||
			      !strncmp(d->desc, "Learned (read-only)", 19) ||
			      !strncmp(d->desc, "Tracked (read-only)", 19);
		if (model != !!(d->flags & PARAM_LOCKED) || result != !!(d->flags & PARAM_READONLY))
			unit_fail(u, __FILE__, __LINE__, "%s: flags %u", d->name, d->flags);
	}
}

/* Frames for `seconds` without app_tick (with it when r->collect_ticks), the outbox
 * drained after each: the status lines that start with `prefix` counted (the last kept in
 * `text`), the final results (APP_EV_CMD_DONE) counted (the last kept in *done). */
static int fly_collect(struct rig *r, float seconds, const char *prefix, char *text, size_t cap, int *n_done,
		       struct app_event *done)
{
	int n_text = 0;
	for (int i = 0; i < (int)(seconds * 90.0f); i++) {
		r->t += 1.0 / 90.0;
		r->h.now_us += FRAME_US;
		frame_at(r, r->t);
		if (r->collect_ticks)
			app_tick(&r->a);
		struct app_event e;
		while (app_next_event(&r->a, &e)) {
			if (e.kind == APP_EV_STATUS && !strncmp(e.text, prefix, strlen(prefix))) {
				n_text++;
				snprintf(text, cap, "%s", e.text);
			}
			if (e.kind == APP_EV_CMD_DONE) {
				(*n_done)++;
				*done = e;
			}
		}
	}
	return n_text;
}

/* A vehicle that cannot lift off: take-off runs out of NAV_TKO_TO, says why (what
 * height it reached of what), gives the take-off's requester its final FAILED
 * and lands; the learned hover values stay read-only from outside. */
UNIT_TEST(app_takeoff_time_limit_fails_to_its_origin)
{
	struct rig *r = rig_new();
	char why[64], text[APP_EVENT_TEXT] = "";
	const float limit = 3.0f;
	CHECK(app_param_write(&r->a, (size_t)param_index("NAV_TKO_TO"), limit) == NULL);
	CHECK(app_param_write(&r->a, (size_t)param_index("HOV_THR"), 0.5f) != NULL);
	CHECK(app_param_write(&r->a, (size_t)param_index("KFT_EST"), 20.0f) != NULL);
	r->stuck = true;
	r->z_stuck = 0.0f;
	fly(r, 5);
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED);
	const app_origin origin = 0x0102u;
	CHECK(app_cmd_takeoff(&r->a, 4.0f, origin, why, sizeof why) == APP_ACCEPTED);
	int n_done = 0;
	struct app_event done;
	memset(&done, 0, sizeof done);
	int n = fly_collect(r, limit - 0.5f, "Take-off failed", text, sizeof text, &n_done, &done);
	CHECK(n == 0 && n_done == 0 && r->a.mode == APP_TAKEOFF); /* not before its limit */
	n = fly_collect(r, 1.0f, "Take-off failed", text, sizeof text, &n_done, &done);
	CHECK(n == 1);
	char want[64];
	snprintf(want, sizeof want, "Take-off failed: NAV_TKO_TO %.0f s, 0.00/4.00 m", (double)limit);
	CHECK(!strcmp(text, want));
	CHECK(n_done == 1);
	CHECK(done.cmd == APP_CMD_TAKEOFF && done.result == APP_FAILED && done.origin == origin);
	CHECK(r->a.mode == APP_LAND || r->a.mode == APP_DISARMED);
	n = fly_collect(r, 3.0f, "Take-off failed", text, sizeof text, &n_done, &done);
	CHECK(n == 0 && n_done == 1); /* said once; the landing it became answers no one */
	CHECK(r->a.mode == APP_DISARMED);
}

/* Commanded during the take-off, an experiment waits (IN_PROGRESS, said once, retries
 * answered IN_PROGRESS, another experiment BUSY) and starts once the vehicle hovers. */
UNIT_TEST(app_experiment_commanded_in_the_take_off_waits_and_starts)
{
	struct rig *r = rig_new();
	char why[64] = "", text[APP_EVENT_TEXT] = "";
	fly(r, 5);
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED);
	CHECK(app_cmd_takeoff(&r->a, 3.0f, 7, why, sizeof why) == APP_ACCEPTED);
	fly(r, 2);
	CHECK(r->a.mode == APP_TAKEOFF);
	take_events(&r->a, APP_EV_STATUS, NULL);
	CHECK(app_cmd_experiment(&r->a, 1.0f, 0x0203, why, sizeof why) == APP_IN_PROGRESS);
	CHECK(app_cmd_experiment(&r->a, 1.0f, 0x0203, why, sizeof why) == APP_IN_PROGRESS);
	CHECK(app_cmd_experiment(&r->a, 2.0f, 0x0203, why, sizeof why) == APP_BUSY);
	CHECK(!strcmp(why, "Experiment 1 waits for the hover"));
	r->collect_ticks = true;
	int n_done = 0, n_wait = 0;
	struct app_event done = {0};
	for (int k = 0; k < 60 * 10 && r->a.mode != APP_EXPERIMENT; k++)
		n_wait += fly_collect(r, 0.1f, "Experiment 1 waits", text, sizeof text, &n_done, &done);
	CHECK(n_wait == 1 && !strcmp(text, "Experiment 1 waits: taking off"));
	CHECK(r->a.mode == APP_EXPERIMENT && n_done == 0 && r->a.exp.id == 1);
}

/* Not hovering in HOLD (the vehicle held 1 m below its target): the experiment waits,
 * then fails to its requester after 30 s of plant time, saying why; a landing ends a wait
 * at once. */
UNIT_TEST(app_experiment_waiting_fails_with_its_reason)
{
	struct rig *r = rig_hovering(u);
	char why[64] = "", text[APP_EVENT_TEXT] = "";
	r->stuck = true;
	r->z_stuck = sc_to_float(r->a.guid.z_target_m) - 1.0f;
	r->collect_ticks = true;
	int n_done = 0;
	struct app_event done = {0};
	fly_collect(r, 0.1f, "", text, sizeof text, &n_done, &done);
	CHECK(app_cmd_experiment(&r->a, 3.0f, 0x0405, why, sizeof why) == APP_IN_PROGRESS);
	CHECK(fly_collect(r, 29.0f, "Experiment 3", text, sizeof text, &n_done, &done) == 1);
	CHECK(!strcmp(text, "Experiment 3 waits: height -1.00 m off (0.30)") && n_done == 0);
	CHECK(fly_collect(r, 2.0f, "Experiment 3", text, sizeof text, &n_done, &done) == 1);
	CHECK(!strcmp(text, "Experiment 3 not started: 30 s, height -1.00 m off (0.30)"));
	CHECK(n_done == 1 && done.cmd == APP_CMD_EXPERIMENT && done.result == APP_FAILED && done.origin == 0x0405);
	CHECK(r->a.mode == APP_HOLD && r->a.exp_wait.id == 0);

	CHECK(app_cmd_experiment(&r->a, 4.0f, 0x0405, why, sizeof why) == APP_IN_PROGRESS);
	CHECK(app_cmd_land(&r->a, 7, why, sizeof why) == APP_ACCEPTED);
	n_done = 0;
	CHECK(fly_collect(r, 0.1f, "Experiment 4 not", text, sizeof text, &n_done, &done) == 1);
	CHECK(!strcmp(text, "Experiment 4 not started: mode LAND"));
	CHECK(n_done == 1 && done.result == APP_FAILED && done.origin == 0x0405);
}

/* The tracked k_f's update and publication (KFT_* parameters, their PARAM_VALUE and
 * NAMED_VALUE_FLOAT events, a VEH_KF refresh) are between-frames work: the step only leaves
 * the tracker its input; the app_tick after it updates the tracker and, when that frame
 * reaches the next second of plant time, publishes what it saw. */
UNIT_TEST(app_kft_published_between_frames_after_its_step)
{
	struct rig *r = rig_hovering(u);
	fly(r, 3 * 90); /* the tracker has started and published */
	const int i_t = param_index("KFT_T"), i_est = param_index("KFT_EST");
	CHECK(params_get(&r->a.p, (size_t)i_t) > 0.0f);
	int published = 0;
	for (int i = 0; i < 3 * 90; i++) {
		float t_before = params_get(&r->a.p, (size_t)i_t);
		r->t += 1.0 / 90.0;
		r->h.now_us += FRAME_US;
		frame_at(r, r->t);
		struct app_event e;
		while (app_next_event(&r->a, &e)) /* the step posts no KFT event */
			CHECK(!(e.kind == APP_EV_VALUE ||
				(e.kind == APP_EV_PARAM && (e.param_index == i_t || e.param_index == i_est))));
		CHECK(params_get(&r->a.p, (size_t)i_t) == t_before);
		/* the tracker takes the frame at the frame boundary (app_settle in the tick): due
		 * when its update reaches the next second of plant time */
		CHECK(r->a.after.kf_due);
		bool due = r->a.env_kf.kft.started && !app_t_before(r->a.fr.t_s, r->a.env_kf.pub_next_t);
		tick(r);
		float t_after = params_get(&r->a.p, (size_t)i_t);
		if (due) {
			published++;
			CHECK(t_after == (float)r->t); /* the plant time of the step that was due */
			CHECK(params_get(&r->a.p, (size_t)i_est) == sc_to_float(r->a.env_kf.kft.k));
		} else {
			CHECK(t_after == t_before);
		}
	}
	CHECK(published >= 2 && published <= 3); /* once a second of plant time, in 3 s */
}

/* The HOLD entry's HOV_* parameters and "Hover throttle" status line are formatted between
 * frames too: the step that enters HOLD posts neither, nor computes them; the app_tick after
 * it publishes what the hover had taught by the end of that step. */
UNIT_TEST(app_hold_entry_published_between_frames)
{
	struct rig *r = rig_new();
	char why[64];
	fly(r, 5);
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED);
	CHECK(app_cmd_takeoff(&r->a, 3.0f, 7, why, sizeof why) == APP_ACCEPTED);
	const int i_thr = param_index("HOV_THR");
	float thr0 = params_get(&r->a.p, (size_t)i_thr);
	int i = 0;
	for (; i < 90 * 60 && r->a.mode != APP_HOLD; i++) {
		r->t += 1.0 / 90.0;
		r->h.now_us += FRAME_US;
		frame_at(r, r->t);
		if (r->a.mode != APP_HOLD) {
			tick(r);
			continue;
		}
		struct app_event e;
		int mode_hold = 0;
		while (app_next_event(&r->a, &e)) {
			CHECK(!(e.kind == APP_EV_STATUS && !strncmp(e.text, "Hover throttle", 14)));
			CHECK(!(e.kind == APP_EV_PARAM && e.param_index == i_thr));
			mode_hold += e.kind == APP_EV_STATUS && !strcmp(e.text, "Mode HOLD");
		}
		CHECK(mode_hold == 1);
		CHECK(params_get(&r->a.p, (size_t)i_thr) == thr0);
		/* computed between frames, from hover learning as the entry's step left it */
		float now = sc_to_float(hover_est_u_ahead(&r->a.env_hover.hov));
		tick(r);
		CHECK(now > 0.0f && params_get(&r->a.p, (size_t)i_thr) == now);
	}
	CHECK(r->a.mode == APP_HOLD && i < 90 * 60);
}

/* A vehicle that cannot come down: landing runs out of NAV_LAND_TO, says so once
 * with the height, the landing's requester gets FAILED, and it keeps landing. */
UNIT_TEST(app_landing_time_limit_fails_to_its_origin)
{
	struct rig *r = rig_hovering(u);
	char why[64], text[APP_EVENT_TEXT] = "";
	CHECK(app_param_write(&r->a, (size_t)param_index("NAV_LAND_TO"), 1.0f) == NULL);
	r->stuck = true;
	r->z_stuck = r->f.pos_i_m[2];
	take_events(&r->a, APP_EV_STATUS, NULL);
	const app_origin origin = 0x0BEEu;
	CHECK(app_cmd_land(&r->a, origin, why, sizeof why) == APP_ACCEPTED);
	int n_done = 0;
	struct app_event done;
	memset(&done, 0, sizeof done);
	int n = fly_collect(r, 3.0f, "Landing failed", text, sizeof text, &n_done, &done);
	CHECK(n == 1);
	char want[64];
	snprintf(want, sizeof want, "Landing failed: NAV_LAND_TO 1 s, %.2f m up", (double)r->z_stuck);
	CHECK(!strcmp(text, want));
	CHECK(n_done == 1 && done.cmd == APP_CMD_LAND && done.result == APP_FAILED && done.origin == origin);
	CHECK(r->a.mode == APP_LAND);
	/* freed, it lands: the limit did not stop the landing */
	r->stuck = false;
	fly_until(r, APP_DISARMED, 90 * 60);
	CHECK(r->a.mode == APP_DISARMED);
}

/* ---------------------------------------------------------------- what the step says
 *
 * The step formats no status line: it records what it says (struct app_said), and the pass
 * between frames says it, in the order the step said it, with the text it had. */

#define SAID_MAX 32
struct said_log {
	int n;
	char line[SAID_MAX][APP_EVENT_TEXT]; /* a status line's text; a final answer as "DONE cmd result origin" */
};

/* The outbox's status lines and final answers, in order, appended to s (app_next_event: what
 * the last step said comes first). */
static void said_take(struct rig *r, struct said_log *s)
{
	struct app_event e;
	while (app_next_event(&r->a, &e)) {
		if (s->n >= SAID_MAX)
			continue;
		if (e.kind == APP_EV_STATUS)
			snprintf(s->line[s->n++], APP_EVENT_TEXT, "%s", e.text);
		else if (e.kind == APP_EV_CMD_DONE)
			snprintf(s->line[s->n++], APP_EVENT_TEXT, "DONE %u %u %x", (unsigned)e.cmd, (unsigned)e.result,
				 (unsigned)e.origin);
	}
}

/* One frame dt_plant after the last (the wall clock a frame on): the pass between frames
 * before it, then its step, which says nothing during the step (no console line, no log
 * event); then what it said, into *s in order, each line also on the console and in the log. */
static void step_said(struct unit_ctx *u, struct rig *r, double dt_plant, struct said_log *s)
{
	app_settle(&r->a);
	struct said_log older = {0};
	said_take(r, &older);
	memset(s, 0, sizeof *s);
	r->t += dt_plant;
	r->h.now_us += FRAME_US;
	uint32_t reports = r->h.n_reports, events = r->h.n_events;
	frame_at(r, r->t);
	CHECK(r->h.n_reports == reports && r->h.n_events == events);
	said_take(r, s);
	int lines = 0;
	for (int i = 0; i < s->n; i++)
		lines += strncmp(s->line[i], "DONE ", 5) != 0;
	CHECK(r->h.n_reports == reports + (uint32_t)lines && r->h.n_events == events + (uint32_t)lines);
	if (lines > 0) { /* the console's and the log's last line: the outbox's last status line */
		int last = s->n - 1;
		while (!strncmp(s->line[last], "DONE ", 5))
			last--;
		CHECK(!strcmp(r->h.last_report, s->line[last]) && !strcmp(r->h.last_event, s->line[last]));
	}
}

/* Between frames only (app_tick without MAVLink) for `seconds` of wall time: no frames. */
static void silence(struct rig *r, double seconds)
{
	for (int i = 0; i < (int)(seconds * 1e6 / FRAME_US); i++) {
		r->h.now_us += FRAME_US;
		app_tick(&r->a);
	}
}

UNIT_TEST(app_step_lines_said_between_frames_in_order)
{
	struct rig *r = rig_hovering(u);
	struct said_log s;
	char why[64];
	/* the plant moves its origin: the step that absorbs the shift */
	r->f.pos_i_m[0] = 1000.0f;
	step_said(u, r, 1.0 / 90.0, &s);
	CHECK(s.n == 1 && !strcmp(s.line[0], "Plant moved its local origin (1000 m): position re-referenced"));
	fly(r, 2 * 90);
	/* frames missing in plant time, fewer than FS_LAND_AFTER: 45 frame periods */
	step_said(u, r, 0.5, &s);
	CHECK(s.n == 1 && !strcmp(s.line[0], "X-Plane frames missing for 0.50 s"));
	CHECK(r->a.mode == APP_HOLD);
	fly(r, 2 * 90);
	/* the link lost (between frames) and back within FS_LAND_AFTER (the step) */
	s.n = 0;
	silence(r, 0.5);
	said_take(r, &s);
	CHECK(s.n == 1 && !strcmp(s.line[0], "X-Plane link lost (no frames)"));
	step_said(u, r, 1.0 / 90.0, &s);
	CHECK(s.n == 1 && !strncmp(s.line[0], "X-Plane link back after 0.5", 27));
	CHECK(r->a.mode == APP_HOLD);
	fly(r, 2 * 90);
	/* an experiment aborted in the step: its reason, the command's FAILED, the mode; refused
	 * within 10 s of the last gap (4 s ago here), saying so */
	if (exp_available(1)) {
		CHECK(app_cmd_experiment(&r->a, 1.0f, 0x0A0B, why, sizeof why) == APP_BUSY);
		CHECK(!strncmp(why, "Experiment 1 refused: frames lost 4.0 s ago", 43));
		fly(r, 8 * 90);
		CHECK(app_cmd_experiment(&r->a, 1.0f, 0x0A0B, why, sizeof why) == APP_IN_PROGRESS);
		fly(r, 10);
		step_said(u, r, 0.5, &s);
		CHECK(s.n == 4);
		CHECK(!strcmp(s.line[0], "X-Plane frames missing for 0.50 s"));
		CHECK(!strcmp(s.line[1], "ID aborted: X-Plane frames missing"));
		CHECK(!strcmp(s.line[2], "DONE 1 4 a0b")); /* APP_CMD_EXPERIMENT, APP_FAILED */
		CHECK(!strcmp(s.line[3], "Mode HOLD"));
		CHECK(r->a.mode == APP_HOLD);
		fly(r, 2 * 90);
	}
	/* the link lost for longer than FS_LAND_AFTER: back, the landing said, the mode */
	s.n = 0;
	silence(r, (double)r->a.p.fs_land_after + 0.5);
	said_take(r, &s);
	CHECK(s.n == 1 && !strcmp(s.line[0], "X-Plane link lost (no frames)"));
	step_said(u, r, 1.0 / 90.0, &s);
	CHECK(s.n == 3);
	CHECK(!strncmp(s.line[0], "X-Plane link back after 2.", 26));
	CHECK(!strcmp(s.line[1], "Link was lost for more than 2.0 s: landing"));
	CHECK(!strcmp(s.line[2], "Mode LAND"));
	CHECK(r->a.mode == APP_LAND);
	/* the step that lands: "Landed", then the mode */
	for (int i = 0; i < 90 * 60 && r->a.mode != APP_DISARMED; i++)
		step_said(u, r, 1.0 / 90.0, &s);
	CHECK(r->a.mode == APP_DISARMED);
	CHECK(s.n == 2 && !strcmp(s.line[0], "Landed") && !strcmp(s.line[1], "Mode DISARMED"));
	/* take-off (a command: said at once), then the step that reaches HOLD */
	fly(r, 5);
	s.n = 0;
	said_take(r, &s);
	s.n = 0;
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED);
	CHECK(app_cmd_takeoff(&r->a, 3.0f, 7, why, sizeof why) == APP_ACCEPTED);
	said_take(r, &s);
	CHECK(s.n == 3 && !strcmp(s.line[0], "Mode IDLE") && !strcmp(s.line[1], "Takeoff to 3.00 m") &&
	      !strcmp(s.line[2], "Mode TAKEOFF"));
	for (int i = 0; i < 90 * 60 && r->a.mode != APP_HOLD; i++)
		step_said(u, r, 1.0 / 90.0, &s);
	CHECK(r->a.mode == APP_HOLD);
	CHECK(s.n == 1 && !strcmp(s.line[0], "Mode HOLD"));
	/* a parameter change between frames: its step says nothing */
	CHECK(app_param_write(&r->a, (size_t)param_index("ATT_WN_RP"), 6.5f) == NULL);
	step_said(u, r, 1.0 / 90.0, &s);
	CHECK(s.n == 0);
}

/* The time limits of take-off and landing, said from the step: the reason (and what was
 * missing), the command's FAILED, then the landing's mode. */
UNIT_TEST(app_step_phase_limits_said_in_order)
{
	struct rig *r = rig_new();
	struct said_log s;
	char why[64];
	CHECK(app_param_write(&r->a, (size_t)param_index("NAV_TKO_TO"), 1.0f) == NULL);
	r->stuck = true;
	r->z_stuck = 0.0f;
	fly(r, 5);
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED);
	CHECK(app_cmd_takeoff(&r->a, 4.0f, 0x0102u, why, sizeof why) == APP_ACCEPTED);
	int i = 0;
	for (; i < 3 * 90 && r->a.mode == APP_TAKEOFF; i++)
		step_said(u, r, 1.0 / 90.0, &s);
	CHECK(r->a.mode == APP_LAND);
	CHECK(s.n == 3 || s.n == 4);
	CHECK(!strcmp(s.line[0], "Take-off failed: NAV_TKO_TO 1 s, 0.00/4.00 m"));
	CHECK(s.n == 3 || !strncmp(s.line[1], "Hover throttle ", 15));
	CHECK(!strcmp(s.line[s.n - 2], "DONE 2 4 102")); /* APP_CMD_TAKEOFF, APP_FAILED */
	CHECK(!strcmp(s.line[s.n - 1], "Mode LAND"));

	r = rig_hovering(u);
	CHECK(app_param_write(&r->a, (size_t)param_index("NAV_LAND_TO"), 1.0f) == NULL);
	r->stuck = true;
	r->z_stuck = r->f.pos_i_m[2];
	CHECK(app_cmd_land(&r->a, 0x0BEEu, why, sizeof why) == APP_ACCEPTED);
	int said = 0;
	for (i = 0; i < 2 * 90 && !said; i++) {
		step_said(u, r, 1.0 / 90.0, &s);
		said = s.n;
	}
	CHECK(s.n == 2);
	char want[64];
	snprintf(want, sizeof want, "Landing failed: NAV_LAND_TO 1 s, %.2f m up", (double)r->z_stuck);
	CHECK(!strcmp(s.line[0], want));
	CHECK(!strcmp(s.line[1], "DONE 3 4 bee")); /* APP_CMD_LAND, APP_FAILED */
	CHECK(r->a.mode == APP_LAND);
}

/* More than the ring holds in one step: the ring's lines said at once, in the step, and the
 * rest after them; nothing lost, the order kept, the overflow counted and reported. */
UNIT_TEST(app_step_said_ring_full_said_in_order)
{
	struct rig *r = rig_hovering(u);
	struct said_log s = {0};
	said_take(r, &s);
	memset(&s, 0, sizeof s);
	uint32_t reports = r->h.n_reports;
	r->a.said.in_step = true; /* as in a step */
	for (int i = 0; i < APP_SAID_LEN + 4; i++)
		app_status(&r->a, APP_SEV_INFO, "line %d %.1f", i, 0.5);
	CHECK(r->h.n_reports == reports + APP_SAID_LEN); /* the full ring, said in the step */
	r->a.said.in_step = false;
	said_take(r, &s);
	CHECK(s.n == APP_SAID_LEN + 5);
	char want[APP_EVENT_TEXT];
	for (int i = 0, k = 0; i < s.n && k < APP_SAID_LEN + 4; i++) {
		if (i == APP_SAID_LEN) {
			snprintf(want, sizeof want, "Step said over %d lines 1 times: said in the step", APP_SAID_LEN);
			CHECK(!strcmp(s.line[i], want));
			continue;
		}
		snprintf(want, sizeof want, "line %d 0.5", k++);
		CHECK(!strcmp(s.line[i], want));
	}
	CHECK(r->a.said.overflows == 1 && r->a.said.n == 0);
}

/* app_t_before (the per-frame plant-time comparisons by integer operations) gives the IEEE
 * answer of a < b: special values pairwise (zeros of both signs, subnormals, infinities,
 * NaNs of both signs) and random pairs (any bit pattern; neighbours one ulp apart; plant
 * times a frame apart). */
static uint64_t xs64(uint64_t *s)
{
	*s ^= *s << 13;
	*s ^= *s >> 7;
	*s ^= *s << 17;
	return *s;
}

static double dbl_of_bits(uint64_t u)
{
	union {
		uint64_t u;
		double d;
	} v = {u};
	return v.d;
}

UNIT_TEST(app_t_before_is_the_ieee_order)
{
	const double sp[] = {0.0,
			     -0.0,
			     dbl_of_bits(1u),
			     -dbl_of_bits(1u),
			     1.0,
			     -1.0,
			     1e-300,
			     -1e-300,
			     1.7976931348623157e308,
			     -1.7976931348623157e308,
			     INFINITY,
			     -INFINITY,
			     dbl_of_bits(0x7ff8000000000000u),
			     dbl_of_bits(0xfff8000000000001u),
			     dbl_of_bits(0x7ff0000000000001u),
			     12.345678,
			     12.345678 + 1.0 / 90.0};
	const int n_sp = (int)(sizeof sp / sizeof sp[0]);
	int bad = 0;
	for (int i = 0; i < n_sp; i++)
		for (int j = 0; j < n_sp; j++)
			bad += app_t_before(sp[i], sp[j]) != (sp[i] < sp[j]);
	CHECK(bad == 0);
	uint64_t s = 0x9E3779B97F4A7C15u;
	for (int k = 0; k < 20000; k++) {
		uint64_t ua = xs64(&s), ub = xs64(&s);
		double a = dbl_of_bits(ua), b = dbl_of_bits(ub);
		bad += app_t_before(a, b) != (a < b);
		double c = dbl_of_bits(ua ^ (ub & 3u)); /* a neighbour of a, or a itself */
		bad += app_t_before(a, c) != (a < c) || app_t_before(c, a) != (c < a);
		double t = (double)(ub >> 40) / 90.0, t1 = t + 1.0 / 90.0, tm = -t;
		bad += app_t_before(t, t1) != (t < t1) || app_t_before(t1, t) != (t1 < t) ||
		       app_t_before(tm, t) != (tm < t) || app_t_before(t, tm) != (t < tm);
	}
	CHECK(bad == 0);
}

/* the float comparisons of fcmp.h by integer operations (the form Cortex-M0 runs) give the
 * IEEE answers of <, <= and ==: special values pairwise and random pairs (any bit pattern;
 * neighbours; frame periods) */
static float flt_of_bits(uint32_t u)
{
	union {
		uint32_t u;
		float f;
	} v = {u};
	return v.f;
}

static int fcmp_wrong(float a, float b)
{
	return (app_f_lt_bits(a, b) != (a < b)) + (app_f_le_bits(a, b) != (a <= b)) +
	       (app_f_eq_bits(a, b) != (a == b)) + (app_f_lt(a, b) != (a < b)) + (app_f_le(a, b) != (a <= b)) +
	       (app_f_eq(a, b) != (a == b));
}

UNIT_TEST(app_f_cmp_is_the_ieee_order)
{
	const float sp[] = {0.0f,
			    -0.0f,
			    flt_of_bits(1u),
			    -flt_of_bits(1u),
			    1.0f,
			    -1.0f,
			    1e-38f,
			    -1e-38f,
			    3.4028235e38f,
			    -3.4028235e38f,
			    INFINITY,
			    -INFINITY,
			    flt_of_bits(0x7fc00000u),
			    flt_of_bits(0xffc00001u),
			    flt_of_bits(0x7f800001u),
			    1.0f / 90.0f,
			    0.2f,
			    0.3f};
	const int n_sp = (int)(sizeof sp / sizeof sp[0]);
	int bad = 0;
	for (int i = 0; i < n_sp; i++)
		for (int j = 0; j < n_sp; j++)
			bad += fcmp_wrong(sp[i], sp[j]);
	CHECK(bad == 0);
	uint64_t s = 0x2545F4914F6CDD1Du;
	for (int k = 0; k < 50000; k++) {
		uint64_t r = xs64(&s);
		uint32_t ua = (uint32_t)r, ub = (uint32_t)(r >> 32);
		float a = flt_of_bits(ua), b = flt_of_bits(ub), c = flt_of_bits(ua ^ (ub & 3u));
		float t = (float)(ub >> 8) * 1e-9f, t1 = flt_of_bits(ua & 0x80000000u ? ub : ub + 1u);
		bad += fcmp_wrong(a, b) + fcmp_wrong(a, c) + fcmp_wrong(c, a) + fcmp_wrong(t, 1.0f / 90.0f) +
		       fcmp_wrong(b, t1) + fcmp_wrong(t1, b) + fcmp_wrong(-t, t);
	}
	CHECK(bad == 0);
}

/* What the app's conversions of the log rely on (boundary.h: bnd_excitation_to_float, bnd_kept_to_float):
 * a scalar and its negation convert to floats of opposite sign, 0 to +0.0f and +0.0f to 0,
 * over random scalars of every magnitude. */
UNIT_TEST(app_sc_to_float_is_odd)
{
	int bad = 0;
	uint64_t s = 0x853C49E6748FEA9Bu;
	for (int k = 0; k < 100000; k++) {
		uint64_t r = xs64(&s);
#if OCTO_FIXED
		scalar_t v = (scalar_t)((uint32_t)r >> (r >> 59)); /* 0 .. INT32_MAX, any magnitude */
		if (v < 0)
			v = -(v + 1);
		bad += sc_to_float(-v) != -sc_to_float(v) || (signbit(sc_to_float(-v)) != 0) != (v != 0);
#else
		float v = flt_of_bits((uint32_t)r & 0x7fffffffu);
		bad += !isnan(v) && (sc_to_float(-v) != -sc_to_float(v));
#endif
	}
	union {
		float f;
		uint32_t u;
	} z = {sc_to_float(SC_ZERO)};
	CHECK(z.u == 0u && sc_from_float(0.0f) == SC_ZERO);
	CHECK(bad == 0);
}

/* app_t_gap is (float)(t - t_prev) bit for bit: plant times a frame apart (and jittered,
 * and many frames apart), neighbours, random bit patterns, special values. */
static int gap_wrong(double t, double tp)
{
	float g = app_t_gap(t, tp), want = (float)(t - tp);
	union {
		float f;
		uint32_t u;
	} x = {g}, y = {want};
	return x.u != y.u && !(isnan(g) && isnan(want));
}

UNIT_TEST(app_t_gap_is_the_float_of_the_difference)
{
	const double sp[] = {0.0,        -0.0,      dbl_of_bits(1u),
			     1.0,        -1.0,      2.0,
			     1e-300,     1e300,     1.7976931348623157e308,
			     INFINITY,   -INFINITY, dbl_of_bits(0x7ff8000000000000u),
			     1.0 / 90.0, 3.0,       4.0,
			     1.5,        0.75,      1e-40,
			     1e-38};
	const int n_sp = (int)(sizeof sp / sizeof sp[0]);
	int bad = 0;
	for (int i = 0; i < n_sp; i++)
		for (int j = 0; j < n_sp; j++)
			bad += gap_wrong(sp[i], sp[j]);
	CHECK(bad == 0);
	uint64_t s = 0xD1B54A32D192ED03u;
	for (int k = 0; k < 200000; k++) {
		uint64_t r = xs64(&s), r2 = xs64(&s);
		double t = (double)(r >> 40) / 90.0, t1 = (double)((r >> 40) + 1u + (r2 & 7u)) / 90.0;
		double j = t1 + (double)((int)(r2 >> 60) - 8) * 1e-5;
		bad += gap_wrong(t1, t) + gap_wrong(j, t) + gap_wrong(t, j);
		double a = dbl_of_bits(r), b = dbl_of_bits(r2), c = dbl_of_bits(r ^ (r2 & 0xffffu));
		double d = dbl_of_bits((r & 0x800fffffffffffffu) | ((r2 & 0x7fe0000000000000u) >> 1));
		/* in [1, 2) and in [1, 4): exponents equal or one apart */
		double e2 = dbl_of_bits((r & 0x000fffffffffffffu) + 0x3ff0000000000000u);
		double f2 = dbl_of_bits((r2 & 0x000fffffffffffffu) + 0x3ff0000000000000u + ((r >> 63) << 52));
		bad += gap_wrong(a, b) + gap_wrong(a, c) + gap_wrong(c, a) + gap_wrong(d, c) + gap_wrong(e2, f2) +
		       gap_wrong(f2, e2);
		/* differences of every length at exponents equal or one apart: the rounding cases */
		double g2 = dbl_of_bits(0x3ff0000000000000u + (r2 >> (12 + (r & 63u) % 52u)));
		bad += gap_wrong(f2, g2) + gap_wrong(g2, e2);
		/* the rounding's edge cases, from a difference D of the mantissas (t_prev = 1 + 2^-52):
		 * ties and near-ties after the float's 24 bits (q even and odd), a round-up to the next
		 * power of two, and 54-bit differences whose double subtraction rounds (then the
		 * float of the rounded double, which can differ from the exact difference's) */
		uint64_t q = (r & 0xffffffu) | 0x800000u, mb = (1ull << 52) + 1u;
		unsigned sh = 1u + (unsigned)(r2 % 28u);
		uint64_t tie = (q << sh) | (1ull << (sh - 1u)),
			 over = (0xffffffull << sh) | (3ull << (sh - 2u + (sh < 2u)));
		const uint64_t dd[] = {tie,
				       tie + 1u,
				       tie - 1u,
				       over,
				       q << sh,
				       (q << 30) | 0x3fffffffu,
				       (((q & 0xefffffu) | 1u) << 30) | 0x1fffffffu,
				       ((q & 0xeffffeu) << 30) | 0x1fffffffu};
		for (int k2 = 0; k2 < 8; k2++) {
			uint64_t d2 = dd[k2], ma = mb + d2; /* same exponent while ma < 2^53 */
			double tp = dbl_of_bits(0x3ff0000000000001u);
			if (ma < (1ull << 53))
				bad += gap_wrong(dbl_of_bits((ma - (1ull << 52)) | 0x3ff0000000000000u), tp);
			else if (!((d2 + mb) & 1u) && (d2 + mb) / 2u < (1ull << 53)) /* t in [2, 4) */
				bad += gap_wrong(dbl_of_bits(((d2 + mb) / 2u - (1ull << 52)) | 0x4000000000000000u),
						 tp);
		}
	}
	CHECK(bad == 0);
}

/* The torque gain against the k_f hover learning finds (env_hover_torque_scale): r = VEH_KF /
 * k_f below 1 (down to 0.1), r / 2 above 2 (up to 10), 1 between (a thrust curve's secant
 * overstates the slope); said when above 1 or below 1/2; 1 before the hover is known. */
UNIT_TEST(env_hover_torque_gain_follows_the_learned_kf)
{
	struct app_params p;
	params_defaults(&p);
	p.veh_mass = 1.2f;
	p.veh_kf = 20.0f;
	struct env_hover h;
	memset(&h, 0, sizeof h);
	env_hover_init(&h, &p);
	env_hover_model_sync(&h, &p);
	float mg = p.veh_mass * p.veh_grav;
	h.hf = sc_from_float(2.0f * mg);
	h.hf_ok = true;
	env_hover_torque_scale(&h, &p); /* nothing learned: 1 */
	CHECK(sc_to_float(h.tau_k_target) == 1.0f && !env_hover_alloc_learned(&h));
	h.hov.p_pct2 = SC(1.0); /* u_h known to 1 % */
	static const struct {
		float kf, k;
		bool alloc;
	} c[] = {{3.87f, 10.0f / 3.87f, true}, {8.0f, 1.25f, true},           {12.0f, 1.0f, false},
		 {20.0f, 1.0f, false},         {28.0f, 20.0f / 28.0f, false}, {50.0f, 0.4f, true},
		 {80.0f, 0.25f, true},         {400.0f, 0.1f, true},          {1.0f, 10.0f, true}};
	for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
		float u_h = mg / (8.0f * c[i].kf); /* the hover throttle of a vehicle of that k_f */
		h.hf = sc_from_float(8.0f * p.veh_kf * u_h);
		env_hover_torque_scale(&h, &p);
		CHECK_REL(sc_to_float(h.tau_k_target), c[i].k, 2e-3);
		CHECK(env_hover_alloc_learned(&h) == c[i].alloc);
	}
}

/* The rotor experiment's throttle sweep, losing every `lose`-th frame (0: none): the rises
 * seen (steps), those that lost frames, those that lasted more plant frames than their plan,
 * and the rotor phase's count of patterns flown and cut (rows_level). */
struct sweep_seen {
	int steps, lost_in_step, over;
	uint32_t n_pat, n_cut;
};
static struct sweep_seen sweep_fly(struct unit_ctx *u, int lose)
{
	struct sweep_seen s = {0, 0, 0, 0u, 0u};
	struct rig *r = rig_hovering(u);
	char why[64] = "";
	CHECK(app_cmd_experiment(&r->a, 1.0f, 7, why, sizeof why) == APP_IN_PROGRESS);
	const struct experiment *e = &r->a.exp;
	long first = -1, last = -1, frame = 0;
	int lost_since = 0;
	for (int i = 0; i < 90 * 40 && r->a.mode == APP_EXPERIMENT; i++) {
		r->t += 1.0 / 90.0;
		r->h.now_us += FRAME_US;
		frame++;
		if (lose > 0 && i % lose == lose - 1) { /* lost: the plant holds the last throttles */
			lost_since++;
			continue;
		}
		frame_at(r, r->t);
		tick(r);
		if (r->a.mode != APP_EXPERIMENT)
			break;
		s.n_pat = e->swp_n_pat;
		s.n_cut = e->swp_n_cut;
		/* a rise's plan: the cut one once a frame was lost, else the levels' longest */
		uint32_t len = lose > 0 ? e->swp_len[EXP_SWP_LEVELS] : 0u;
		for (int k = 0; lose == 0 && k < EXP_SWP_LEVELS; k++)
			len = e->swp_len[k] > len ? e->swp_len[k] : len;
		float mean = 0.0f;
		for (int j = 0; j < HAL_ROTORS; j++)
			mean += sc_to_float(r->a.exp_out.thr_delta[j]) / (float)HAL_ROTORS;
		bool in_step = mean > 0.02f; /* the dithers sum to 0 over the rotors; a rise does not */
		if (in_step) {
			if (first < 0) {
				first = frame;
				lost_since = 0;
			}
			last = frame;
		} else if (first >= 0) { /* the rise's plant frames: to the last delivered at its top */
			s.steps++;
			s.lost_in_step += lost_since > 0;
			s.over += len < 3u || (uint32_t)(last - first + 1) > len;
			first = -1;
		}
		lost_since = first >= 0 ? lost_since : 0;
	}
	return s;
}

/* On a link that loses every third frame: the plant holds the last throttles through a lost
 * frame, a rise's among them, so each rise must end after its planned plant time (swp_len
 * frames), not after that many delivered frames; and every rise is cut (a frame lost within
 * SWP_LOSS_S before its pattern). On a clean link none is. */
UNIT_TEST(app_sweep_steps_last_their_plant_time_through_lost_frames)
{
	if (!exp_available(1))
		return;
	struct sweep_seen s = sweep_fly(u, 3);
	CHECK(s.steps >= 4 && s.lost_in_step >= 2);
	CHECK(s.over == 0);
	CHECK(s.n_pat >= 4u && s.n_cut == s.n_pat);
	s = sweep_fly(u, 0);
	CHECK(s.steps >= 4 && s.lost_in_step == 0 && s.over == 0);
	CHECK(s.n_pat >= 4u && s.n_cut == 0u);
}

/* k_f tracked from the accelerometer: the rotors' speeds at a harmonic of the frame rate fold
 * their vibration to nearly 0 Hz; a steady fold below 0.1 Hz pauses the publications (said
 * once, resumed when the speed moves away), a passage through it does not. */
static int kf_fold_run(struct env_kf *k, const struct app_params *p, double *t, double secs, float hz0, float hz1,
		       struct env_kf_pub *last, int *paused_pubs)
{
	scalar_t thr[HAL_ROTORS];
	float spd[HAL_ROTORS];
	int said = 0;
	for (int j = 0; j < HAL_ROTORS; j++)
		thr[j] = SC(0.36);
	int n = (int)(secs * 90.0);
	for (int i = 0; i < n; i++) {
		*t += 1.0 / 90.0;
		float hz = hz0 + (hz1 - hz0) * (float)i / (float)n;
		for (int j = 0; j < HAL_ROTORS; j++)
			spd[j] = 6.2831853f * hz;
		struct env_kf_input in = {.thrust_n = NULL,
					  .acc_z_g = SC(1),
					  .src = ENV_SRC_IMU,
					  .t_cal_s = 0.0,
					  .thr = thr,
					  .dt_s = sc_from_float(1.0f / 90.0f),
					  .t_s = *t,
					  .speed_rps = spd,
					  .gate = true,
					  .hold = true};
		env_kf_step(k, &in, p);
		if (env_kf_due(k) && env_kf_publish(k, p, (uint64_t)(*t * 1e6), *t, 1.0f / 90.0f, last)) {
			said += last->fold != 0 ? last->fold : 0;
			*paused_pubs += last->paused ? 1 : 0;
		}
	}
	return said;
}

UNIT_TEST(env_kf_pauses_on_a_steady_fold_near_0_hz)
{
	struct app_params p;
	params_defaults(&p);
	struct env_kf k;
	memset(&k, 0, sizeof k);
	k.src = ENV_SRC_IMU;
	env_kf_init(&k, &p);
	struct env_kf_pub last;
	double t = 0.0;
	int paused = 0;
	/* a passage through 90 Hz in 2 s: no pause */
	CHECK(kf_fold_run(&k, &p, &t, 2.0, 88.0f, 92.0f, &last, &paused) == 0 && paused == 0);
	/* steady at 90.03 Hz (a fold at 0.03 Hz): paused after a few publications, said once */
	CHECK(kf_fold_run(&k, &p, &t, 20.0, 90.03f, 90.03f, &last, &paused) == 1);
	CHECK(last.paused && last.fold_hz < 0.1f && paused >= 10);
	float kf, sd;
	CHECK(!env_kf_estimate(&k, t, &kf, &sd)); /* the log shows none */
	/* the second harmonic of 45.01 Hz folds too */
	paused = 0;
	CHECK(kf_fold_run(&k, &p, &t, 25.0, 45.01f, 45.01f, &last, &paused) == 0 && last.paused);
	/* away from it (92 Hz: a fold at 2 Hz): resumed, said once */
	CHECK(kf_fold_run(&k, &p, &t, 10.0, 92.0f, 92.0f, &last, &paused) == -1 && !last.paused);
	CHECK(env_kf_estimate(&k, t, &kf, &sd));
}
