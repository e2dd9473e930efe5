/*
 * envelope.h - what lets octo-fw fly a vehicle whose nominal values are far off:
 * the hover throttle learned in flight (core/hover_est) and fed to the height
 * controller, the first k_f it implies (published as HOV_* parameters and a status
 * line at every HOLD entry, optionally seeding VEH_KF before the rotor experiment),
 * k_f tracked in HOLD and during experiments (core/kf_track: KFT_EST with its sd, the
 * plant time it holds for and its memory, published each second between frames as parameters and NAMED_VALUE_FLOAT
 * events "KFT"/"KFT_SD"; VEH_KF refreshed from it when it drifts beyond KFT_REFRESH after an
 * identification, or on request with KFT_APPLY = 1), and the time limits of take-off
 * (NAV_TKO_TO, to HOLD), of its hold entry (NAV_HOLD_TO: from the set point's arrival at
 * the target height to HOLD) and of landing (NAV_LAND_TO), with their reasons.
 *
 * The app calls these from a few places only (its step, set_mode, the experiment
 * command, the mode timer), so that they survive a reshaping of app.c.
 */
#ifndef OCTO_ENVELOPE_H
#define OCTO_ENVELOPE_H

#include <stdbool.h>
#include <stdint.h>

#include "hover_est.h"
#include "kf_track.h"
#include "outbox.h"
#include "sc_recip.h"

struct app;

struct envelope {
	struct hover_est hov;
	bool hov_used;      /* a measurement was taken in the last step */
	float phase_s;      /* time in the current take-off or landing */
	float hold_s;       /* time in the take-off's hold entry (set point at the target) */
	struct kf_track kft;/* k_f tracked in HOLD and experiments */
	double kft_pub_next_t; /* plant time of the next KFT_* publication (1 s after the last) */
	uint64_t kft_pub_wall_us; /* wall time of it: a fast lockstep run must not flood the link */
	uint32_t kft_votes; /* consecutive publications that called for a VEH_KF refresh */
	bool kft_pub_due;   /* the last step reached kft_pub_next_t: envelope_publish's turn */
	bool kft_pub_hold;  /* and flew in HOLD (where VEH_KF may be refreshed) */
	bool hov_pub_due;   /* a HOLD entry's HOV_* publication waits for envelope_publish */
	scalar_t hov_pub_u, hov_pub_sd; /* the hover throttle and its sd at that entry */
	scalar_t kf8;       /* 8 VEH_KF (N at full throttle, all rotors): set by envelope_model_sync */
	struct sc_recip kf8_r; /* its reciprocal, for the step's division by it */
	/* the hover thrust kf8 / theta of the last step and its operands: the division is redone
	 * only when one changed (theta stays while the estimator only tracks) */
	scalar_t hf_kf8, hf_theta, hf;
	bool hf_ok;
	/* the torque demands' gain (envelope_torque_scale): the target set between frames, the
	 * value the step applies, which follows the target over about a second */
	scalar_t tau_k_target, tau_k;
	/* the oscillation guard (envelope_osc_step, envelope_publish): the roll and pitch rates'
	 * sum of squares over the current second of plant time and its frames; the last whole
	 * second's, waiting for the guard, with the mode it flew in; the second before's mean
	 * square (0: none, or not flown in TAKEOFF or HOLD) */
	scalar_t osc_ss, osc_due_ss;
	uint16_t osc_n, osc_due_n;
	uint8_t osc_due_mode;
	bool osc_due;
	double osc_next_t;
	float osc_prev_ms;
	float osc_last_ms;  /* the last whole second's mean square (0 outside TAKEOFF and HOLD) */
	uint8_t cmd;        /* enum app_command that started the phase, for its final result */
	app_origin origin;  /* who asked for it (APP_ORIGIN_NONE: no one to answer) */
};

/* From the parameters: the estimator starts at m g / (8 VEH_KF). */
void envelope_init(struct app *a);
/* After a parameter change: restarts the k_f tracker when the rotor model it uses (lag,
 * curve, per-rotor scales, drift bound) changed, and sets what the step reads of VEH_KF. */
void envelope_model_sync(struct app *a);

/* Once per control step, before the height controller: learns from the last step
 * (vertical speed, collective throttle of the thrust the mixer achieved, tilt) and
 * returns the hover thrust demand in the mixer's newtons, 8 VEH_KF u_h. */
