/*
 * env_kf.h - k_f tracked in flight (core/kf_track) in HOLD and during experiments, and what
 * follows from it between frames: the KFT_* parameters once a second of plant time, and a
 * VEH_KF refresh when it drifts beyond KFT_REFRESH after an identification (a warmed-up
 * tracker, a drift seen three publications in a row) or on request (KFT_APPLY = 1).
 *
 * Knows nothing of the app: the step gives it this frame's thrusts and throttles, and the
 * publication is a request (the values to write and announce, a VEH_KF to set and why)
 * that the app carries out.
 *
 * The measured thrust y (env_hover.h, ENV_SRC_*): the thrust rows summed, or
 * VEH_MASS VEH_GRAV a_z from the calibrated accelerometer. The accelerometer's vibration
 * is coloured at the frame rate: the tracker then updates on 0.1 s means (kf_track.h, avg_n).
 * A change of source restarts the tracker.
 *
 * The sd published (KFT_SD, and the log's) is absolute: the tracking's sd (kf_track_sd,
 * relative to the rotor model it regresses on) combined in quadrature with the model's own
 * relative sd, that of k_f in the last accepted identification (ID_KF_SD / ID_KF_EST,
 * which carries the thrust curve's and the motor lag's shares: motor_id.h), after an
 * identification from the thrust rows the tracker's drift over the span of its data
 * (exp_rotor_span_s: a drift biases the identified curve, and so the model's hover thrust,
 * beyond ID_KF_SD), and with the accelerometer, its bias walk since the ground calibration
 * (KFT_ACC_WALK). The model's error is common to the tracked and the identified k_f, so a
 * VEH_KF refresh keeps it:
 * the refresh compares the tracked drift with the tracking sd alone, and the later
 * publications still carry the identification's share. Without an accepted identification
 * the model is the one given (MOT_CURVE, MOT_SCALE*, ID_MOT_TAU) and KFT_SD carries no share
 * of it. docs/identification.md, "k_f tracked in flight".
 *
 * A fold the tracker cannot see: with the accelerometer, a rotor speed whose first or second
 * harmonic lies within KFT_FOLD_HZ of a multiple of the frame rate shakes the reading at
 * nearly 0 Hz after the 90 Hz read, a swing slower than the tracker's windows whose first
 * turn looks like a drift. With the ESCs' speeds the fold's frequency is known: the
 * publications pause while it is that slow, and say so ("KFT paused: ..."), rather than
 * publish an sd that cannot carry it.
 */
#ifndef OCTO_ENV_KF_H
#define OCTO_ENV_KF_H

#include <stdbool.h>
#include <stdint.h>

#include "env_hover.h"
#include "hal.h"
#include "kf_track.h"
#include "params.h"

struct env_kf {
	struct kf_track kft;
	enum env_src src;     /* what the running tracker's y is */
	scalar_t mg;          /* VEH_MASS VEH_GRAV, N: the thrust of 1 g of specific force */
	float model_rsd;      /* the rotor model's relative sd (an accepted identification's k_f) */
	float drift_span_s;   /* s: a drift biases the identified model over this (exp_rotor_span_s; 0: none) */
	float walk_rel2;      /* (KFT_ACC_WALK / VEH_GRAV)^2: relative variance per second of the calibration's age */
	double t_cal;         /* plant time of the accelerometer's calibration (src IMU) */
	double pub_next_t;    /* plant time of the next publication (1 s after the last) */
	uint64_t pub_wall_us; /* wall time of the last announced one */
	uint32_t votes;       /* consecutive publications that called for a VEH_KF refresh */
	bool pub_due;         /* the last step reached pub_next_t: env_kf_publish's turn */
	bool pub_hold;        /* and flew in HOLD (where VEH_KF may be refreshed) */
	float spd_hz;         /* the rotors' mean speed, Hz, smoothed (src IMU with the ESCs' speeds; 0: none) */
	uint32_t fold_votes;  /* publications in a row whose fold (its first two harmonics' nearest
			       * to 0 Hz at the frame rate) lay below KFT_FOLD_HZ */
	bool folded;          /* a steady fold that slow: the estimate is not published */
};

/* One step's inputs. */
struct env_kf_input {
	const scalar_t *thrust_n; /* HAL_ROTORS measured rotor thrusts of this frame (src THRUST) */
	scalar_t acc_z_g;         /* the calibrated specific force along body z, g (src IMU) */
	enum env_src src;         /* what the thrust is measured with (env_hover_src) */
	double t_cal_s;           /* plant time of the accelerometer's calibration (src IMU) */
	const scalar_t *thr;      /* HAL_ROTORS throttles of the last step (what acts now) */
	scalar_t dt_s;
	double t_s;             /* this frame's plant time */
	const float *speed_rps; /* HAL_ROTORS rotor speeds, rad/s (NULL: not delivered) */
	bool gate;              /* HOLD or an experiment, airborne, the source's measurement in this frame */
	bool hold;              /* in HOLD */
};

/* What a publication asks of the app, in this order: KFT_EST, KFT_SD (absolute), KFT_T, KFT_MEM set
 * (announced as PARAM_VALUE and the values "KFT", "KFT_SD" when `announce`); KFT_APPLY set
 * back to 0 (clear_apply); VEH_KF := kf (refresh, with `why` for its status line). */
struct env_kf_pub {
	bool paused;   /* a fold near 0 Hz: nothing set, nothing refreshed (KFT_* keep their last values) */
	int8_t fold;   /* +1: paused now, -1: resumed now (a status line each), 0: as before */
	float fold_hz; /* the fold's frequency, Hz */
	float k, sd, t, mem;
	bool announce;
	bool clear_apply;
	bool refresh;
	float kf;
	const char *why;
};

/* Starts the tracker at VEH_KF with the rotor model of the parameters (and the source of the
 * last step: thrust rows before any). */
void env_kf_init(struct env_kf *k, const struct app_params *p);
/* After a parameter change: a changed rotor model (lag, curve, scales, drift bound, and
 * with the accelerometer the mass) restarts the tracker from the current VEH_KF; the model's
 * sd and the walk are read again. */
void env_kf_model_sync(struct env_kf *k, const struct app_params *p);
/* In the step, every flying frame (p: for a restart on a change of source). */
void env_kf_step(struct env_kf *k, const struct env_kf_input *in, const struct app_params *p);
/* A publication is due (env_kf_publish has something to say). */
static inline bool env_kf_due(const struct env_kf *k) { return k->pub_due; }
/* Between frames: true (and *out) after a step that reached the next second of plant time.
 * now_us: wall time (announcements at most once a wall second); t_s: the frame's plant
 * time; dt_frame: the frame period (the tracker's warm-up is counted in frames). */
bool env_kf_publish(struct env_kf *k, const struct app_params *p, uint64_t now_us, double t_s, float dt_frame,
		    struct env_kf_pub *out);

/* The absolute sd of the estimate at plant time t_s (header comment). */
float env_kf_sd_abs(const struct env_kf *k, double t_s);

/* The estimate and its absolute sd for the log (false before the first estimate, and while
 * paused by a fold). */
static inline bool env_kf_estimate(const struct env_kf *k, double t_s, float *kf, float *sd)
{
	if (!k->kft.started || k->folded)
		return false;
	*kf = sc_to_float(k->kft.k);
	*sd = env_kf_sd_abs(k, t_s);
	return true;
}

#endif /* OCTO_ENV_KF_H */
