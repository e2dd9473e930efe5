/* envelope.c - see envelope.h. */
#include "envelope.h"

#include <math.h>
#include <stdio.h>

#include "app.h"
#include "outbox.h"
#include "params.h"

#define HOVER_READY_RSD 0.03f  /* take-off ends once u_h is known to 3 % */
#define AIRBORNE_M 0.1f        /* above the take-off ground: the acceleration is free */
#define KF_SEED_REL 0.10f      /* NAV_KF_SEED: VEH_KF replaced when this far off */
#define ENV_OSC_RATE_DPS 12.0f /* the oscillation guard's rate rms (deg/s) */
#define ENV_OSC_DETUNE 0.85f   /* its factor on ATT_WN_RP */
#define ENV_OSC_KEEP 0.8f      /* sustained: the rms of a second at least this share of the one before */
#define ENV_OSC_MIN_FRAMES 45u /* a second with fewer frames is not judged */

static float nominal_u(const struct app_params *p)
{
	return p->veh_mass * p->veh_grav / (8.0f * p->veh_kf);
}

/* A parameter changed by the envelope: the ground station hears of it (PARAM_VALUE). */
static void post_param(struct app *a, int index)
{
	struct app_event ev = {.kind = APP_EV_PARAM, .param_index = (uint16_t)index};
	outbox_post(&a->outbox, &ev);
}

/* A live value for the ground station (NAMED_VALUE_FLOAT). */
static void post_value(struct app *a, const char *name, float v)
{
	struct app_event ev = {.kind = APP_EV_VALUE, .value = v};
	snprintf(ev.text, sizeof ev.text, "%s", name);
	outbox_post(&a->outbox, &ev);
}

/* The tracker's model of the rotors: the vehicle's motor lag, thrust curve and per-rotor
 * effectiveness, as identified (or given). */
static struct kf_track_params kft_params(const struct app_params *p)
{
	struct kf_track_params kp = kf_track_params_default();
	kp.drift_per_min = sc_from_float(p->kft_drift);
	kp.tau_lag_s = sc_from_float(p->id_mot_tau);
	kp.curve = sc_from_float(p->mot_curve);
	const float scale[KF_TRACK_ROTORS] = {p->mot_scale1, p->mot_scale2, p->mot_scale3, p->mot_scale4,
					      p->mot_scale5, p->mot_scale6, p->mot_scale7, p->mot_scale8};
	for (int j = 0; j < KF_TRACK_ROTORS; j++)
		kp.scale[j] = sc_from_float(scale[j]);
	return kp;
}

#define KFT_WARM_S 10.0f   /* s of tracker updates before it may refresh VEH_KF */
#define KFT_VOTES 3u       /* publications in a row that must call for the refresh */

static void kft_init(struct app *a)
{
	struct kf_track_params kp = kft_params(&a->p);
	kf_track_init(&a->env.kft, &kp, sc_from_float(a->p.veh_kf));
	a->env.kft_pub_next_t = 1.0;
	a->env.kft_votes = 0;
	a->env.kft_pub_due = false;
}

void envelope_model_sync(struct app *a)
{
	/* An estimate made with another rotor model (before identification found the curve,
	 * lag or a weak rotor) would be compared with the new VEH_KF and "refresh" it wrongly:
	 * a changed model restarts the tracker from the current VEH_KF. */
	struct kf_track_params kp = kft_params(&a->p);
	const struct kf_track_params *cur = &a->env.kft.p;
	bool same = kp.tau_lag_s == cur->tau_lag_s && kp.curve == cur->curve &&
		    kp.drift_per_min == cur->drift_per_min;
	for (int j = 0; j < KF_TRACK_ROTORS; j++)
		same = same && kp.scale[j] == cur->scale[j];
	if (!same)
		kft_init(a);
	a->env.kf8 = sc_mul(SC(8.0), sc_from_float(a->p.veh_kf));
	a->env.kf8_r = sc_recip_of(a->env.kf8);
}

void envelope_init(struct app *a)
{
	kft_init(a);
	struct hover_est_params hp = hover_est_params_default();
	hp.g_mps2 = sc_from_float(a->p.veh_grav);
	hover_est_init(&a->env.hov, &hp, sc_from_float(nominal_u(&a->p)));
	a->env.tau_k = a->env.tau_k_target = SC(1.0);
}

