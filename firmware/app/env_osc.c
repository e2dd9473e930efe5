/* env_osc.c - see env_osc.h. */
#include "env_osc.h"

#include <math.h>

#include "fcmp.h"

#define DEG 0.017453292519943295f /* rad per degree */
#define ENV_OSC_RATE_DPS 12.0f    /* the guard's rate rms (deg/s) */
#define ENV_OSC_DETUNE 0.85f      /* its factor on ATT_WN_RP */
#define ENV_OSC_KEEP 0.8f         /* sustained: the rms of a second at least this share of the one before */
#define ENV_OSC_MIN_FRAMES 45u    /* a second with fewer frames is not judged */

void env_osc_step(struct env_osc *o, const scalar_t w[3], double t_s, bool judged)
{
	o->ss = sc_add(o->ss, sc_add(sc_mul(w[0], w[0]), sc_mul(w[1], w[1]))); /* saturates */
	if (o->n < UINT16_MAX)
		o->n++;
	if (app_t_before(t_s, o->next_t))
		return;
	o->next_t = t_s + 1.0;
	o->due_ss = o->ss;
	o->due_n = o->n;
	o->due_judged = judged;
	o->due = true;
	o->ss = SC_ZERO;
	o->n = 0;
}

bool env_osc_judge(struct env_osc *o, const struct app_params *p, struct env_osc_req *req)
{
	if (!o->due)
		return false;
	o->due = false;
	const float lim = ENV_OSC_RATE_DPS * DEG;
	bool judged = o->due_judged && o->due_n >= ENV_OSC_MIN_FRAMES;
	float ms = judged ? sc_to_float(o->due_ss) / (float)o->due_n : 0.0f, prev = o->prev_ms;
	o->prev_ms = o->last_ms = ms;
	if (!(ms > lim * lim && prev > lim * lim && ms >= ENV_OSC_KEEP * ENV_OSC_KEEP * prev))
		return false;
	o->prev_ms = 0.0f; /* the next detune needs two more seconds of it */
	req->rms_dps = sqrtf(ms) / DEG;
	req->wn = p->att_wn_rp;
	req->nw = fmaxf(req->wn * ENV_OSC_DETUNE, param_defs[PX_ATT_WN_RP].min);
	req->at_min = !(req->nw < req->wn);
	return true;
}

float env_osc_rms_dps(const struct env_osc *o) { return sqrtf(o->last_ms) / DEG; }

bool env_osc_oscillating(const struct env_osc *o) { return env_osc_rms_dps(o) > ENV_OSC_RATE_DPS; }
