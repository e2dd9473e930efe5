/*
 * experiment.h - the in-flight identification experiments (MAV_CMD_USER_1 1..6). In mode
 * EXPERIMENT the app computes the hover control, then calls exp_step(), which reads
 * exp_input and adds its excitation (exp_output) to the demands and throttles. Phases end
 * and begin between frames (exp_turn); status lines are formatted there too (exp_pump). The
 * experiment reports its phase, progress and live estimates in its struct, results as data
 * (ids) and parameter results that the app applies at the next frame boundary. It aborts
 * itself (EXP_ABORTED, reason queued); the app aborts it (exp_abort) past
 * EXP_TILT_ABORT_DEG or when the link drops. The experiments, their acceptance and what
 * the app and they rely on of each other: docs/identification.md, "The experiments".
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
#include "imu_id.h"
#include "imu_scale.h"
#include "line.h"
#include "motor_id.h"
#include "outbox.h"
#include "params.h"

#define EXP_MAX_EST 8
#define EXP_MAX_RESULTS 32
#define EXP_MAX_IDS 24 /* results as data of one phase's end (the rotor model's: 15) */
#define EXP_MAX_PHASES 6
#define EXP_QUEUE 20
#define EXP_TILT_ABORT_DEG 15.0f
#define EXP_TILT_SOFT_DEG 9.0f /* beyond this tilt the excitation halves (down to EXP_GAIN_MIN) */
#define EXP_GAIN_MIN 0.125f
/* the position hold's tilt set point per axis during an experiment: both axes at it stay
 * within EXP_TILT_SOFT_DEG, and a position error met in the experiment asks for no tilt the
 * excitation's budget does not have */
#define EXP_TILT_SP_DEG 5.0f
#define EXP_HEIGHT_SOFT_M 0.75f /* beyond this climb or sink since the start the excitation halves too */
#define EXP_SWP_LEVELS 4        /* the IMU rotor experiment's sweep levels */
/* ... and with the thrust rows the lossy link's cut rise after them (rows_plan) */
#define EXP_SWP_PLANS (EXP_SWP_LEVELS + 1)

enum exp_state { EXP_IDLE = 0, EXP_RUNNING, EXP_FINISHED, EXP_ABORTED };

/* what an experiment measures the rotors with (ID_SOURCE; the codes of OCTO_ID_SOURCE) */
enum exp_source {
	EXP_SRC_THRUST = 1,     /* each rotor's thrust and torque rows (a simulator, a test bench) */
	EXP_SRC_IMU = 2,        /* gyro, accelerometer, throttles sent, mass and geometry */
	EXP_SRC_IMU_RPM = 3,    /* the IMU, and each rotor's speed (ESC telemetry) for its motor model */
	EXP_SRC_IMU_RPM_TQ = 4, /* those, and each rotor's shaft torque (ESC current) for k_tau */
};

struct exp_input {
	const struct hal_sensor_frame *frame; /* this frame (paper's frames) */
	/* this frame's measurements as scalars (converted once by the app): */
	const scalar_t *thrust_n;        /* 8 rotor thrusts, N */
	const scalar_t *torque_nm;       /* 8 rotor reaction torques, N m: read only when
						* exp_reads_torque() (NULL otherwise) */
	const scalar_t *rate_b_rps;      /* 3 body rates, rad/s */
	float dt_s;                      /* time since the previous step */
	const struct app_params *params; /* parameters in use */
	const float *wrench_dem;         /* [f, tau_x, tau_y, tau_z] of the hover control */
	const scalar_t *rotor_f_cmd;     /* 8 rotor thrusts allocated last step, N */
	const scalar_t *thr_prev;        /* 8 throttles sent on the previous frame */
	float dt_frame_s;                /* the plant's frame period (0: unknown, the
						* first step's dt_s is taken) */
};

