/* step.c - the 90 Hz control step (app_step): one named stage after another, each reading
 * the frame and what the stages before it handed on. */
#include <math.h>
#include <string.h>

#include "app.h"

/* What one step's stages hand each other. */
struct step {
	float dt;             /* the time the step integrates, s */
	struct guid_input gi; /* height, vertical speed and dt as scalars; hold_ready */
	const scalar_t *pos, *vel;
	struct quat q;                /* the attitude */
	scalar_t cos_tilt;            /* its body z axis, up component */
	struct quat q_sp;             /* the attitude set point */
	uint8_t short_pos, short_neg; /* what the allocation cut on the previous step */
	struct vec3 tau;              /* torque demand */
	scalar_t fz;                  /* thrust demand */
	bool excited;                 /* an experiment adds its excitation */
	scalar_t thr[HAL_ROTORS];     /* the throttle map's throttles */
	scalar_t acc_z;               /* the accelerometer's specific force along body z, g (as read) */
};

/* The frame as scalars; the excitation is zero unless the experiment sets it. */
static inline void step_inputs(struct app *a, struct step *s)
{
	bnd_frame_in(&a->bnd, &a->fr);
	s->pos = app_in(a)->pos_i_m;
	s->vel = app_in(a)->vel_i_mps;
	const scalar_t *qf = app_in(a)->q_ib;
	s->q = quat_normalize((struct quat){qf[0], qf[1], qf[2], qf[3]});
	a->exp_out.f_delta = SC_ZERO; /* field by field: the library's memset costs more */
	SC_HOT_UNROLL
	for (int i = 0; i < 3; i++)
		a->exp_out.tau_delta[i] = SC_ZERO;
	SC_HOT_UNROLL
	for (int j = 0; j < HAL_ROTORS; j++)
		a->exp_out.thr_delta[j] = SC_ZERO;
	s->gi = (struct guid_input){s->pos[2], s->vel[2], bnd_dt(&a->bnd, s->dt), false};
}

/* Disarmed or idle: the rotors at rest (MOT_THR_IDLE when armed), control reset, the set
 * points on the ground. True: the step ends here. */
static inline bool step_ground(struct app *a, struct step *s)
{
	bool ground = a->mode == APP_DISARMED || a->mode == APP_IDLE;
	/* thrust rows noted; on the ground the accelerometer calibrated (env_hover.h) */
	s->acc_z = sc_from_float(a->fr.accel_b_g[2]);
	env_hover_sense(&a->env_hover, a->fr.valid, s->acc_z, ground, a->fr.t_s);
	if (!ground)
		return false;
	app_set_thr_all(a, a->mode == APP_IDLE ? a->p.mot_thr_idle : 0.0f);
	app_reset_control(a);
	guid_ground(&a->guid, s->gi.z_m, a->mode == APP_IDLE);
	memset(a->wrench_dem, 0, sizeof a->wrench_dem);
	memset(a->log.rotor_f, 0, sizeof a->log.rotor_f);
	a->mix_out.limits = 0;
	return true;
}

/* The take-off's and landing's time limits (env_limits.h): a phase that ran out is said,
 * its command answered FAILED, and a take-off lands. */
static inline void step_limits(struct app *a, struct step *s)
{
	bool takeoff = a->mode == APP_TAKEOFF, land = a->mode == APP_LAND;
	if (!takeoff && !land)
		return;
	float ground = sc_to_float(a->guid.z_ground_m);
	struct env_limits_input in = {
		.takeoff = takeoff,
		.land = land,
		.dt_s = s->dt,
		.z_m = a->fr.pos_i_m[2] - ground,
		.target_m = sc_to_float(a->guid.z_target_m) - ground,
		.vz_mps = a->fr.vel_i_mps[2],
		.sp_at_target = a->guid.z_sp_m == a->guid.z_target_m,
		.hover = &a->env_hover,
	};
	struct env_limits_req req;
	if (env_limits_step(&a->env_limits, &in, &a->p, &req))
		app_phase_timeout(a, &req);
}

/* Guidance: set points and mode transitions (take-off ends once the hover is learned).
 * True once landed: the step ends here. */
static inline bool step_guidance(struct app *a, struct step *s)
{
	s->gi.hold_ready = a->mode == APP_TAKEOFF && env_hover_ready(&a->env_hover);
	uint32_t ev = guid_update(&a->guid, app_guid_mode(a->mode), &s->gi);
	if (ev & GUID_HOLD_REACHED)
		app_set_mode(a, APP_HOLD);
	if (!(ev & GUID_LANDED))
		return false;
	app_set_thr_all(a, 0.0f);
	app_status2(a, APP_SEV_INFO, "Landed", "");
	app_set_mode(a, APP_DISARMED);
	return true;
}

/* Position: hold the position of the take-off through small tilts (level near the ground
 * during take-off; within EXP_TILT_SP_DEG in an experiment); the attitude set point with the
 * set point's yaw. */
