/*
 * experiment.h - the hook for in-flight identification experiments.
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
 * and logged every frame), a pending status line (STATUSTEXT), and parameter
 * results that the app applies (at the next frame boundary), broadcasts as
 * PARAM_VALUE and saves to the parameter file.
 *
 * Returning EXP_ABORTED (reason in msg) puts the vehicle back in hold; the app
 * also aborts the experiment itself (exp_abort) when the attitude leaves
 * EXP_TILT_ABORT_DEG or the X-Plane link drops.
 *
 * This file is the contract; experiment.c holds the implementations,
 * firmware/core/ident.h the estimators.
 *
 * ---------------------------------------------------------------- the experiments
 * MAV_CMD_USER_1 param1: 1 rotor coefficients, 2 validation, 3 Ixx, 4 Iyy, 5 Izz,
 * 6 the sequence validation -> rotor -> validation -> Ixx -> Iyy -> Izz. Every phase
 * starts with 1 s without excitation (filters settle), then excites:
 *   rotor      ID_EXC_TIME s of two independent dithers d1, d2 (ID_EXC_KIND: 0 uniform,
 *              1 PRBS (default, order 9), 2 multisine 0.5..4 Hz; amplitude ID_EXC_AMP 0.04,
 *              a new value every ID_EXC_DIV = 9 frames: 10 Hz) added after the throttle map
 *              on the null-space patterns of Gamma_o (excite.h): d1 on [1 0 -1 0 1 0 -1 0],
 *              d2 on [0 1 0 -1 0 1 0 -1] (thrust, roll, pitch AND yaw cancel whatever k_f and
 *              k_tau are, so the vehicle stays still; every rotor is excited), plus an offset
 *              o = ID_EXC_OFS (0.03) times +1, 0, -1, 0 (half a second each) on their sum,
 *              which moves each rotor's mean throttle over three levels (the thrust curve).
 *              The motor model of every rotor (motor_id.h): measured f_j, tau_j (rows 35/36)
 *              against the throttles sent, a bank of transport delays 0-4 frames, each with
 *              its lag found by prediction error (grid refined around the best between
 *              frames; ID_MOT_TAU only centres the first grid), k_f, k_tau, the curve
 *              (ID_CRV_EST 1; 0: MOT_CURVE taken as known) and the per-rotor effectiveness
 *              MOT_SCALE1..8 (median 1), each with its std. Beside it rotor 1 alone with the
 *              model given (ID_MOT_TAU, ID_DELAY_FR, MOT_CURVE: the live KF/KTAU estimates)
 *              and the paper's plain estimator (eq. 18-20, ident.h). ID_EXC_NULL 0: rotor 1
 *              alone is dithered (the paper's, left to the attitude loop) and only the
 *              estimator with the model given runs (its lag check is then the acceptance
 *              rule, as described under "changes" below).
 *              Acceptance of the motor model: the thrust noise is measured while hovering
 *              still (the first second, first differences); the residual variance over it
 *              (NE, per rotor and overall) must stay below 1.3; the cause of a rejection is
 *              named with its remedy ("ID rejected: thrust curve not modelled", "ID remedy:
 *              set ID_CRV_EST 1"; a rotor no lag explains: "ID rejected: rotor 3
 *              unexplained, NE 9.54"; a lag out of 0.5-500 ms, a delay of 4 frames or more,
 *              two delays that explain the data alike); ranges: curve 0-0.99, scales 0.3-1.5
 *              (a rejection names the bound). Only then are VEH_KF, VEH_KTAU, ID_MOT_TAU,
 *              ID_DELAY_FR, MOT_CURVE (when estimated) and MOT_SCALE1..8 among the results
 *              (the later phases model the rotors with them); a rotor below MOT_SCALE_MIN
 *              (0.8) is reported "ID rotor 3 degraded: effectiveness 0.700". Results also:
 *              ID_TAU_CHECK (the lag found) with ID_TAU_SD, ID_CRV_SD, ID_MOT_NE.
 *              k_f is the thrust at FULL throttle: with the curve estimated it is an
 *              extrapolation from hover throttles (d k_f / k_f = d c / (1 - c)), and its std
 *              (0.2-0.5 % in 10 s) says so; with the curve known it is ~0.03 %.
 *   validation ID_VAL_TIME s of mu_1: uniform random (+/- ID_INR_AMP / 10 N m, new every
 *              ID_EXC_DIV frames) added to the YAW torque demand (yaw moves single rotor
 *              thrusts most, ~+/-0.7 N on rotor 1, and tilts nothing). Compared: measured
 *              f_1 against the model's prediction of it: the thrust the mixer allocated
 *              to rotor 1 for the throttle that can act (previous frame), through the
 *              modelled delay and lag. NE = RMS(y - y_hat) / RMS(y), fit % =
 *              100 (1 - |y - y_hat| / |y - mean y|). Results go to ID_VAL_*_PRE before
 *              rotor identification, ID_VAL_*_POST after (experiment 2 alone: POST when
 *              ID_RESULT bit 1 is set).
 *   inertia    ID_INR_TIME s of torque excitation about one axis. Roll/pitch: a multisine
 *              (harmonics 4..15 of 0.5 Hz = 2..7.5 Hz, Schroeder phases) of peak
 *              ID_INR_AMP (0.8 N m): above the attitude loop's bandwidth torque becomes
 *              acceleration rather than tilt (~3 deg), which is what the estimate feeds
 *              on; SVF corner 25 rad/s. Yaw: PRBS at the ID_EXC_DIV clock, peak
 *              ID_INR_AMP / 10 (rotor thrusts move ~9 N per N m of yaw), SVF corner
 *              12 rad/s (gyro noise). Torque from the measured rotor thrusts through
 *              Gamma_o (arm VEH_ARM_L) and, for yaw, from the measured rotor torques;
 *              torque, rate and the gyroscopic product through one SVF (zeta 0.7); the
 *              sampled-data regression of ident.h (torque weight from ID_MOT_TAU), solved with
 *              the excitation as instrumental variable (no bias from gyro noise; its std from
 *              0.5 s blocks). Not accurate enough for ID_RSD_MAX: a warning says what to
 *              raise ("ID Izz: ID_INR_AMP 1.57 and ID_INR_TIME 320 s": the std falls as
 *              1 / (amplitude sqrt(time)); the amplitude up to the rotors' headroom, half the
 *              hover thrust per rotor, the rest in time up to ID_INR_TIME's maximum; 2x margin
 *              on the std; "or" when either alone suffices). Past that maximum the advice is
 *              the longest run at the largest amplitude with the std expected there ("(the
 *              longest: rsd 0.0017 expected)"), or, when even that misses ID_RSD_MAX, "ID_RSD_MAX
 *              0.0010 out of reach: ... give rsd 0.0017": never a value the parameter refuses.
 * Acceptance (ident_accept): finite, within [0.25, 4] x the current VEH_* value,
 * relative std < ID_RSD_MAX (0.02); then VEH_* and ID_RESULT bits are among the
 * results; otherwise a STATUSTEXT says why and VEH_* stay. The experiment aborts
 * itself ("height limit") if the height leaves +/-1.5 m of its start, and fails when a
 * phase runs past its time limit (plant time, settling included: ID_ROT_TO, ID_INR_TO,
 * ID_VAL_TO; 0 = twice the planned time + 5 s): "ID inertia Izz failed: ID_INR_TO 3.0 s"
 * and "ID aborted: time limit, phase planned 11.0 s" (severity ERROR), final FAILED.
 *
 * ---------------------------------------------------------------- live estimates
 * est[i] / est_sd[i] (also the LCM log's est[8] / est_sd[8]), fixed order:
 *   0 KF, 1 KTAU (lag-aware), 2 KF_PLAIN, 3 KTAU_PLAIN (paper, eq. 20), 4 IXX, 5 IYY,
 *   6 IZZ, 7 VAL_NE (est_sd[7] holds the running fit %, not a std).
 * est_name[i] is the NAMED_VALUE_FLOAT name; est_live bit i says which are being
 * estimated in the current phase (only those are streamed); a std is streamed as
 * "<name>_SD" (KF_SD, KTAU_SD, IXX_SD, IYY_SD, IZZ_SD).
 *
 * ---------------------------------------------------------------- what the app and the
 * experiments rely on
 *   - results: the app applies e->results[0..n_results) after EVERY exp_step that
 *     returns with n_results > 0 (not only at the end: sequence 6 validates with the new
 *     k_f) and then sets n_results = 0; EXP_MAX_RESULTS 32 (the rotor model's phase
 *     end posts 24).
 *   - est_live (above); final_result, the app_result of the command's final answer
 *     (APP_ACCEPTED when finished, APP_FAILED when aborted); result parameters are
 *     read-only (PARAM_READONLY in experiment_params.h); parameter ID_EXC_NULL (the
 *     null-space dither, default 1); result parameter ID_TAU_CHECK (the motor lag the rotor experiment's data show, a
 *     Gauss-Newton step from ID_MOT_TAU; -1 when ID_MOT_TAU is 0) with a STATUSTEXT
 *     "ID motor lag 0.0301 s (ID_MOT_TAU 0.0300)", "... DIFFERS ..." (warning) when the
 *     two differ by more than 10 % (LAG_TOL). The lag check is also the rotor experiment's
 *     acceptance rule: beyond 10 % k_f and k_tau are biased by about 0.03 % per % of lag
 *     and are rejected ("ID kf 27.670 +/- 0.143 rejected: motor lag off", VEH_KF and
 *     VEH_KTAU unchanged). Causes: a wrong ID_MOT_TAU (set it to ID_TAU_CHECK and run
 *     again: each run is one Gauss-Newton step, e.g. 0.030 -> 0.0424 -> ~0.045 s for
 *     motors of 45 ms), a transport delay not declared in ID_DELAY_FR (one frame reads as
 *     ~+13 ms of lag), or a lockstep loop that slipped a frame (the simulator timed out on
 *     a late answer and took it for the next frame: every throttle then acts one frame late).
 *   - lost frames: a step after a gap has dt_s a multiple of the frame period
 *     (dt_frame_s, the app's: measured on the platform clock); the rotor and validation models
 *     advance through the gap with the held throttle, the inertia updates wait GAP_HOLD
 *     frames. Stale (reordered, duplicated) frames are not stepped.
 *   - the app switches to an identified k_f bumplessly (height integrator rescaled).
 *   - the experiment's STATUSTEXT lines are queued and handed out one per frame through
 *     msg; EXP_FINISHED is returned only when all have gone ("ID done" last). They are
 *     formatted between frames (exp_pump, called by the app's tick), not in the step.
 *   - a phase that ends in a step is closed (results posted) and the next started between
 *     frames (exp_turn, called by the app before it applies results), from a copy of that
 *     step's inputs: the next step sees exactly what it saw when this ran in the step. The
 *     first phase too: the experiment's first step only takes its frame (no excitation), and
 *     the phase begins between frames.
 */
