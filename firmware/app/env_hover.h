/*
 * env_hover.h - the hover throttle learned in flight (core/hover_est), and what it gives
 * the step: the height controller's hover thrust 8 VEH_KF u_h, and the gain on the attitude
 * loop's torque demands that takes out the throttle map's error at hover. Between frames:
 * the HOV_* values of a HOLD entry, and the VEH_KF seed before a rotor experiment.
 * Why: docs/octo-fw.md, "Flight envelope".
 *
 * Knows nothing of the app: it reads its inputs and the parameters, and what it asks of
 * the app (parameters to write, a status line to post) is in its outputs.
 */
#ifndef OCTO_ENV_HOVER_H
#define OCTO_ENV_HOVER_H

#include <stdbool.h>

#include "hover_est.h"
#include "params.h"
#include "sc_recip.h"
#include "vec3.h"

struct env_hover {
	struct hover_est hov;
	bool pub_due;           /* a HOLD entry's HOV_* wait for env_hover_publish */
	scalar_t pub_u, pub_sd; /* the hover throttle and its sd at that entry */
	scalar_t kf8;           /* 8 VEH_KF (N at full throttle, all rotors) */
	struct sc_recip kf8_r;  /* its reciprocal, for the step's division by it */
	/* the hover thrust kf8 / theta of the last step and its operands: the division is redone
	 * only when one changed (theta stays while the estimator only tracks) */
	scalar_t hf_kf8, hf_theta, hf;
	bool hf_ok;
	/* the torque demands' gain: the target set between frames, the value the step applies */
	scalar_t tau_k_target, tau_k;
};

/* One step's inputs (scalars of this frame). */
struct env_hover_input {
	scalar_t f_achieved;  /* the collective thrust the mixer achieved last step, N */
	scalar_t z_m, vz_mps; /* height and vertical speed */
	scalar_t z_ground_m;  /* the take-off ground */
	scalar_t cos_tilt;    /* the body's z axis, up component */
	scalar_t dt_s;
	bool learn_mode;    /* TAKEOFF, HOLD or LAND: airborne measurements teach */
	bool takeoff_climb; /* TAKEOFF with a set point above the vehicle (spool up) */
};

/* A HOLD entry's publication: HOV_THR, HOV_THR_SD, HOV_KF, HOV_KF_SD and a status line. */
struct env_hover_pub {
	float u, sd, kf, kf_sd;
};

/* From the parameters: the estimator starts at m g / (8 VEH_KF); the torque gain at 1. */
void env_hover_init(struct env_hover *h, const struct app_params *p);
/* After a parameter change: what the step reads of VEH_KF. */
void env_hover_model_sync(struct env_hover *h, const struct app_params *p);

/* Once per flying step, before the height controller: learns from the last step and returns
 * the hover thrust demand in the mixer's newtons, 8 VEH_KF u_h. *up: above the take-off
 * ground by more than the airborne margin. */
scalar_t env_hover_step(struct env_hover *h, const struct env_hover_input *in, bool *up);

/* Nothing learned yet (no airborne measurement since the last init). */
static inline bool env_hover_untaught(const struct env_hover *h) { return h->hov.updates == 0; }
/* Take-off may end (HOLD) once the hover throttle is known to 3 % (relative sd). */
bool env_hover_ready(const struct env_hover *h);

/* On entering HOLD: what the hover taught is noted for env_hover_publish. */
void env_hover_on_hold(struct env_hover *h);
/* Between frames: true (and *out) once after a HOLD entry. */
bool env_hover_publish(struct env_hover *h, const struct app_params *p, struct env_hover_pub *out);

/* Between frames: the torque demands' gain, from the hover throttle learned so far: the
 * map's thrust at hover against m g, within 0.5-1 (1 until the hover is known). */
void env_hover_torque_scale(struct env_hover *h, const struct app_params *p);
/* In the step: the torque demand with that gain (moving 2 % of the way to its target per step). */
struct vec3 env_hover_torque(struct env_hover *h, struct vec3 tau);

/* Before experiment `id`: true with *kf = m g / (8 u_h) when NAV_KF_SEED asks for it, the
 * experiment identifies the rotors, the hover is known and VEH_KF is more than 10 % off. */
bool env_hover_seed_kf(const struct env_hover *h, const struct app_params *p, int id, float *kf);

#endif /* OCTO_ENV_HOVER_H */
