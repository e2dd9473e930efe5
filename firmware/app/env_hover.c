/* env_hover.c - see env_hover.h. */
#include "env_hover.h"

#include <math.h>
#include <string.h>

#include "est_ops.h"

#define HOVER_READY_RSD 0.03f /* take-off ends once u_h is known to 3 % */
#define AIRBORNE_M 0.1f       /* above the take-off ground: the acceleration is free */
#define KF_SEED_REL 0.10f     /* NAV_KF_SEED: VEH_KF replaced when this far off */
#define CAL_BLOCK 900u        /* ground frames per calibration block (10 s at 90 Hz) */
#define TAU_K_FAR 2.0f        /* r's largest overstatement of the slope by a curve's secant (env_hover.h) */
#define TAU_K_MIN 0.1f        /* the torque gain's range: 0.1-10 */
#define TAU_K_MAX 10.0f

static float nominal_u(const struct app_params *p)
{
	return p->veh_mass * p->veh_grav / ((float)HAL_ROTORS * p->veh_kf);
}

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
	hp.tau_m_s = sc_from_float(p->id_mot_tau > 0.0f ? p->id_mot_tau : 0.0f);
	hp.drift_per_s = sc_from_float(p->kft_drift > 0.0f ? p->kft_drift / 60.0f : 0.0f);
	hover_est_init(&h->hov, &hp, sc_from_float(nominal_u(p)));
	h->tau_k = h->tau_k_target = SC(1.0);
}

void env_hover_model_sync(struct env_hover *h, const struct app_params *p)
{
	h->kf8 = sc_mul(SC(8.0), sc_from_float(p->veh_kf));
	h->kf8_r = sc_recip_of(h->kf8);
}

/* The block under way becomes the calibration: a_z at rest reads 1 + mean. */
static void cal_end(struct env_acc_cal *c, double t_s)
{
	scalar_t mean = est_div_int(c->sum, c->n);
	c->fac = sc_div(SC(1.0), sc_add(SC(1.0), mean));
	c->have = true;
	c->t_s = t_s;
	c->n_cal = c->n;
	c->sum = SC_ZERO;
	c->n = 0;
}

void env_hover_sense(struct env_hover *h, uint32_t valid, scalar_t acc_z_g, bool ground, double t_s)
{
	struct env_acc_cal *c = &h->cal;
	if (valid & HAL_FRAME_THRUST)
		c->rows = true;
	if (!ground) {
		if (c->n > 0u) /* off the ground: what the ground gave is the calibration */
			cal_end(c, t_s);
		return;
	}
	/* at rest the specific force is 1 g: the deviations summed (small: no overflow of the
	 * fixed build's sum over a block) */
	if (!(valid & HAL_FRAME_ACCEL) || !sc_isfinite(acc_z_g) || sc_abs(sc_sub(acc_z_g, SC(1.0))) > SC(0.2))
		return; /* not at rest (handled, bumped): not taken */
	c->sum = sc_add(c->sum, sc_sub(acc_z_g, SC(1.0)));
	if (++c->n >= CAL_BLOCK)
		cal_end(c, t_s);
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
	bool learn = *up && in->learn_mode;
	if (in->src == ENV_SRC_IMU) { /* the thrust per mass from the accelerometer, m/s^2 */
		scalar_t a = in->acc_ok ? sc_mul(h->hov.p.g_mps2, in->acc_z_g) : SC_ZERO;
		if (!in->acc_ok)
			hover_est_track_acc(&h->hov, a, s_u, SC_ZERO); /* no reading: the filters restart */
		else if (learn)
			hover_est_update_acc(&h->hov, a, s_u, in->dt_s);
		else
			hover_est_track_acc(&h->hov, a, s_u, in->dt_s);
	} else if (learn) {
		hover_est_update(&h->hov, in->vz_mps, s_u, in->cos_tilt, in->dt_s);
	} else {
		hover_est_track(&h->hov, in->vz_mps, s_u, in->cos_tilt, in->dt_s);
	}
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

void env_hover_on_hold(struct env_hover *h, double t_s)
{
	h->pub_t_s = t_s;
	h->pub_due = true;
}

bool env_hover_publish(struct env_hover *h, const struct app_params *p, struct env_hover_pub *out)
{
	if (!h->pub_due)
		return false;
	h->pub_due = false;
	float u = sc_to_float(hover_est_u_ahead(&h->hov)), sd = sc_to_float(hover_est_sd_err(&h->hov));
	float cal_rel2 = 0.0f;
	const struct env_acc_cal *c = &h->cal;
	if (h->hov.acc && c->have && c->n_cal > 0u && p->veh_grav > 0.0f) {
		float n = p->kft_acc_noise / p->veh_grav, w = p->kft_acc_walk / p->veh_grav;
		double age = h->pub_t_s > c->t_s ? h->pub_t_s - c->t_s : 0.0;
		cal_rel2 = n * n / (float)c->n_cal + w * w * (float)age;
	}
	sd = sqrtf(sd * sd + u * u * cal_rel2);
	out->u = u;
	out->sd = sd;
	out->kf = p->veh_mass * p->veh_grav / ((float)HAL_ROTORS * u);
	out->kf_sd = out->kf * sd / u;
	out->alloc = env_hover_alloc_learned(h);
	out->tau_k = sc_to_float(h->tau_k_target);
	return true;
}

void env_hover_torque_scale(struct env_hover *h, const struct app_params *p)
{
	float k = 1.0f;
	if (h->hf_ok && env_hover_ready(h)) {
		float mg = p->veh_mass * p->veh_grav, hf = sc_to_float(h->hf);
		if (mg > 0.0f && hf > 0.0f) { /* by compares: a NaN ratio leaves 1 */
			float r = hf / mg;
			if (r > TAU_K_FAR) /* VEH_KF too high: what no curve explains */
				k = r < TAU_K_FAR * TAU_K_MAX ? r / TAU_K_FAR : TAU_K_MAX;
			else if (r < 1.0f)
				k = r > TAU_K_MIN ? r : TAU_K_MIN; /* too low: lowered */
		}
	}
	h->tau_k_target = sc_from_float(k);
}

bool env_hover_alloc_learned(const struct env_hover *h)
{
	float k = sc_to_float(h->tau_k_target);
	return k > 1.0f || k < 1.0f / TAU_K_FAR;
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
	*kf = p->veh_mass * p->veh_grav / ((float)HAL_ROTORS * u);
	return fabsf(*kf / p->veh_kf - 1.0f) > KF_SEED_REL;
}