scalar_t envelope_hover_f(struct app *a, scalar_t dt_s, scalar_t cos_tilt);

/* Between frames: after a HOLD entry, the HOV_* parameters and the "Hover throttle" status
 * line of what the hover taught by then; after a step that reached the next second of plant
 * time, the KFT_* parameters (announced at most once a second of wall time) and, in HOLD, a
 * VEH_KF refresh from the tracker (KFT_REFRESH, KFT_APPLY). Parameter events and formatted
 * status lines are work kept out of the step. A refreshed VEH_KF reaches the controllers at
 * the parameter sync that follows, before the next step, as when the step did this itself. */
void envelope_publish(struct app *a);
/* Between frames: the gain by which the step multiplies the attitude loop's torque demands.
 * Torques reach the rotors through the throttle map's VEH_KF (and MOT_CURVE); a map that
 * gets the rotors' thrust per throttle wrong scales the attitude loop's gain by that error
 * (1.75 with VEH_KF 20 on a 35 N vehicle: with slow motors and a late link, an oscillation
 * that grew past the experiments' tilt limit). Once the hover throttle is learned, the
 * map's thrust there, 8 VEH_KF u_h, against the thrust that holds the vehicle, m g, measures
 * the error: the gain is their ratio, within 0.5-1 (1 before, and when the map is right).
 * Only lowered: the ratio is a secant (thrust / throttle), and with a thrust curve the rotors'
 * slope at hover, which the loop feels, is up to ~25 % steeper; raising the gain by the
 * secant for rotors weaker than the map overshot (a slow, late vehicle with curve 0.45 that
 * flew at the map's gain tipped over at 1.13 of it). ArduPilot's motor output scales by its
 * battery voltage for the same reason. */
void envelope_torque_scale(struct app *a);
/* In the step: the torque demand with that gain (which moves 2 % of the way to its target
 * per step, about 0.5 s at 90 Hz). */
struct vec3 envelope_torque(struct app *a, struct vec3 tau);

/* In the step (flying modes): the roll and pitch rates into the oscillation guard's second.
 * Between frames (envelope_publish), each whole second of TAKEOFF or HOLD is judged: an
 * attitude loop whose margin the vehicle does not have (a slow motor, a late link: 100 ms
 * and 3 frames at the default ATT_WN_RP) oscillates at a growing amplitude, which the
 * excitation of an experiment then takes past its tilt limit. Two seconds in a row whose
 * rate rms exceeds ENV_OSC_RATE_DPS (12 deg/s), the second at least 0.8 of the first (not
 * decaying), lower ATT_WN_RP by 15 % (within its range), with a warning that names the rms
 * and the new value; the parameter is saved, so the next flight starts from it. A stable
 * vehicle's take-off transient decays (a peak of 16 deg/s seen, 6 the second after). */
void envelope_osc_step(struct app *a);
/* The last whole second's roll and pitch rate rms (deg/s; 0 outside TAKEOFF and HOLD), and
 * whether it is over the guard's limit: no experiment starts on an oscillating vehicle. */
float envelope_osc_rms_dps(const struct app *a);
bool envelope_oscillating(const struct app *a);

/* Take-off may end (HOLD) once the hover throttle is known to this relative sd. */
bool envelope_hover_ready(const struct app *a);

/* A take-off or landing command about to start its phase (APP_CMD_TAKEOFF or
 * APP_CMD_LAND): who gets the final result should the phase run out of time. */
void envelope_on_command(struct app *a, enum app_command cmd, app_origin origin);

/* On every mode change: a HOLD entry has HOV_* and what the hover taught published by
 * envelope_publish. */
void envelope_on_mode(struct app *a);

/* Before experiment `id`: with NAV_KF_SEED = 1 and a converged hover throttle that
 * disagrees with VEH_KF by more than 10 %, VEH_KF := m g / (8 u_h) (rotor experiments). */
void envelope_seed_kf(struct app *a, int id);

/* Phase limits, once per control step: when take-off (NAV_TKO_TO), its hold entry
 * (NAV_HOLD_TO) or landing (NAV_LAND_TO) runs out, says why (status lines, severity
 * ERROR, naming what was reached and what was missing), posts the command's final result
 * APP_FAILED for whoever asked for the phase, and lands (a take-off) or keeps landing. */
void envelope_limits(struct app *a, float dt);

#endif /* OCTO_ENVELOPE_H */
