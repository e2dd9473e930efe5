/* rotor_guard.c - the app's side of a rotor failure (declared in app.h). */
#include <stdio.h>

#include "app.h"
#include "outbox.h"
#include "params.h"
#include "rotor_fail.h"

void rotor_guard_init(struct rotor_fail *rf)
{
	struct rotor_fail_params p = rotor_fail_params_default();
	rotor_fail_init(rf, &p);
}

void rotor_guard_sync(struct rotor_fail *rf, const struct app_params *p)
{
	const float scale[ROTOR_FAIL_ROTORS] = {p->mot_scale1, p->mot_scale2, p->mot_scale3, p->mot_scale4,
						p->mot_scale5, p->mot_scale6, p->mot_scale7, p->mot_scale8};
	struct rotor_fail_model m;
	m.tau_lag_s = sc_from_float(p->id_mot_tau);
	m.curve = sc_from_float(p->mot_curve);
	for (int j = 0; j < ROTOR_FAIL_ROTORS; j++)
		m.scale[j] = sc_from_float(scale[j]);
	rotor_fail_set_model(rf, &m);
}

bool rotor_guard_failed(const struct rotor_fail *rf) { return rf->failed != 0; }

void rotor_guard_note(struct app *a, float dt)
{
	/* judged in hover, the experiments, the landing, and the take-off once off the ground
	 * (above the height where its set points turn from level: the spool-up and ground
	 * contact are below it) */
	const bool airborne =
		a->mode == APP_HOLD || a->mode == APP_EXPERIMENT || a->mode == APP_LAND ||
		(a->mode == APP_TAKEOFF && !guid_level_only(&a->guid, GUID_TAKEOFF, sc_from_float(a->fr.pos_i_m[2])));
	a->after.judged = airborne && a->actuating;
	/* frames missing before this one: the step covers more than one frame period */
	a->after.gap = a->dt_frame > 0.0f && dt > 1.5f * a->dt_frame;
	/* Only a deeper drop is a failure while the rotors swing through a model that may be
	 * off: an experiment's excitation (the model may be another vehicle's, from a stale
	 * parameter file), or rates over the oscillation guard's limit (an oscillating attitude
	 * loop swings the rotors at full range through a motor model still nominal; IMU
	 * outliers raise the rates too, so this is not a reason to stop judging). */
	a->after.excited = a->mode == APP_EXPERIMENT || env_osc_oscillating(&a->env_osc);
	a->after.dt = dt;
	/* app_thr_sc: the throttles of the last step, what the plant answers with now */
	const scalar_t *thr = app_thr_sc(a);
	SC_HOT_UNROLL
	for (int j = 0; j < HAL_ROTORS; j++)
		a->after.thr_prev[j] = thr[j];
	a->after.judge_due = true;
}

void rotor_guard_run(struct app *a)
{
	const struct hal_sensor_frame *f = &a->fr;
	const float dt = a->after.dt;
	/* the speeds only when the thrust rows are missing (the thrusts decide otherwise) */
	const bool thrust = (f->valid & HAL_FRAME_THRUST) != 0, speed = !thrust && (f->valid & HAL_FRAME_RPM);
#if OCTO_FIXED
	scalar_t meas[HAL_ROTORS];
	if (thrust)
		for (int j = 0; j < HAL_ROTORS; j++)
			meas[j] = sc_from_float(f->rotor_thrust_n[j]);
	else if (speed)
		for (int j = 0; j < HAL_ROTORS; j++)
			meas[j] = sc_from_float(f->rotor_speed_rps[j]);
	const scalar_t *thrust_n = thrust ? meas : NULL, *speed_rps = speed ? meas : NULL;
	scalar_t dt_s = sc_from_float(dt);
#else
	const scalar_t *thrust_n = thrust ? f->rotor_thrust_n : NULL, *speed_rps = speed ? f->rotor_speed_rps : NULL;
	scalar_t dt_s = dt;
#endif
	struct rotor_fail_input in = {.thr = a->after.thr_prev,
				      .thrust_n = thrust_n,
				      .speed_rps = speed_rps,
				      .dt_s = dt_s,
				      .judge = a->after.judged,
				      .gap = a->after.gap,
				      .excited = a->after.excited};
	struct rotor_fail_output o = rotor_fail_step(&a->rf, &in);

	if (o.rotor >= 0) {
		int j = o.rotor;
		float s = sc_to_float(o.scale);
		size_t idx = (size_t)(PX_MOT_SCALE1 + j);
		if (params_set(&a->p, idx, s) == PARAM_OK) {
			struct app_event e = {.kind = APP_EV_PARAM, .param_index = (uint16_t)idx};
			outbox_post(&a->outbox, &e);
		}
		a->params_dirty = true; /* mixer and throttle map rebuilt before the next step */
		app_status(a, APP_SEV_CRITICAL,
			   "Rotor %d failed (effectiveness %.2f, from its %s): holding on %s, then landing", j + 1,
			   (double)s, o.source == ROTOR_FAIL_SRC_THRUST ? "thrust" : "speed",
			   s > 0.0f ? "all rotors" : "the others");
		if (a->mode == APP_TAKEOFF && a->env_limits.cmd == APP_CMD_TAKEOFF &&
		    a->env_limits.origin != APP_ORIGIN_NONE) {
			/* the take-off will not be completed: its command's final answer, once
			 * (the landing follows the hold) */
			struct app_event e = {.kind = APP_EV_CMD_DONE,
					      .cmd = APP_CMD_TAKEOFF,
					      .result = APP_FAILED,
					      .origin = a->env_limits.origin};
			outbox_post(&a->outbox, &e);
			a->env_limits.origin = APP_ORIGIN_NONE;
		}
		if (a->mode == APP_EXPERIMENT) {
			char why[24];
			snprintf(why, sizeof why, "rotor %d failed", j + 1);
			exp_abort(&a->exp, why); /* the next step's experiment part ends it, to HOLD */
		}
	}
	if (o.land && (a->mode == APP_TAKEOFF || a->mode == APP_HOLD || a->mode == APP_EXPERIMENT)) {
		char why[8];
		app_status2(a, APP_SEV_CRITICAL, "Rotor failure: landing", "");
		app_cmd_land(a, APP_ORIGIN_NONE, why, sizeof why);
	}
}
