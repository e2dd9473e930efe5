/*
 * env_osc.h - the oscillation guard. The step adds the roll and pitch rates of every flying
 * frame into the current second of plant time; between frames each whole second flown in
 * TAKEOFF or HOLD is judged: two seconds in a row whose rate rms exceeds 12 deg/s, the
 * second at least 0.8 of the first (not decaying), ask for ATT_WN_RP lowered by 15 %
 * (within its range). No experiment starts on an oscillating vehicle. Why: docs/octo-fw.md,
 * "Flight envelope".
 *
 * Knows nothing of the app: its judgement is a request (the gain to lower, from and to,
 * with the rms for the warning) that the app carries out.
 */
#ifndef OCTO_ENV_OSC_H
#define OCTO_ENV_OSC_H

#include <stdbool.h>
#include <stdint.h>

#include "params.h"

struct env_osc {
	/* the rates' sum of squares over the current second and its frames; the last whole
	 * second's, waiting for the judgement, and whether it was flown in TAKEOFF or HOLD */
	scalar_t ss, due_ss;
	uint16_t n, due_n;
	bool due_judged;
	bool due;
	double next_t;
	float prev_ms; /* the second before's mean square (0: none, or not judged) */
	float last_ms; /* the last whole second's mean square (0 outside TAKEOFF and HOLD) */
};

/* A judgement that found an oscillation: ATT_WN_RP from wn to nw (nw < wn), or, when it is
 * at its minimum already (at_min), only the warning. */
struct env_osc_req {
	float rms_dps;
	float wn, nw;
	bool at_min;
};

/* In the step (flying modes): this frame's body rates and plant time; judged: the frame
 * flies in TAKEOFF or HOLD. */
void env_osc_step(struct env_osc *o, const scalar_t rate_b_rps[3], double t_s, bool judged);
/* Between frames: true (and *req) when the last whole second calls for a detune. */
bool env_osc_judge(struct env_osc *o, const struct app_params *p, struct env_osc_req *req);

/* The last whole second's roll and pitch rate rms (deg/s; 0 outside TAKEOFF and HOLD), and
 * whether it is over the guard's limit. */
float env_osc_rms_dps(const struct env_osc *o);
bool env_osc_oscillating(const struct env_osc *o);

#endif /* OCTO_ENV_OSC_H */