#ifndef OCTO_EXPERIMENT_H
#define OCTO_EXPERIMENT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "excite.h"
#include "filt.h"
#include "hal.h"
#include "id_result.h"
#include "ident.h"
#include "motor_id.h"
#include "outbox.h"
#include "params.h"

#define EXP_MAX_EST 8
#define EXP_MAX_RESULTS 32
#define EXP_MAX_IDS 24        /* results as data of one phase's end (the rotor model's: 15) */
#define EXP_MAX_PHASES 6
#define EXP_QUEUE 20
#define EXP_TILT_ABORT_DEG 15.0f

enum exp_state { EXP_IDLE = 0, EXP_RUNNING, EXP_FINISHED, EXP_ABORTED };

struct exp_input {
	const struct hal_sensor_frame *frame;  /* this frame (paper's frames) */
	/* this frame's measurements as scalars (converted once by the app): */
	const scalar_t *thrust_n;              /* 8 rotor thrusts, N */
	const scalar_t *torque_nm;             /* 8 rotor reaction torques, N m: read only when
						* exp_reads_torque() (NULL otherwise) */
	const scalar_t *rate_b_rps;            /* 3 body rates, rad/s */
	float dt_s;                            /* time since the previous step */
	const struct app_params *params;       /* parameters in use */
	const float *wrench_dem;               /* [f, tau_x, tau_y, tau_z] of the hover control */
	const scalar_t *rotor_f_cmd;           /* 8 rotor thrusts allocated last step, N */
	const scalar_t *thr_prev;              /* 8 throttles sent on the previous frame */
	float dt_frame_s;                      /* the plant's frame period (0: unknown, the
						* first step's dt_s is taken) */
};