static void set_result(struct app *a, int i, float v);

static void set_kft(struct app *a, int i, float v, bool announce)
{
	if (params_set(&a->p, (size_t)i, v) == PARAM_OK && announce)
		post_param(a, i);
}

static void set_veh_kf(struct app *a, float kf, const char *why)
{
	float old = a->p.veh_kf;
	if (params_set(&a->p, PX_VEH_KF, kf) != PARAM_OK)
		return;
	post_param(a, PX_VEH_KF);
	a->params_dirty = true;
	a->save_pending = true;
	app_status(a, APP_SEV_INFO, "VEH_KF %.2f -> %.2f N (%s)", (double)old, (double)kf, why);
}

/* k_f tracking in HOLD and experiments: the last step's throttles (what the plant answers now) against
 * the sum of the measured rotor thrusts of this frame. */
static void kft_step(struct app *a, scalar_t s_dt, bool up)
{
	struct envelope *e = &a->env;
	struct kf_track *t = &e->kft;
	const scalar_t *f = app_in(a)->rotor_thrust_n;
	scalar_t y = SC_ZERO;   /* the sum in scalars: float's own sum in the float build */
	for (int j = 0; j < HAL_ROTORS; j++)
		y = sc_add(y, f[j]);
	/* in HOLD and in the experiments (their excitation only adds information; a rotor model
	 * found by identification restarts the tracker, envelope_model_sync) */
	bool gate = (a->mode == APP_HOLD || a->mode == APP_EXPERIMENT) && up && (a->fr.valid & HAL_FRAME_THRUST);
	kf_track_update(t, app_thr_sc(a), HAL_ROTORS, y, s_dt, gate);
	/* The KFT_* parameters once a second of plant time, published between frames
	 * (envelope_publish): the step only notes that this frame is due and whether it flew in
	 * HOLD. */
	if (!t->started || app_t_before(a->fr.t_s, e->kft_pub_next_t))
		return;
	e->kft_pub_next_t = a->fr.t_s + 1.0;
	e->kft_pub_due = true;
	e->kft_pub_hold = a->mode == APP_HOLD;
}

static void publish_kft(struct app *a);
static void publish_hover(struct app *a);
static void guard_osc(struct app *a);

void envelope_publish(struct app *a)
{
	publish_hover(a);
	publish_kft(a);
	guard_osc(a);
}

float envelope_osc_rms_dps(const struct app *a)
{
	return sqrtf(a->env.osc_last_ms) / DEG_F;
}

bool envelope_oscillating(const struct app *a)
{
	return envelope_osc_rms_dps(a) > ENV_OSC_RATE_DPS;
}

void envelope_osc_step(struct app *a)
{
	struct envelope *e = &a->env;
	const scalar_t *w = app_in(a)->rate_b_rps;
	e->osc_ss = sc_add(e->osc_ss, sc_add(sc_mul(w[0], w[0]), sc_mul(w[1], w[1])));   /* saturates */
	if (e->osc_n < UINT16_MAX)
		e->osc_n++;
	if (app_t_before(a->fr.t_s, e->osc_next_t))
		return;
	e->osc_next_t = a->fr.t_s + 1.0;
	e->osc_due_ss = e->osc_ss;
	e->osc_due_n = e->osc_n;
	e->osc_due_mode = (uint8_t)a->mode;
	e->osc_due = true;
	e->osc_ss = SC_ZERO;
	e->osc_n = 0;
}

/* The oscillation guard's judgement of the last whole second (envelope.h). */
static void guard_osc(struct app *a)
{
	struct envelope *e = &a->env;
	if (!e->osc_due)
		return;
	e->osc_due = false;
	const float lim = ENV_OSC_RATE_DPS * DEG_F;
	bool judged = (e->osc_due_mode == APP_TAKEOFF || e->osc_due_mode == APP_HOLD) &&
		      e->osc_due_n >= ENV_OSC_MIN_FRAMES;
	float ms = judged ? sc_to_float(e->osc_due_ss) / (float)e->osc_due_n : 0.0f, prev = e->osc_prev_ms;
	e->osc_prev_ms = e->osc_last_ms = ms;
	if (!(ms > lim * lim && prev > lim * lim && ms >= ENV_OSC_KEEP * ENV_OSC_KEEP * prev))
		return;
	e->osc_prev_ms = 0.0f;   /* the next detune needs two more seconds of it */
	float wn = a->p.att_wn_rp, nw = fmaxf(wn * ENV_OSC_DETUNE, param_defs[PX_ATT_WN_RP].min);
	if (!(nw < wn) || params_set(&a->p, PX_ATT_WN_RP, nw) != PARAM_OK) {
		app_status(a, APP_SEV_WARNING, "Attitude oscillation %.0f deg/s: ATT_WN_RP at its minimum",
			   (double)(sqrtf(ms) / DEG_F));
		return;
	}
	post_param(a, PX_ATT_WN_RP);
	a->params_dirty = true;
	a->save_pending = true;
	app_status(a, APP_SEV_WARNING, "Attitude oscillation %.0f deg/s: ATT_WN_RP %.2f -> %.2f",
		   (double)(sqrtf(ms) / DEG_F), (double)wn, (double)nw);
}