static inline void step_position(struct app *a, struct step *s)
{
	struct pos_ctrl_input pi = {
		.pos_sp_m = {a->guid.pos_sp_m[0], a->guid.pos_sp_m[1]},
		.pos_m = {s->pos[0], s->pos[1]},
		.vel_mps = {s->vel[0], s->vel[1]},
		.q_b2i = s->q,
	};
	struct pos_ctrl_output po = pos_ctrl_update(a->mode == APP_EXPERIMENT ? &a->pos_exp : &a->pos, &pi);
	if (guid_level_only(&a->guid, app_guid_mode(a->mode), s->gi.z_m))
		po.roll_rad = po.pitch_rad = SC_ZERO;
	/* the yaw's half-angle trigonometry, kept while the yaw stays */
	if (!a->yaw_half_ok || a->guid.yaw_sp_rad != a->yaw_half_of) {
		a->yaw_half_of = a->guid.yaw_sp_rad;
		a->yaw_half = quat_yaw_half(a->yaw_half_of);
		a->yaw_half_ok = true;
	}
	s->q_sp = quat_from_euler_yh(po.roll_rad, po.pitch_rad, a->yaw_half);
	a->log.q_sp[0] = sc_to_float(s->q_sp.w);
	a->log.q_sp[1] = sc_to_float(s->q_sp.x);
	a->log.q_sp[2] = sc_to_float(s->q_sp.y);
	a->log.q_sp[3] = sc_to_float(s->q_sp.z);
}

/* Attitude: the torque demand (its integral held where the last allocation fell short),
 * with the gain that takes out the throttle map's error at hover; the rates into the
 * oscillation guard's second. */
static inline void step_attitude(struct app *a, struct step *s)
{
	mixer_shortfall(&a->mix_out, &s->short_pos, &s->short_neg);
	const scalar_t *w = app_in(a)->rate_b_rps;
	struct att_ctrl_input ai = {
		.q_sp_b2i = s->q_sp,
		.rate_ff_b = vec3_zero(),
		.q_b2i = s->q,
		.rate_b_rps = vec3_make(w[0], w[1], w[2]),
		.inertia_kgm2 = a->ps.inertia_kgm2,
		.dt_s = s->gi.dt_s,
		.alloc_short_pos = (uint8_t)(s->short_pos >> 1),
		.alloc_short_neg = (uint8_t)(s->short_neg >> 1),
	};
	att_ctrl_update(&a->att, &ai, &s->tau);
	s->tau = env_hover_torque(&a->env_hover, s->tau);
	env_osc_step(&a->env_osc, w, a->fr.t_s, a->mode == APP_TAKEOFF || a->mode == APP_HOLD);
}

/* Height: the hover throttle learned from the last step, the k_f tracker's input, and the
 * thrust demand around the hover thrust. */
static inline void step_height(struct app *a, struct step *s)
{
	s->cos_tilt = quat_body_z_up(s->q);
	/* what the thrust is measured with, and the accelerometer's a_z calibrated */
	enum env_src src = env_hover_src(&a->env_hover, &a->p, a->fr.valid);
	bool acc_ok = (a->fr.valid & HAL_FRAME_ACCEL) != 0;
	scalar_t acc_z = acc_ok ? env_hover_acc(&a->env_hover, s->acc_z) : SC_ZERO;
	struct env_hover_input hi = {
		.f_achieved = a->mix_out.achieved[0],
		.acc_z_g = acc_z,
		.src = src,
		.acc_ok = acc_ok,
		.z_m = s->pos[2],
		.vz_mps = s->vel[2],
		.z_ground_m = a->guid.z_ground_m,
		.cos_tilt = s->cos_tilt,
		.dt_s = s->gi.dt_s,
		.learn_mode = a->mode == APP_TAKEOFF || a->mode == APP_HOLD || a->mode == APP_LAND,
		.takeoff_climb = a->mode == APP_TAKEOFF && sc_to_float(a->guid.z_sp_m) > a->fr.pos_i_m[2] + 0.05f,
	};
	bool up;
	scalar_t hover_f = env_hover_step(&a->env_hover, &hi, &up);
	bool have = src == ENV_SRC_IMU ? acc_ok : (a->fr.valid & HAL_FRAME_THRUST) != 0;
	/* k_f tracked at the frame boundary (app_settle), on the throttles before this step */
	struct env_kf_input *ki = &a->after.kf_in; /* every field set, in place */
	ki->thrust_n = app_in(a)->rotor_thrust_n;
	ki->acc_z_g = acc_z;
	ki->src = src;
	ki->t_cal_s = a->env_hover.cal.t_s;
	ki->thr = a->after.thr_prev;
	ki->dt_s = s->gi.dt_s;
	ki->t_s = a->fr.t_s;
	ki->speed_rps = (a->fr.valid & HAL_FRAME_RPM) ? a->fr.rotor_speed_rps : NULL;
	ki->gate = (a->mode == APP_HOLD || a->mode == APP_EXPERIMENT) && up && have;
	ki->hold = a->mode == APP_HOLD;
	a->after.kf_due = true;
	struct alt_ctrl_input li = {
		.z_sp_m = a->guid.z_sp_m,
		.vz_ff_mps = a->guid.vz_ff_mps,
		.z_m = s->gi.z_m,
		.vz_mps = s->gi.vz_mps,
		.q_b2i = s->q,
		.mass_kg = a->ps.mass_kg,
		.dt_s = s->gi.dt_s,
		.hover_f_n = hover_f,
		.alloc_short_up = (s->short_pos & 1u) != 0,
		.alloc_short_down = (s->short_neg & 1u) != 0,
	};
	s->fz = alt_ctrl_update(&a->alt, &li);
	a->wrench_dem[0] = sc_to_float(s->fz);
	a->wrench_dem[1] = sc_to_float(s->tau.x);
	a->wrench_dem[2] = sc_to_float(s->tau.y);
	a->wrench_dem[3] = sc_to_float(s->tau.z);
}