/* in scalars: the app adds them to its scalar demands and throttles (the log has thr_delta as
 * floats); every value is small enough (|x| < 256) to be a float exactly */
struct exp_output {
	scalar_t f_delta;                      /* added to the demanded thrust, N */
	scalar_t tau_delta[3];                 /* added to the demanded torque, N m (mu_1) */
	scalar_t thr_delta[HAL_ROTORS];        /* added to each throttle after the map (delta_1) */
};

struct exp_result {
	int param_index;                       /* params_find() of the parameter */
	float value;
};

/* a status line waiting to be formatted: the format and its arguments (experiment.c) */
#define EXP_LINE_ARGS 5
struct exp_line {
	const char *fmt;
	int sev;                               /* enum app_severity */
	char kind[EXP_LINE_ARGS + 1];          /* 'd' int, 's' string, 'f' double per argument */
	union {
		int i;
		const char *s;
		double f;
	} arg[EXP_LINE_ARGS];
};

/* what the start of a phase needs of the step that ended the previous one (a copy: the
 * frame is gone by the time the turn runs between frames) */
struct exp_turn {
	scalar_t thr_prev0;                    /* rotor 1's throttle sent before that step */
	scalar_t thr_prev_all[HAL_ROTORS];     /* every rotor's */
	scalar_t rotor_f_cmd0;                 /* rotor 1's thrust allocated before that step */
	scalar_t thrust_n[HAL_ROTORS], torque_nm[HAL_ROTORS], rate_b_rps[3];   /* of its frame */
};

