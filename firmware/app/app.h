/*
 * app.h - the autopilot: one control step per received frame, modes,
 * parameters, commands. Platform-independent: it talks to the world only
 * through hal.h. The platform owns one struct app and calls:
 *
 *   app_init(a, hal)         defaults, then the stored parameters
 *   app_on_frame(a, frame)   each sensor frame (the app actuates once per frame
 *                            that brings a new time stamp, from the first arming
 *                            on: duplicates and reordered frames are not answered)
 *   app_tick(a)              often (main loop), and between frames: applies
 *                            identification results, rebuilds the mixer after
 *                            a parameter change, saves the parameter file,
 *                            link supervision (docs/architecture.md, "Between frames")
 *
 * A ground-station module (mav.h) reads the app through app_view, takes its
 * events with app_next_event and acts through the app_cmd_* functions.
 *
 * Modes: DISARMED -> (arm) IDLE -> (NAV_TAKEOFF) TAKEOFF -> HOLD
 *        HOLD <-> EXPERIMENT (app_cmd_experiment, only while hovering)
 *        any flying mode -> (NAV_LAND or failsafe) LAND -> (touch-down) DISARMED
 * Link to the plant silent for FS_LINK_TO s: reported (and an experiment
 * aborted); silent for more than FS_LAND_AFTER s: the vehicle lands when the
 * link comes back.
 */
#ifndef OCTO_APP_H
#define OCTO_APP_H

#include <stdbool.h>
#include <stdint.h>

#include "alt_ctrl.h"
#include "att_ctrl.h"
#include "boundary.h"
#include "env_hover.h"
#include "env_kf.h"
#include "env_limits.h"
#include "env_osc.h"
#include "experiment.h"
#include "fcmp.h"
#include "guidance.h"
#include "hal.h"
#include "line.h"
#include "log.h"
#include "mixer.h"
#include "origin.h"
#include "outbox.h"
#include "params.h"
#include "pos_ctrl.h"
#include "rotor_fail.h"
#include "thrmap.h"

#define DEG_F 0.017453292519943295f /* rad per degree */

/* What the step reads of the parameters, as scalars: set by the parameter sync (between
 * frames, after every parameter change), not converted per frame. */
struct app_param_sc {
	struct vec3 inertia_kgm2; /* VEH_IXX, VEH_IYY, VEH_IZZ */
	scalar_t mass_kg;         /* VEH_MASS */
	scalar_t thr_max;         /* MOT_THR_MAX */
};

enum app_mode {
	APP_DISARMED = 0,
	APP_IDLE = 1, /* armed on the ground, rotors at MOT_THR_IDLE */
	APP_TAKEOFF = 2,
	APP_HOLD = 3,       /* level, height and position held */
	APP_EXPERIMENT = 4, /* hold + identification experiment */
	APP_LAND = 5,
};

/* What the step says, said between frames. Status lines formatted in the 90 Hz step would
 * cost more than the step (vsnprintf with %f), so while app_on_frame runs, what the app says
 * is recorded here in the order it is said: status lines as formats and values (line.h), an
 * experiment's end (its lines when it was aborted, its run closed) and a command's final
 * answer. The next pass between frames (app_settle; app_next_event and every command first)
 * says them in that order, before anything newer: the ground station, the console and the
 * log see them as if said in the step. A step that says more than the ring holds says what
 * the ring holds at once, in the step, and goes on: nothing is lost and the order stays; such
 * overflows are counted and a status line reports them. */
#define APP_SAID_LEN 16
enum app_said_kind {
	APP_SAID_LINE = 1, /* line */
	APP_SAID_EXP_END,  /* the experiment ended: aborted (its lines said), its run closed */
	APP_SAID_DONE,     /* a command's final answer: cmd, result, progress, origin */
};
struct app_said_item {
	uint8_t kind; /* enum app_said_kind */
	uint8_t cmd, result, progress;
	app_origin origin;
	struct line line;
};
struct app_said {
	struct app_said_item q[APP_SAID_LEN];
	uint8_t head, n;
	bool in_step;            /* app_on_frame runs: what is said goes into q */
	bool saying;             /* q is being said */
	uint32_t overflows;      /* steps that said more than q holds (said in the step) */
	uint32_t overflows_said; /* of them, reported */
};

struct app {
	const struct hal *hal; /* the platform (set by app_init) */
	struct app_params p;
	enum app_mode mode;

	/* plant link */
	struct hal_sensor_frame fr; /* the newest frame, its position made continuous (origin.h) */
	struct origin orig;
	bool have_frame, have_step;
	uint64_t n_prev;        /* frame_n of the last step */
	uint64_t per_n, per_us; /* frame_n and t_us where the period's measurement started */
	float dt_frame;         /* frame period, measured from t_us and smoothed */
	uint64_t wall_last_frame_us;
	bool link_ok, link_ever;
	uint64_t link_lost_at_us;
	/* "frames missing" lines: at most one a wall second (a fast lockstep run through a burst
	 * storm would otherwise crowd the ground station's other lines out of its rate) */
	uint64_t gap_said_us;
	uint32_t gaps_unsaid; /* gaps since the last line */
	float gap_max_unsaid_s;
	uint64_t gap_n; /* frame_n that ended the last gap longer than FS_LINK_TO (0: none) */
	bool actuating; /* throttles are ours (from the first arming) */
	bool have_actuated;
	uint64_t n_actuated; /* frame_n of the last frame answered */
	float thr[HAL_ROTORS];
	struct boundary bnd; /* the frame and throttles as scalars (boundary.h) */