/* The KFT_* parameters of the last due step and, in HOLD, the VEH_KF refresh. */
static void publish_kft(struct app *a)
{
	struct envelope *e = &a->env;
	const struct kf_track *t = &e->kft;
	if (!e->kft_pub_due)
		return;
	e->kft_pub_due = false;
	/* announced to the ground station (PARAM_VALUE, NAMED_VALUE_FLOAT) at most once a second
	 * of wall time, whose rates are wall-clock: a fast lockstep run must not flood the link */
	uint64_t now_us = hal_wall_us(a->hal);
	bool announce = now_us - e->kft_pub_wall_us >= 1000000u;
	if (announce)
		e->kft_pub_wall_us = now_us;
	float k = sc_to_float(t->k), sd = sc_to_float(kf_track_sd(t));
	set_kft(a, PX_KFT_EST, k, announce);
	set_kft(a, PX_KFT_SD, sd, announce);
	set_kft(a, PX_KFT_T, (float)a->fr.t_s, announce);
	set_kft(a, PX_KFT_MEM, sc_to_float(t->mem_s), announce);
	if (announce) {
		post_value(a, "KFT", k);
		post_value(a, "KFT_SD", sd);
	}
	if (!e->kft_pub_hold)
		return;
	if (a->p.kft_apply >= 0.5f) {
		if (params_set(&a->p, PX_KFT_APPLY, 0.0f) == PARAM_OK)
			post_param(a, PX_KFT_APPLY);
		set_veh_kf(a, k, "tracked, on request");
		return;
	}
	float rel = k / a->p.veh_kf - 1.0f;
	bool identified = ((unsigned)a->p.id_result & 1u) != 0;   /* k_f accepted by identification */
	/* A refresh needs a warmed-up tracker (KFT_WARM_S of updates since its last start: the
	 * throttles jump when a new rotor model is applied, and the first memories follow that
	 * transient) and a drift seen on KFT_VOTES publications in a row (1 s apart): a battery
	 * sags for minutes, a transient does not last. */
	bool call = a->p.kft_refresh > 0.0f && identified && fabsf(rel) > a->p.kft_refresh &&
		    3.0f * sd < a->p.kft_refresh * k && (float)t->updates * a->dt_frame >= KFT_WARM_S;
	e->kft_votes = call ? e->kft_votes + 1u : 0u;
	if (e->kft_votes >= KFT_VOTES) {
		e->kft_votes = 0;
		set_veh_kf(a, k, rel < 0.0f ? "tracked drift down" : "tracked drift up");
	}
}

/* the same scalar, by its bits (an integer comparison in both builds: no soft-float call) */
static bool same_bits(scalar_t a, scalar_t b)
{
	_Static_assert(sizeof(scalar_t) == sizeof(uint32_t), "a scalar is one word");
	union { scalar_t s; uint32_t u; } x = {a}, y = {b};
	return x.u == y.u;
}