/* in scalars: the app adds them to its scalar demands and throttles (the log has thr_delta as
 * floats); every value is small enough (|x| < 256) to be a float exactly */
struct exp_output {
	scalar_t f_delta;               /* added to the demanded thrust, N */
	scalar_t tau_delta[3];          /* added to the demanded torque, N m (mu_1) */
	scalar_t thr_delta[HAL_ROTORS]; /* added to each throttle after the map (delta_1) */
};

struct exp_result {
	int param_index; /* params_find() of the parameter */
	float value;
};

/* what the start of a phase needs of the step that ended the previous one (a copy: the
 * frame is gone by the time the turn runs between frames) */
struct exp_turn {
	scalar_t thr_prev0;                /* rotor 1's throttle sent before that step */
	scalar_t thr_prev_all[HAL_ROTORS]; /* every rotor's */
	scalar_t rotor_f_cmd0;             /* rotor 1's thrust allocated before that step */
	scalar_t thrust_n[HAL_ROTORS], torque_nm[HAL_ROTORS], rate_b_rps[3]; /* of its frame */
	float speed_rps[HAL_ROTORS];                                         /* its rotor speeds */
};

/* the experiment's configuration (ID_* parameters), read once at exp_start */
struct exp_cfg {
	float exc_amp, exc_time, mot_tau, inr_amp, inr_time, val_time, rsd_max, exc_ofs;
	float rot_to, inr_to, val_to; /* phase time limits (0: automatic) */
	uint32_t exc_kind, exc_div, seed, delay_fr;
	bool exc_null, crv_est;
	enum exp_source src;
	float col_amp, swp_thr, swp_dz, izz_sd, imu_time; /* the IMU rotor experiment's; I_z's prior */
	float slope_rsd; /* IMU: the modelled thrust's relative sd about hover (imu_id_result) */
	float tau_rsd;   /* IMU: the modelled lag's relative sd (the rotor experiment's) */
	float gp_rsd;    /* IMU: the curve's slope g'(y_h)'s relative sd (the yaw torque's scale) */
	float kf, curve; /* the rotor model the later phases fly with: VEH_KF, MOT_CURVE, or what
			  * this run found (applied only at the next frame boundary) */
	float ktau;      /* the yaw torque model's k_tau: VEH_KTAU, or the ESCs' torques' of this run */
	float kt_rsd;    /* that estimate's torque slope about hover: relative sd */
	bool kt_id;      /* k_tau identified by this run (from the ESCs' torques) */
	float sc_rsd[4]; /* IMU: the identified scales' share of the modelled torque's relative sd: roll, pitch,
			  * yaw with VEH_KTAU, yaw with the ESCs' k_tau (0: MOT_SCALE flown, not identified) */
	bool model_ok;   /* that model was identified (ID_RESULT bit 0, or this run) */
};

/* the rotors as the identified model has them: each throttle sent through the delay and the
 * lag, then k_f s_j g(y) (the IMU source's thrusts and torques) */
struct exp_rmodel {
	struct filt_delay d[HAL_ROTORS];
	struct filt_lag l[HAL_ROTORS];
	struct filt_lag l2[HAL_ROTORS]; /* the lag's output through the lag again: d y / d ln tau */
	scalar_t kfs[HAL_ROTORS];       /* k_f s_j */
	scalar_t c, c1;                 /* the curve c and 1 - c */
	scalar_t kt;                    /* k_tau / k_f */
};

