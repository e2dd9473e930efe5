/*
 * env_limits.h - the time limits of take-off (NAV_TKO_TO, to HOLD), of its hold entry
 * (NAV_HOLD_TO: from the set point's arrival at the target height to HOLD) and of landing
 * (NAV_LAND_TO). When one runs out it asks the app to say why (status lines of severity
 * ERROR, naming what was reached and what was missing), to answer the command that started
 * the phase with FAILED, and, for a take-off, to land. A take-off also lands, before HOLD,
 * when the hover throttle it learned gives a thrust-to-weight below NAV_TW_MIN.
 *
 * Knows nothing of the app: the step gives it the phase and the vehicle's state, and the
 * timeout is a request that the app carries out.
 */
#ifndef OCTO_ENV_LIMITS_H
#define OCTO_ENV_LIMITS_H

#include <stdbool.h>
#include <stdint.h>

#include "env_hover.h"
#include "line.h"
#include "outbox.h"
#include "params.h"

struct env_limits {
	float phase_s;     /* time in the current take-off or landing */
	float hold_s;      /* time in the take-off's hold entry (set point at the target) */
	uint8_t cmd;       /* enum app_command that started the phase, for its final result */
	app_origin origin; /* who asked for it (APP_ORIGIN_NONE: no one to answer) */
	float scale_sum;   /* MOT_SCALE1..8 summed: the rotors' full thrust in VEH_KF */
};

/* One step's inputs. */
struct env_limits_input {
	bool takeoff, land; /* the phase flown */
	float dt_s;
	float z_m;      /* height above the take-off ground */
	float target_m; /* the take-off's target height above the ground */
	float vz_mps;
	bool sp_at_target;             /* the take-off's set point has reached the target */
	const struct env_hover *hover; /* the hover throttle learned so far */
};

/* A phase that ran out: the lines to post, as formats and values that the app formats
 * between frames (line.h; more.fmt NULL: one line), the command's final FAILED to send
 * (cmd != 0 and origin not APP_ORIGIN_NONE), and whether to land. Reasons fit one STATUSTEXT
 * (50 characters). */
struct env_limits_req {
	struct line why, more;
	uint8_t cmd;
	app_origin origin;
	bool land;
};

/* A take-off or landing command about to start its phase: who gets the final result. */
void env_limits_on_command(struct env_limits *l, enum app_command cmd, app_origin origin);
/* Parameters -> env_limits, between frames (the rotors' effectiveness summed). */
void env_limits_sync(struct env_limits *l, const struct app_params *p);
/* On every mode change: the phase's clocks restart. */
void env_limits_on_mode(struct env_limits *l);
/* Once per flying step: true (and *req) when the phase ran out. A landing's limit is said
 * once; the landing goes on. */
bool env_limits_step(struct env_limits *l, const struct env_limits_input *in, const struct app_params *p,
		     struct env_limits_req *req);

#endif /* OCTO_ENV_LIMITS_H */