/* Excitation (EXPERIMENT only): the experiment's step on top of the hover control, aborted
 * beyond its tilt limit; an experiment that ended returns to HOLD. */
static inline void step_excitation(struct app *a, struct step *s)
{
	if (a->mode != APP_EXPERIMENT)
		return;
	/* tilt > EXP_TILT_ABORT_DEG, without acosf: the body's z axis vs cos(limit) */
	if (s->cos_tilt < sc_from_float(cosf(EXP_TILT_ABORT_DEG * DEG_F)))
		exp_abort(&a->exp, "attitude limit");
	/* the rotor torques: only the rotor and inertia phases read them */
	const scalar_t *torque = NULL;
	if (exp_reads_torque(&a->exp)) {
		bnd_torque_in(&a->bnd, &a->fr);
		torque = app_in(a)->rotor_torque_nm;
	}
	/* the thrusts allocated last step: the mixer's output (the log's rotor_f in floats) */
	struct exp_input in = {&a->fr,        app_in(a)->rotor_thrust_n,
			       torque,        app_in(a)->rate_b_rps,
			       s->dt,         &a->p,
			       a->wrench_dem, a->mix_out.f_n,
			       app_thr_sc(a), a->dt_frame};
	if (exp_step(&a->exp, &in, &a->exp_out) != EXP_RUNNING) {
		memset(&a->exp_out, 0, sizeof a->exp_out);
		app_set_mode(a, APP_HOLD);
	}
}

/* Allocation: the demands (and the excitation's) -> rotor thrusts (mixer) -> throttles
 * (throttle map), in scalars. */
static inline void step_allocation(struct app *a, struct step *s)
{
	s->excited = a->mode == APP_EXPERIMENT;
	scalar_t demand[MIXER_N_AXES] = {s->fz, s->tau.x, s->tau.y, s->tau.z};
	if (s->excited) {
		demand[0] = sc_add(demand[0], a->exp_out.f_delta);
		for (int i = 0; i < 3; i++)
			demand[i + 1] = sc_add(demand[i + 1], a->exp_out.tau_delta[i]);
	}
	mixer_step(&a->mix, &a->mix_warm, demand, &a->mix_out); /* its exact search: app_tick */
	a->thr_clamped = thrmap_update(&a->map, a->mix_out.f_n, s->thr, HAL_ROTORS);
}

/* Output: the excitation's throttles added, each throttle within [0, MOT_THR_MAX] (not
 * finite: 0), stored as sent. */
static inline void step_output(struct app *a, struct step *s)
{
	const scalar_t thr_max = a->ps.thr_max; /* read once: the stores below are floats too */
	SC_HOT_UNROLL
	for (int j = 0; j < HAL_ROTORS; j++) {
		a->log.rotor_f[j] = sc_to_float(a->mix_out.f_n[j]);
		scalar_t t = s->excited ? sc_add(s->thr[j], a->exp_out.thr_delta[j]) : s->thr[j];
		t = sc_clamp(sc_isfinite(t) ? t : SC_ZERO, SC_ZERO, thr_max);
		a->thr[j] = sc_to_float(t);
		bnd_thr_store(&a->bnd, j, t); /* sc_from_float(a->thr[j]) exactly: a throttle in [0, 1] is a float */
	}
}

void app_step(struct app *a, float dt)
{
	struct step s; /* each field set by the stage that makes it */
	s.dt = dt;
	a->torque_gain_due = true; /* what this step learns of the hover: the gain between frames */
	step_inputs(a, &s);        /* the frame as scalars, the excitation cleared */
	if (step_ground(a, &s))    /* disarmed or idle: rotors at rest, control reset */
		return;
	step_limits(a, &s);       /* take-off and landing time limits */
	if (step_guidance(a, &s)) /* set points and mode transitions; landed: done */
		return;
	step_position(a, &s);   /* the tilt that holds the position, the attitude set point */
	step_attitude(a, &s);   /* the torque demand; the rates into the oscillation guard */
	step_height(a, &s);     /* hover learning, the k_f tracker's input, the thrust demand */
	step_excitation(a, &s); /* the experiment's excitation on top (EXPERIMENT only) */
	step_allocation(a, &s); /* demands -> rotor thrusts -> throttles */
	step_output(a, &s);     /* throttles clamped and stored */
}