scalar_t envelope_hover_f(struct app *a, scalar_t s_dt, scalar_t cos_tilt)
{
	struct envelope *e = &a->env;
	/* collective throttle of the last step's achieved thrust (linearised by the map), in
	 * scalars: the same float operations in the float build, integer ones in the fixed.
	 * kf8 is the one of the step's start (a refresh by kft_step below takes effect with
	 * the next step, after the parameter sync). */
	scalar_t kf8 = e->kf8;
	scalar_t s_u = sc_div_r(a->mix_out.achieved[0], kf8, &e->kf8_r);   /* sc_div by kf8 exactly */
	scalar_t s_z = app_in(a)->pos_i_m[2];
	bool up = sc_sub(s_z, a->guid.z_ground_m) > SC(AIRBORNE_M);
	bool learn = up && (a->mode == APP_TAKEOFF || a->mode == APP_HOLD || a->mode == APP_LAND);
	scalar_t s_vz = app_in(a)->vel_i_mps[2], s_c = cos_tilt;
	e->hov_used = false;
	if (learn)
		e->hov_used = hover_est_update(&e->hov, s_vz, s_u, s_c, s_dt);
	else
		hover_est_track(&e->hov, s_vz, s_u, s_c, s_dt);
	kft_step(a, s_dt, up);
	/* a climb commanded that has not lifted off: the hover throttle is higher */
	if (a->mode == APP_TAKEOFF && !up && sc_to_float(a->guid.z_sp_m) > a->fr.pos_i_m[2] + 0.05f)
		hover_est_spool(&e->hov, s_dt);
	/* 8 k_f u_h = 8 k_f / theta (hover_est.h): one rounding */
	if (!e->hf_ok || !same_bits(kf8, e->hf_kf8) || !same_bits(e->hov.theta, e->hf_theta)) {
		e->hf_kf8 = kf8;
		e->hf_theta = e->hov.theta;
		e->hf = sc_div(kf8, e->hf_theta);
		e->hf_ok = true;
	}
	return e->hf;
}

void envelope_torque_scale(struct app *a)
{
	struct envelope *e = &a->env;
	float k = 1.0f;
	if (e->hf_ok && envelope_hover_ready(a)) {
		float mg = a->p.veh_mass * a->p.veh_grav, hf = sc_to_float(e->hf);
		if (mg > 0.0f && hf > 0.0f)
			k = fminf(fmaxf(hf / mg, 0.5f), 1.0f);
	}
	e->tau_k_target = sc_from_float(k);
}

struct vec3 envelope_torque(struct app *a, struct vec3 tau)
{
	struct envelope *e = &a->env;
	if (!same_bits(e->tau_k, e->tau_k_target))
		e->tau_k = sc_add(e->tau_k, sc_mul(sc_sub(e->tau_k_target, e->tau_k), SC(0.02)));
	return same_bits(e->tau_k, SC(1.0)) ? tau : vec3_scale(tau, e->tau_k);
}

bool envelope_hover_ready(const struct app *a)
{
	return hover_est_converged(&a->env.hov, sc_from_float(HOVER_READY_RSD));
}

static void set_result(struct app *a, int i, float v)
{
	if (params_set(&a->p, (size_t)i, v) == PARAM_OK)
		post_param(a, i);
}

void envelope_on_command(struct app *a, enum app_command cmd, app_origin origin)
{
	a->env.cmd = (uint8_t)cmd;
	a->env.origin = origin;
}

void envelope_on_mode(struct app *a)
{
	struct envelope *e = &a->env;
	e->phase_s = 0.0f;
	e->hold_s = 0.0f;
	if (a->mode == APP_TAKEOFF && e->hov.updates == 0)
		envelope_init(a);   /* nothing learned yet: start from the current VEH_* */
	if (a->mode != APP_HOLD)
		return;
	/* what the hover taught, as of this entry; published between frames (envelope_publish) */
	e->hov_pub_u = hover_est_u(&e->hov);
	e->hov_pub_sd = hover_est_sd(&e->hov);
	e->hov_pub_due = true;
}

/* The HOV_* parameters and the status line of the last HOLD entry. */
static void publish_hover(struct app *a)
{
	struct envelope *e = &a->env;
	if (!e->hov_pub_due)
		return;
	e->hov_pub_due = false;
	float u = sc_to_float(e->hov_pub_u), sd = sc_to_float(e->hov_pub_sd);
	float kf = a->p.veh_mass * a->p.veh_grav / (8.0f * u), kf_sd = kf * sd / u;
	set_result(a, PX_HOV_THR, u);
	set_result(a, PX_HOV_THR_SD, sd);
	set_result(a, PX_HOV_KF, kf);
	set_result(a, PX_HOV_KF_SD, kf_sd);
	app_status(a, APP_SEV_INFO, "Hover throttle %.4f+/-%.4f, k_f %.2f+/-%.2f N", (double)u, (double)sd,
		   (double)kf, (double)kf_sd);
}