/* the experiment's configuration (ID_* parameters), read once at exp_start */
struct exp_cfg {
	float exc_amp, exc_time, mot_tau, inr_amp, inr_time, val_time, rsd_max, exc_ofs;
	float rot_to, inr_to, val_to;          /* phase time limits (0: automatic) */
	uint32_t exc_kind, exc_div, seed, delay_fr;
	bool exc_null, crv_est;
};

struct experiment {
	const struct mixer *mix;               /* the app's mixer: its Gamma gives the inertia phases' torque */
	/* id and state are experiment.c's alone: exp_start sets them, exp_step and exp_abort
	 * move the state on; the app reads them */
	int id;                                /* MAV_CMD_USER_1 param1; 0 = none */
	enum exp_state state;
	int phase;
	float progress;                        /* 0..1 */
	int n_est;
	char est_name[EXP_MAX_EST][11];        /* NAMED_VALUE_FLOAT names, <= 10 chars */
	float est[EXP_MAX_EST], est_sd[EXP_MAX_EST];
	char msg[APP_EVENT_TEXT];              /* pending status line ("" = none) */
	int msg_severity;                      /* enum app_severity */
	int n_results;
	struct exp_result results[EXP_MAX_RESULTS];
	int n_ids;                             /* results as data of the last phase's end: the app */
	struct app_id_result ids[EXP_MAX_IDS]; /* numbers and posts them, then sets n_ids = 0 */
	bool ids_final;                        /* they are the run's last */
	uint32_t est_live;                     /* bit i: est[i] is being estimated (streamed) */
	int final_result;                      /* enum app_result of the command's final answer */