	/* guidance (set points) and the position loop */
	struct guid guid;
	struct pos_ctrl_params pos;
	struct pos_ctrl_params pos_exp; /* in EXPERIMENT: the tilt set point within EXP_TILT_SP_DEG */
	struct app_param_sc ps;         /* parameters the step reads, as scalars */
	/* the set point's yaw and its half-angle trigonometry, kept while the yaw stays */
	scalar_t yaw_half_of;
	struct quat_yaw_half yaw_half;
	bool yaw_half_ok;

	/* control */
	struct att_ctrl att;
	struct alt_ctrl alt;
	/* the flight envelope: what the app learns and guards in flight */
	struct env_hover env_hover;   /* hover throttle learned, hover thrust, torque gain */
	struct env_kf env_kf;         /* k_f tracked */
	struct env_osc env_osc;       /* the oscillation guard */
	struct env_limits env_limits; /* take-off and landing time limits */
	struct mixer mix;
	struct mixer_warm mix_warm; /* the step's allocation between frames: mixer_step, mixer_refresh */
	struct thrmap map;
	struct mixer_output mix_out;
	struct rotor_fail rf; /* a failed rotor, found from the rotors' outputs (rotor_guard.h) */
	float wrench_dem[4];
	uint32_t thr_clamped;

	/* identification (the experiment's own state, large, is the struct's last member) */
	struct exp_output exp_out;
	struct app_id_run id_run; /* the last run's results as data */
	bool exp_ack_pending;     /* a final result of the experiment command is owed */
	app_origin exp_origin;    /* to whom */
	/* an experiment commanded in TAKEOFF or HOLD before the vehicle hovers: it starts when it
	 * does (app_tick), or fails with the reason after EXP_WAIT_S of plant time */
	struct {
		int id; /* 0: none waiting */
		app_origin origin;
		double t0_s; /* plant time of the command */
	} exp_wait;

	/* The frame's work the step leaves to the frame boundary (app_settle runs it first):
	 * the k_f tracker's update, the rotor-failure judge and the frame's log record. Their
	 * results do not enter the step's outputs; they see the frame, the state and the
	 * throttles the step saw (the plant's answer to thr_prev), as if run in the step. */
	struct {
		bool kf_due;                   /* the k_f tracker's input waits (kf_in) */
		bool judge_due;                /* the rotor-failure judge's input waits */
		bool log_due;                  /* the frame's record waits (log_step, log_dt) */
		bool log_step;                 /* the frame was stepped */
		float log_dt;                  /* its dt */
		float dt;                      /* the step's dt */
		bool judged, gap, excited;     /* the judge's conditions at the step (rotor_guard.c) */
		scalar_t thr_prev[HAL_ROTORS]; /* the throttles before the step */
		struct env_kf_input kf_in;     /* the k_f tracker's input (thr: thr_prev) */
	} after;

	/* between frames (app_settle, app_tick): work the 90 Hz step does not do */
	bool params_dirty;    /* a parameter changed: rebuild gains, mixer, map */
	bool torque_gain_due; /* a step, a mode change or new parameters: the torque gain again */
	bool save_pending;    /* results applied: write the parameter file */

	struct app_said said;     /* what the step said, to be said between frames */
	struct app_outbox outbox; /* events for the ground station (app_next_event) */
	struct app_log_frame log; /* this frame's record; the step writes its set point (q_sp)
				       * and allocated rotor thrusts (rotor_f) here directly */
	uint32_t steps;

	/* Last, the large ones: the step's own fields above keep small offsets, which a
	 * microcontroller's loads and stores reach without extra address arithmetic. */
	char param_text[8192]; /* the parameter file's text while it is loaded or saved */
	struct experiment exp;
};

/* The frame's inputs and the throttles sent, as scalars (boundary.h): the converted copies
 * in the fixed build, the floats themselves in the float build. */
static inline const bnd_frame_t *app_in(const struct app *a) { return bnd_in(&a->bnd, &a->fr); }
static inline const scalar_t *app_thr_sc(const struct app *a) { return bnd_thr(&a->bnd, a->thr); }

/* A failed rotor (rotor_guard.c; the detector is core/rotor_fail.h): once a frame, at the
 * boundary after the step, the detector is fed the throttles before that step and what the
 * frame measured of the rotors; on a detection the rotor's MOT_SCALEj becomes the detected effectiveness (0: left
 * out of the allocation) and the mixer is rebuilt before the next step, an experiment in
 * progress stops with the rotor named, a critical status line says so, and after the
 * detector's hold the vehicle lands. rotor_guard_sync gives the detector the rotor model
 * from the parameters (with the mixer's, between frames); rotor_guard_failed: a rotor is
 * known failed (its scale 0, or found failed and not set anew). */