struct experiment {
	const struct mixer *mix; /* the app's mixer: its Gamma gives the inertia phases' torque */
	/* id and state are experiment.c's alone: exp_start sets them, exp_step and exp_abort
	 * move the state on; the app reads them */
	int id; /* MAV_CMD_USER_1 param1; 0 = none */
	enum exp_state state;
	int phase;
	float progress; /* 0..1 */
	int n_est;
	char est_name[EXP_MAX_EST][11]; /* NAMED_VALUE_FLOAT names, <= 10 chars */
	float est[EXP_MAX_EST], est_sd[EXP_MAX_EST];
	char msg[APP_EVENT_TEXT]; /* pending status line ("" = none) */
	int msg_severity;         /* enum app_severity */
	int n_results;
	struct exp_result results[EXP_MAX_RESULTS];
	int n_ids;                             /* results as data of the last phase's end: the app */
	struct app_id_result ids[EXP_MAX_IDS]; /* numbers and posts them, then sets n_ids = 0 */
	bool ids_final;                        /* they are the run's last */
	uint32_t est_live;                     /* bit i: est[i] is being estimated (streamed) */
	int final_result;                      /* enum app_result of the command's final answer */

	/* implementation state (experiment.c) */
	int n_phases, phase_kind[EXP_MAX_PHASES];
	float t_phase;         /* time in the current phase, s */
	float t_settle, t_run; /* of the current phase */
	bool started, reporting;
	float dt_nom, z0;
	float inv_dt_nom;           /* 1 / dt_nom: frames in a step's dt */
	float prog_base, prog_rate; /* progress = base + min(t_phase, total) rate */
	float t_total, t_limit;     /* the phase's planned time and time limit (phase_limit) */
	float fr_dt;                /* the last step's dt_s ... */
	int fr_n;                   /* ... and the frames it spans (phase_step) */
	uint32_t fr_span;           /* ... the same, however long (1 after a gap beyond EXP_SPAN_MAX) */
	int gap_hold;               /* frames left without inertia updates after a gap */
	struct exp_cfg cfg;
	struct excite exc;
	struct excite exc2;          /* rotor experiment: the second pattern's dither */
	struct excite exc3;          /* IMU rotor experiment: the collective dither */
	struct excite exc4;          /* IMU rotor experiment with the rotor speeds: the yaw dither, */
	int8_t yaw_sign[HAL_ROTORS]; /* its sign on each rotor (the mixer's yaw column's; 0: none) */
	/* rotor experiment: the sweep's steps (throttle above hover) and their frames, cycled,
	 * one per period; with the thrust rows, the frames a step keeps out of the whiteness test */
	uint32_t swp_len[EXP_SWP_PLANS], swp_per;
	scalar_t swp_thr[EXP_SWP_PLANS];
	uint16_t swp_white;
	float swp_end;        /* phase time after which no step starts */
	struct exp_rmodel rm; /* IMU source: the modelled thrusts (inertia, validation) */
	scalar_t f_model[HAL_ROTORS], tq_model[HAL_ROTORS];
	float w2_gain;       /* IMU with rotor speeds: the speed^2 to "thrust" gain the motor model reads */
	uint32_t rot_k;      /* rotor experiment: excited frames so far */
	uint32_t swp_k;      /* ... its throttle sweep's clock: the plant's frames, lost ones included */
	uint32_t est_wait;   /* steps until est[] / est_sd[] are read again */
	scalar_t inr_u_prev; /* inertia: the excitation of the previous step (the instrument's input) */
	scalar_t exc_gain;   /* the phase's excitation scale: 1, halved beyond EXP_TILT_SOFT_DEG or EXP_HEIGHT_SOFT_M */
	scalar_t exc_cap;    /* rotor phase: the dithers' scale against the hover throttle (1 elsewhere) */
	float exc_cut_t;     /* t_phase of the last halving */
	float exc_over_t;    /* t_phase the tilt or the height was last beyond its soft limit */
	scalar_t exc_top;    /* what a recovery doubles back to: half the scale last over a limit */
	bool exc_up;         /* the scale doubled back since the last halving */
	bool ext_done;       /* the phase's excitation was extended (once at most) */
	scalar_t inr_gate_k; /* inertia: the gyro outlier gate's rate change per N m of torque */
	int inr_skip;        /* inertia: frames since the filters' last, past gyro outliers */
	/* the estimator of the current phase: phases never overlap, so they share the memory
	 * (each phase_begin initialises its own; phase_end reads it before the next begins) */
	union {
		struct {                         /* rotor coefficients */
			struct ident_rotor rot;  /* rotor 1, model given (and the paper's plain) */
			struct motor_id mid;     /* every rotor, the motor model found (motor_id.h) */
			struct imu_id imid;      /* the IMU source's collective model (imu_id.h) */
			struct imu_scale isc;    /* with the speeds: each rotor's effectiveness (imu_scale.h) */
			float thr_h[HAL_ROTORS]; /* the throttles at the IMU rotor phase's start */
			bool isc_early;          /* the early scales were solved (scales_early) */
			/* thrust rows: each step a dip of swp_dn_len frames, the rise (swp_len
			 * frames), a dip again (rows_plan); the dips' throttle below hover
			 * (swp_dn, negative) and each rotor's rise and dips (sweep_rotors), from
			 * its throttle summed over the settle (thr_n frames) and each level's
			 * thrust ratios over the hover's */
			uint32_t swp_dn_len[EXP_SWP_PLANS], swp_kmax;
			scalar_t swp_dn[EXP_SWP_PLANS];
			scalar_t swp_thr_r[EXP_SWP_PLANS][HAL_ROTORS], swp_dn_r[EXP_SWP_PLANS][HAL_ROTORS];
			scalar_t thr_sum[HAL_ROTORS];
			uint32_t thr_n;
			float swp_ratio[EXP_SWP_PLANS], swp_dn_ratio[EXP_SWP_PLANS], swp_curve, swp_thr_max;
			/* the lossy link's rule (rows_level): the sweep's clock at the last lost
			 * frame (swp_lost: one was lost in the phase), the pattern last chosen
			 * (swp_cut: its rise cut) and the one last counted; patterns flown, cut */
			uint32_t swp_lost_k, swp_pat, swp_pat_n, swp_n_pat, swp_n_cut;
			bool swp_lost, swp_cut;
			bool swp_rotors;             /* swp_thr_r, swp_dn_r are planned */
			uint16_t swp_white_dn;       /* the frames a dip keeps out of the whiteness test */
			scalar_t pat[2][HAL_ROTORS]; /* the two null-space patterns (excite_null_pattern) */
			scalar_t ofs;                /* ID_EXC_OFS: the offset's amplitude */
		};
		struct { /* inertia Ixx, Iyy or Izz */
			struct ident_inertia inr;
			struct filt_delay inr_delay; /* the instrument through the motor model */
			struct filt_lag inr_lag;
		};
		struct { /* validation */
			struct ident_fit fit;
			struct filt_delay val_delay;
			struct filt_lag val_lag;
		};
	};
	bool turn_pending;  /* a phase ended: exp_turn ends it, starts the next */
	bool begin_pending; /* the first step ran: exp_turn begins the first phase */
	struct exp_turn turn;
	struct line queue[EXP_QUEUE]; /* status lines, formatted by exp_pump (line.h) */
	int q_head, q_n;
	bool pump_ready; /* a step ran since the last line was handed out */
};

/* The span (s) of the rotor experiment's data behind the motor model's estimates with the
 * thrust rows and the throttle sweep: its last stage, MOTOR_ID_LAST_PCT of ID_EXC_TIME to the
 * phase's end (the sweep's tail included); 0 without the sweep. Under a drift of k_f the
 * identified curve, and so the model's hover thrust, is off by up to the drift over this span
 * (env_kf.h). */
float exp_rotor_span_s(const struct app_params *p);

/* Is experiment `id` (1..6) built into this firmware? */
bool exp_available(int id);

/* Starts experiment `id` (the caller has checked that the vehicle hovers).
 * Returns an app_result; on refusal `why` says why (for a status line). */
int exp_start(struct experiment *e, int id, const struct app_params *p, enum exp_source src, char *why, size_t cap);

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