	/* implementation state (experiment.c) */
	int n_phases, phase_kind[EXP_MAX_PHASES];
	float t_phase;                         /* time in the current phase, s */
	float t_settle, t_run;                 /* of the current phase */
	bool started, reporting;
	float dt_nom, z0;
	float inv_dt_nom;                      /* 1 / dt_nom: frames in a step's dt */
	float prog_base, prog_rate;            /* progress = base + min(t_phase, total) rate */
	float t_total, t_limit;                /* the phase's planned time and time limit (phase_limit) */
	float fr_dt;                           /* the last step's dt_s ... */
	int fr_n;                              /* ... and the frames it spans (phase_step) */
	int gap_hold;                          /* frames left without inertia updates after a gap */
	struct exp_cfg cfg;
	struct excite exc;
	struct excite exc2;                    /* rotor experiment: the second pattern's dither */
	uint32_t rot_k;                        /* rotor experiment: excited frames so far */
	uint32_t est_wait;                     /* steps until est[] / est_sd[] are read again */
	scalar_t inr_u_prev;                   /* inertia: the excitation of the previous step (the instrument) */
	/* the estimator of the current phase: phases never overlap, so they share the memory
	 * (each phase_begin initialises its own; phase_end reads it before the next begins) */
	union {
		struct {                           /* rotor coefficients */
			struct ident_rotor rot;    /* rotor 1, model given (and the paper's plain) */
			struct motor_id mid;       /* every rotor, the motor model found (motor_id.h) */
			scalar_t pat[2][HAL_ROTORS]; /* the two null-space patterns (excite_null_pattern) */
			scalar_t ofs;              /* ID_EXC_OFS: the offset's amplitude */
		};
		struct ident_inertia inr;          /* inertia Ixx, Iyy or Izz */
		struct {                           /* validation */
			struct ident_fit fit;
			struct filt_delay val_delay;
			struct filt_lag val_lag;
		};
	};
	bool turn_pending;                     /* a phase ended: exp_turn ends it, starts the next */
	bool begin_pending;                    /* the first step ran: exp_turn begins the first phase */
	struct exp_turn turn;
	struct exp_line queue[EXP_QUEUE];      /* status lines, formatted by exp_pump */
	int q_head, q_n;
	bool pump_ready;                       /* a step ran since the last line was handed out */
};

/* Is experiment `id` (1..6) built into this firmware? */
bool exp_available(int id);

/* Starts experiment `id` (the caller has checked that the vehicle hovers).
 * Returns an app_result; on refusal `why` says why (for a status line). */
int exp_start(struct experiment *e, int id, const struct app_params *p, char *why, size_t cap);

/* Does the next exp_step read exp_input.torque_nm? Only the rotor and inertia phases do (a
 * phase's start takes its torques from the frame), so the app converts the rotor torques to
 * scalars only for them. */
bool exp_reads_torque(const struct experiment *e);

/* One control step while running; fills *out (zeroed by the caller). */
enum exp_state exp_step(struct experiment *e, const struct exp_input *in, struct exp_output *out);

/* Between frames, before results are applied: when the last exp_step ended a phase, ends it
 * (estimates, verdicts, results, status lines) and starts the next one from what that step
 * saw, so that the step itself stays a step (exp_step does it first if the app did not). */
void exp_turn(struct experiment *e, const struct app_params *p);

/* Between frames (the app's tick, before it sends msg): formats the next queued status line
 * into msg when msg is free, at most one per exp_step. */
void exp_pump(struct experiment *e);

/* Stops a running experiment (reason for the log/STATUSTEXT); results dropped. */
void exp_abort(struct experiment *e, const char *reason);

#endif /* OCTO_EXPERIMENT_H */
