/*
 * env_kf.h - k_f tracked in flight (core/kf_track) in HOLD and during experiments, and what
 * follows from it between frames: the KFT_* parameters once a second of plant time, and a
 * VEH_KF refresh when it drifts beyond KFT_REFRESH after an identification (a warmed-up
 * tracker, a drift seen three publications in a row) or on request (KFT_APPLY = 1).
 *
 * Knows nothing of the app: the step gives it this frame's thrusts and throttles, and the
 * publication is a request (the values to write and announce, a VEH_KF to set and why)
 * that the app carries out.
 */
#ifndef OCTO_ENV_KF_H
#define OCTO_ENV_KF_H

#include <stdbool.h>
#include <stdint.h>

#include "hal.h"
#include "kf_track.h"
#include "params.h"

struct env_kf {
	struct kf_track kft;
	double pub_next_t;    /* plant time of the next publication (1 s after the last) */
	uint64_t pub_wall_us; /* wall time of the last announced one */
	uint32_t votes;       /* consecutive publications that called for a VEH_KF refresh */
	bool pub_due;         /* the last step reached pub_next_t: env_kf_publish's turn */
	bool pub_hold;        /* and flew in HOLD (where VEH_KF may be refreshed) */
};

/* One step's inputs. */
struct env_kf_input {
	const scalar_t *thrust_n; /* HAL_ROTORS measured rotor thrusts of this frame */
	const scalar_t *thr;      /* HAL_ROTORS throttles of the last step (what acts now) */
	scalar_t dt_s;
	double t_s; /* this frame's plant time */
	bool gate;  /* HOLD or an experiment, airborne, thrust rows present */
	bool hold;  /* in HOLD */
};

/* What a publication asks of the app, in this order: KFT_EST, KFT_SD, KFT_T, KFT_MEM set
 * (announced as PARAM_VALUE and the values "KFT", "KFT_SD" when `announce`); KFT_APPLY set
 * back to 0 (clear_apply); VEH_KF := kf (refresh, with `why` for its status line). */
struct env_kf_pub {
	float k, sd, t, mem;
	bool announce;
	bool clear_apply;
	bool refresh;
	float kf;
	const char *why;
};

/* Starts the tracker at VEH_KF with the rotor model of the parameters. */
void env_kf_init(struct env_kf *k, const struct app_params *p);
/* After a parameter change: a changed rotor model (lag, curve, scales, drift bound)
 * restarts the tracker from the current VEH_KF. */
void env_kf_model_sync(struct env_kf *k, const struct app_params *p);
/* In the step, every flying frame. */
void env_kf_step(struct env_kf *k, const struct env_kf_input *in);
/* A publication is due (env_kf_publish has something to say). */
static inline bool env_kf_due(const struct env_kf *k) { return k->pub_due; }
/* Between frames: true (and *out) after a step that reached the next second of plant time.
 * now_us: wall time (announcements at most once a wall second); t_s: the frame's plant
 * time; dt_frame: the frame period (the tracker's warm-up is counted in frames). */
bool env_kf_publish(struct env_kf *k, const struct app_params *p, uint64_t now_us, double t_s, float dt_frame,
		    struct env_kf_pub *out);

/* The estimate and its sd for the log (false before the first estimate). */
static inline bool env_kf_estimate(const struct env_kf *k, float *kf, float *sd)
{
	if (!k->kft.started)
		return false;
	*kf = sc_to_float(k->kft.k);
	*sd = sc_to_float(kf_track_sd(&k->kft));
	return true;
}

#endif /* OCTO_ENV_KF_H */
