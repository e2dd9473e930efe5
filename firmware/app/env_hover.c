/* env_hover.c - see env_hover.h. */
#include "env_hover.h"

#include <math.h>
#include <string.h>

#define HOVER_READY_RSD 0.03f /* take-off ends once u_h is known to 3 % */
#define AIRBORNE_M 0.1f       /* above the take-off ground: the acceleration is free */
#define KF_SEED_REL 0.10f     /* NAV_KF_SEED: VEH_KF replaced when this far off */

static float nominal_u(const struct app_params *p) { return p->veh_mass * p->veh_grav / (8.0f * p->veh_kf); }

/* the same scalar, by its bits (an integer comparison in both builds: no soft-float call) */
static bool same_bits(scalar_t a, scalar_t b)
{
	_Static_assert(sizeof(scalar_t) == sizeof(uint32_t), "a scalar is one word");
	union {
		scalar_t s;
		uint32_t u;
	} x = {a}, y = {b};
	return x.u == y.u;
}

void env_hover_init(struct env_hover *h, const struct app_params *p)
{
	struct hover_est_params hp = hover_est_params_default();
	hp.g_mps2 = sc_from_float(p->veh_grav);
	hover_est_init(&h->hov, &hp, sc_from_float(nominal_u(p)));
	h->tau_k = h->tau_k_target = SC(1.0);
}

void env_hover_model_sync(struct env_hover *h, const struct app_params *p)
{
	h->kf8 = sc_mul(SC(8.0), sc_from_float(p->veh_kf));
	h->kf8_r = sc_recip_of(h->kf8);
}

scalar_t env_hover_step(struct env_hover *h, const struct env_hover_input *in, bool *up)
{
	/* collective throttle of the last step's achieved thrust (linearised by the map), in
	 * scalars: the same float operations in the float build, integer ones in the fixed.
	 * kf8 is the one of the step's start (a VEH_KF refresh takes effect with the next step,
	 * after the parameter sync). */
	scalar_t kf8 = h->kf8;
	scalar_t s_u = sc_div_r(in->f_achieved, kf8, &h->kf8_r); /* sc_div by kf8 exactly */
	*up = sc_sub(in->z_m, in->z_ground_m) > SC(AIRBORNE_M);
	if (*up && in->learn_mode)
		hover_est_update(&h->hov, in->vz_mps, s_u, in->cos_tilt, in->dt_s);
	else
		hover_est_track(&h->hov, in->vz_mps, s_u, in->cos_tilt, in->dt_s);
	/* a climb commanded that has not lifted off: the hover throttle is higher */
	if (in->takeoff_climb && !*up)
		hover_est_spool(&h->hov, in->dt_s);
	/* 8 k_f u_h = 8 k_f / theta (hover_est.h): one rounding */
	if (!h->hf_ok || !same_bits(kf8, h->hf_kf8) || !same_bits(h->hov.theta, h->hf_theta)) {
		h->hf_kf8 = kf8;
		h->hf_theta = h->hov.theta;
		h->hf = sc_div(kf8, h->hf_theta);
		h->hf_ok = true;
	}
	return h->hf;
}

bool env_hover_ready(const struct env_hover *h) { return hover_est_converged(&h->hov, sc_from_float(HOVER_READY_RSD)); }

void env_hover_on_hold(struct env_hover *h)
{
	h->pub_u = hover_est_u(&h->hov);
	h->pub_sd = hover_est_sd(&h->hov);
	h->pub_due = true;
}

bool env_hover_publish(struct env_hover *h, const struct app_params *p, struct env_hover_pub *out)
{
	if (!h->pub_due)
		return false;
	h->pub_due = false;
	float u = sc_to_float(h->pub_u), sd = sc_to_float(h->pub_sd);
	out->u = u;
	out->sd = sd;
	out->kf = p->veh_mass * p->veh_grav / (8.0f * u);
	out->kf_sd = out->kf * sd / u;
	return true;
}

void env_hover_torque_scale(struct env_hover *h, const struct app_params *p)
{
	float k = 1.0f;
	if (h->hf_ok && env_hover_ready(h)) {
		float mg = p->veh_mass * p->veh_grav, hf = sc_to_float(h->hf);
		if (mg > 0.0f && hf > 0.0f)
			k = fminf(fmaxf(hf / mg, 0.5f), 1.0f);
	}
	h->tau_k_target = sc_from_float(k);
}

struct vec3 env_hover_torque(struct env_hover *h, struct vec3 tau)
{
	if (!same_bits(h->tau_k, h->tau_k_target))
		h->tau_k = sc_add(h->tau_k, sc_mul(sc_sub(h->tau_k_target, h->tau_k), SC(0.02)));
	return same_bits(h->tau_k, SC(1.0)) ? tau : vec3_scale(tau, h->tau_k);
}

bool env_hover_seed_kf(const struct env_hover *h, const struct app_params *p, int id, float *kf)
{
	if (p->nav_kf_seed < 0.5f || (id != 1 && id != 6) || !env_hover_ready(h))
		return false;
	float u = sc_to_float(hover_est_u(&h->hov));
	*kf = p->veh_mass * p->veh_grav / (8.0f * u);
	return fabsf(*kf / p->veh_kf - 1.0f) > KF_SEED_REL;
}