void rotor_guard_init(struct rotor_fail *rf);
void rotor_guard_sync(struct rotor_fail *rf, const struct app_params *p);
/* In the step, before app_step: the judge's conditions (mode, gaps, swinging rotors) and the
 * throttles the frame answers (a->after); rotor_guard_run judges at the frame boundary. */
void rotor_guard_note(struct app *a, float dt);
void rotor_guard_run(struct app *a);
bool rotor_guard_failed(const struct rotor_fail *rf);

void app_init(struct app *a, const struct hal *hal);
void app_on_frame(struct app *a, const struct hal_sensor_frame *f);
void app_tick(struct app *a);
/* The work between frames (app_tick's first part): results of the last step applied,
 * the mixer rebuilt after a parameter change. A ground-station module calls it before
 * it handles commands, so that they see a settled app. */
void app_settle(struct app *a);

/* What a ground-station module reads of the app: a view, rebuilt on each call. */
struct app_view {
	enum app_mode mode;
	bool armed, flying;
	bool link_ok;
	bool frames_ok;                    /* complete frames arrive (a step ran, link up) */
	const struct hal_sensor_frame *fr; /* the newest frame */
	const float *thr;                  /* HAL_ROTORS throttles sent */
	const struct app_params *params;
	/* the running experiment: progress 0..1 and its live estimates (experiment.h) */
	float exp_progress;
	int n_est;
	uint32_t est_live;
	const char (*est_name)[11];
	const float *est, *est_sd;
	const struct app_id_run *id_run; /* the last identification run's results */
	bool rotor_failed;               /* a rotor has failed (rotor_guard.h) */
};
struct app_view app_view(const struct app *a);
static inline const struct app_params *app_params(const struct app *a) { return &a->p; }
/* Takes the oldest event of the outbox into *e (what the last step said, said first); false
 * when there is none. */
bool app_next_event(struct app *a, struct app_event *e);

const char *app_mode_name(enum app_mode m);
bool app_hovering(const struct app *a);
bool app_not_hovering(const struct app *a, char *why, size_t cap);
bool app_flying(const struct app *a);

/* Commands (called by the MAVLink module). Each returns an app_result and, on
 * refusal, a reason in `why`. All are idempotent: a retry gets the same answer. */
enum app_result app_cmd_arm(struct app *a, bool arm, bool force, char *why, size_t cap);
/* Take-off and landing: ACCEPTED at once; should the phase then run out of its
 * time limit (env_limits.h), an APP_EV_CMD_DONE event FAILED goes to `origin`
 * (APP_ORIGIN_NONE: to no one). */
enum app_result app_cmd_takeoff(struct app *a, float height_m, app_origin origin, char *why, size_t cap);
enum app_result app_cmd_land(struct app *a, app_origin origin, char *why, size_t cap);
/* Long-running: APP_IN_PROGRESS, then an APP_EV_CMD_DONE event for `origin`. */
enum app_result app_cmd_experiment(struct app *a, float id, app_origin origin, char *why, size_t cap);
enum app_result app_params_save(struct app *a, char *why, size_t cap);
enum app_result app_params_load(struct app *a, char *why, size_t cap);

/* Parameter write from outside (PARAM_SET); refuses vehicle-model and mixer
 * parameters while an experiment runs. Returns 0 or a reason. */
const char *app_param_write(struct app *a, size_t index, float value);

/* A status line: console, log event, and an APP_EV_STATUS event in the outbox. In the step
 * (app_on_frame) it is recorded (struct app_said) and said between frames: a %s argument
 * said in the step must outlive the step (a literal). */
void app_status(struct app *a, enum app_severity severity, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
/* The same for the text s1 s2 (cut to APP_EVENT_TEXT - 1 characters) without a format: what
 * the step says (a mode, "Landed") costs no formatting there. */
void app_status2(struct app *a, enum app_severity severity, const char *s1, const char *s2);

/* ---- the app's own parts (app.c, step.c), not for platforms or ground stations ---- */

/* The control step (step.c) on a complete frame, integrating dt. */
void app_step(struct app *a, float dt);
void app_set_mode(struct app *a, enum app_mode m);
/* All throttles to t (and their scalars). */
void app_set_thr_all(struct app *a, float t);
/* The attitude and height controllers' integrals reset. */
void app_reset_control(struct app *a);
/* A take-off or landing that ran out of time (env_limits.h): said, answered, landed. */
void app_phase_timeout(struct app *a, const struct env_limits_req *req);

/* what guidance flies in each mode */
static inline enum guid_mode app_guid_mode(enum app_mode m)
{
	switch (m) {
	case APP_TAKEOFF: return GUID_TAKEOFF;
	case APP_HOLD:
	case APP_EXPERIMENT: return GUID_HOLD;
	case APP_LAND: return GUID_LAND;
	default: return GUID_GROUND;
	}
}

#endif /* OCTO_APP_H */
