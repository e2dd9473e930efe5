/*
 * experiment.h - the hook for in-flight identification experiments (issue 6).
 *
 * The app runs an experiment in mode APP_EXPERIMENT: every control step it first
 * computes the hover control (height and level attitude held), then calls
 * exp_step(), which may add excitation at three places of the pipeline and reads
 * everything it needs from exp_input:
 *
 *   sensor frame -> height/attitude control -> [f, tau] + (f_delta, tau_delta)
 *     -> mixer -> rotor thrusts -> throttle map -> T_j + thr_delta[j] -> X-Plane
 *
 * The experiment reports through its struct: phase, progress, up to 8 live
 * estimates with names and standard deviations (streamed as NAMED_VALUE_FLOAT
 * and logged every frame), a pending status line (STATUSTEXT), and when it
 * finishes, parameter results that the app applies (at the next frame
 * boundary), broadcasts as PARAM_VALUE and saves to the parameter file.
 *
 * Returning EXP_ABORTED (reason in msg) puts the vehicle back in hold; the app
 * also aborts the experiment itself (exp_abort) when the attitude leaves
 * EXP_TILT_ABORT_DEG or the X-Plane link drops.
 *
 * This file is the contract; experiment.c holds the implementations (issue 6).
 */
#ifndef OCTO_EXPERIMENT_H
#define OCTO_EXPERIMENT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "excite.h"
#include "filt.h"
#include "hal.h"
#include "ident.h"
#include "params.h"

#define EXP_MAX_EST 8
#define EXP_MAX_RESULTS 24
#define EXP_MAX_PHASES 6
#define EXP_QUEUE 8
#define EXP_TILT_ABORT_DEG 15.0f

enum exp_state { EXP_IDLE = 0, EXP_RUNNING, EXP_FINISHED, EXP_ABORTED };

struct exp_input {
	const struct hal_sensor_frame *frame;  /* this frame (paper's frames) */
	float dt_s;                            /* time since the previous step */
	const struct app_params *params;       /* parameters in use */
	const float *wrench_dem;               /* [f, tau_x, tau_y, tau_z] of the hover control */
	const float *rotor_f_cmd;              /* 8 rotor thrusts allocated last step, N */
	const float *thr_prev;                 /* 8 throttles sent on the previous frame */
};

struct exp_output {
	float f_delta;                         /* added to the demanded thrust, N */
	float tau_delta[3];                    /* added to the demanded torque, N m (mu_1) */
	float thr_delta[HAL_ROTORS];           /* added to each throttle after the map (delta_1) */
};

struct exp_result {
	int param_index;                       /* params_find() of the parameter */
	float value;
};

struct experiment {
	int id;                                /* MAV_CMD_USER_1 param1; 0 = none */
	enum exp_state state;
	int phase;
	float progress;                        /* 0..1 */
	int n_est;
	char est_name[EXP_MAX_EST][11];        /* NAMED_VALUE_FLOAT names, <= 10 chars */
	float est[EXP_MAX_EST], est_sd[EXP_MAX_EST];
	char msg[51];                          /* pending status line ("" = none) */
	int msg_severity;                      /* MAV_SEVERITY */
	int n_results;
	struct exp_result results[EXP_MAX_RESULTS];
	uint32_t est_live;                     /* bit i: est[i] is being estimated (streamed) */

	/* implementation state (experiment.c) */
	int n_phases, phase_kind[EXP_MAX_PHASES];
	float t_phase;                         /* time in the current phase, s */
	float t_settle, t_run;                 /* of the current phase */
	bool started, reporting;
	float dt_nom, z0;
	struct excite exc;
	struct ident_rotor rot;
	struct ident_inertia inr;
	struct ident_fit fit;
	struct filt_delay val_delay;
	struct filt_lag val_lag;
	char queue[EXP_QUEUE][51];
	int queue_sev[EXP_QUEUE];
	int q_head, q_n;
};

/* Is experiment `id` (1..6) built into this firmware? */
bool exp_available(int id);

/* Starts experiment `id` (the caller has checked that the vehicle hovers).
 * Returns a MAV_RESULT; on refusal `why` says why (for a STATUSTEXT). */
int exp_start(struct experiment *e, int id, const struct app_params *p, char *why, size_t cap);

/* One control step while running; fills *out (zeroed by the caller). */
enum exp_state exp_step(struct experiment *e, const struct exp_input *in, struct exp_output *out);

/* Stops a running experiment (reason for the log/STATUSTEXT); results dropped. */
void exp_abort(struct experiment *e, const char *reason);

/* Is parameter `name` a result the firmware writes (a PARAM_SET is refused)? */
bool exp_param_readonly(const char *name);

#endif /* OCTO_EXPERIMENT_H */