void envelope_seed_kf(struct app *a, int id)
{
	if (a->p.nav_kf_seed < 0.5f || (id != 1 && id != 6) || !envelope_hover_ready(a))
		return;
	float u = sc_to_float(hover_est_u(&a->env.hov));
	float kf = a->p.veh_mass * a->p.veh_grav / (8.0f * u);
	if (fabsf(kf / a->p.veh_kf - 1.0f) <= KF_SEED_REL)
		return;
	float old = a->p.veh_kf;
	if (params_set(&a->p, PX_VEH_KF, kf) != PARAM_OK)
		return;
	post_param(a, PX_VEH_KF);
	a->params_dirty = true;
	app_status(a, APP_SEV_INFO, "VEH_KF %.2f -> %.2f N (hover throttle)", (double)old, (double)kf);
}

/* Reasons fit one STATUSTEXT (50 characters); a second line says what was missing. */
static bool phase_timeout(struct app *a, float dt, char *why, size_t cap, char *more, size_t more_cap)
{
	struct envelope *e = &a->env;
	more[0] = 0;
	if (a->mode != APP_TAKEOFF && a->mode != APP_LAND)
		return false;
	e->phase_s += dt;
	float z = a->fr.pos_i_m[2] - sc_to_float(a->guid.z_ground_m);
	if (a->mode == APP_TAKEOFF && e->phase_s > a->p.nav_tko_to) {
		snprintf(why, cap, "Take-off failed: NAV_TKO_TO %.0f s, %.2f/%.2f m", (double)a->p.nav_tko_to,
			 (double)z, (double)(sc_to_float(a->guid.z_target_m) - sc_to_float(a->guid.z_ground_m)));
		if (!envelope_hover_ready(a))
			snprintf(more, more_cap, "Hover throttle %.3f+/-%.3f not learned",
				 (double)sc_to_float(hover_est_u(&e->hov)), (double)sc_to_float(hover_est_sd(&e->hov)));
		return true;
	}
	/* hold entry: the take-off's set point at the target, the vehicle still to settle there
	 * and the hover throttle to be learned (guidance's GUID_HOLD_REACHED) */
	if (a->mode == APP_TAKEOFF && a->guid.z_sp_m == a->guid.z_target_m) {
		e->hold_s += dt;
		if (e->hold_s > a->p.nav_hold_to) {
			float dz = z - (sc_to_float(a->guid.z_target_m) - sc_to_float(a->guid.z_ground_m));
			snprintf(why, cap, "Hold entry failed: NAV_HOLD_TO %g s", (double)a->p.nav_hold_to);
			if (!envelope_hover_ready(a))
				snprintf(more, more_cap, "Hover throttle %.3f+/-%.3f not learned",
					 (double)sc_to_float(hover_est_u(&e->hov)),
					 (double)sc_to_float(hover_est_sd(&e->hov)));
			else
				snprintf(more, more_cap, "Still %+.3f m %+.3f m/s off the target", (double)dz,
					 (double)a->fr.vel_i_mps[2]);
			return true;
		}
	}
	if (a->mode == APP_LAND && e->phase_s > a->p.nav_land_to) {
		snprintf(why, cap, "Landing failed: NAV_LAND_TO %.0f s, %.2f m up", (double)a->p.nav_land_to,
			 (double)z);
		e->phase_s = -1e30f;   /* said once; the landing goes on */
		return true;
	}
	return false;
}

void envelope_limits(struct app *a, float dt)
{
	char why[64], more[64];
	if (!phase_timeout(a, dt, why, sizeof why, more, sizeof more))
		return;
	app_status(a, APP_SEV_ERROR, "%s", why);
	if (more[0])
		app_status(a, APP_SEV_ERROR, "%s", more);
	if (a->env.cmd && a->env.origin != APP_ORIGIN_NONE) {
		struct app_event ev = {.kind = APP_EV_CMD_DONE, .cmd = a->env.cmd, .result = APP_FAILED,
				       .origin = a->env.origin};
		outbox_post(&a->outbox, &ev);
	}
	if (a->mode == APP_TAKEOFF) {   /* the take-off or its hold entry ran out: land */
		char w[8];
		app_cmd_land(a, APP_ORIGIN_NONE, w, sizeof w);   /* the take-off's origin has its answer */
	}
}
