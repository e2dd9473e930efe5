/* env_limits.c - see env_limits.h. */
#include "env_limits.h"

void env_limits_on_command(struct env_limits *l, enum app_command cmd, app_origin origin)
{
	l->cmd = (uint8_t)cmd;
	l->origin = origin;
}

void env_limits_sync(struct env_limits *l, const struct app_params *p)
{
	l->scale_sum = p->mot_scale1 + p->mot_scale2 + p->mot_scale3 + p->mot_scale4 + p->mot_scale5 + p->mot_scale6 +
		       p->mot_scale7 + p->mot_scale8;
}

void env_limits_on_mode(struct env_limits *l)
{
	l->phase_s = 0.0f;
	l->hold_s = 0.0f;
}

static void not_learned(const struct env_limits_input *in, struct line *more)
{
	line_set(more, APP_SEV_ERROR, "Hover throttle %.3f+/-%.3f not learned",
		 (double)sc_to_float(hover_est_u(&in->hover->hov)), (double)sc_to_float(hover_est_sd(&in->hover->hov)));
}

/* The vehicle's thrust-to-weight from the hover throttle learned (the share u_h of all
 * rotors' full thrust, 8 VEH_KF, that holds the weight): MOT_SCALE's sum over 8 u_h. Below
 * NAV_TW_MIN the attitude and height loops have too little thrust in hand to fly an
 * experiment or a gust, so the take-off ends, before HOLD, as soon as the hover throttle is
 * learned, and says so. */
static bool too_heavy(const struct env_limits *l, const struct env_limits_input *in, const struct app_params *p,
		      struct env_limits_req *r)
{
	if (!(p->nav_tw_min > 0.0f) || !env_hover_ready(in->hover))
		return false;
	float u_h = sc_to_float(hover_est_u(&in->hover->hov)), s = l->scale_sum;
	float tw = u_h > 0.0f ? s / ((float)HAL_ROTORS * u_h) : 0.0f;
	if (!(tw < p->nav_tw_min))
		return false;
	line_set(&r->why, APP_SEV_ERROR, "Take-off failed: thrust-to-weight %.2f < %.2f", (double)tw,
		 (double)p->nav_tw_min);
	line_set(&r->more, APP_SEV_ERROR, "Hover at %.0f %% of full thrust: lighten it",
		 (double)(100.0f * u_h * (float)HAL_ROTORS / s));
	return true;
}

static bool timeout(struct env_limits *l, const struct env_limits_input *in, const struct app_params *p,
		    struct env_limits_req *r)
{
	r->more.fmt = NULL;
	if (!in->takeoff && !in->land)
		return false;
	l->phase_s += in->dt_s;
	if (in->takeoff && l->phase_s > p->nav_tko_to) {
		line_set(&r->why, APP_SEV_ERROR, "Take-off failed: NAV_TKO_TO %.0f s, %.2f/%.2f m",
			 (double)p->nav_tko_to, (double)in->z_m, (double)in->target_m);
		if (!env_hover_ready(in->hover))
			not_learned(in, &r->more);
		return true;
	}
	if (in->takeoff && too_heavy(l, in, p, r))
		return true;
	/* hold entry: the take-off's set point at the target, the vehicle still to settle there
	 * and the hover throttle to be learned (guidance's GUID_HOLD_REACHED) */
	if (in->takeoff && in->sp_at_target) {
		l->hold_s += in->dt_s;
		if (l->hold_s > p->nav_hold_to) {
			line_set(&r->why, APP_SEV_ERROR, "Hold entry failed: NAV_HOLD_TO %g s", (double)p->nav_hold_to);
			if (!env_hover_ready(in->hover))
				not_learned(in, &r->more);
			else
				line_set(&r->more, APP_SEV_ERROR, "Still %+.3f m %+.3f m/s off the target",
					 (double)(in->z_m - in->target_m), (double)in->vz_mps);
			return true;
		}
	}
	if (in->land && l->phase_s > p->nav_land_to) {
		line_set(&r->why, APP_SEV_ERROR, "Landing failed: NAV_LAND_TO %.0f s, %.2f m up",
			 (double)p->nav_land_to, (double)in->z_m);
		l->phase_s = -1e30f; /* said once; the landing goes on */
		return true;
	}
	return false;
}

bool env_limits_step(struct env_limits *l, const struct env_limits_input *in, const struct app_params *p,
		     struct env_limits_req *req)
{
	if (!timeout(l, in, p, req))
		return false;
	req->cmd = l->cmd;
	req->origin = l->origin;
	req->land = in->takeoff;
	return true;
}
