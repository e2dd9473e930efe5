/* env_kf.c - see env_kf.h. */
#include "env_kf.h"

#include <math.h>

#include "experiment.h"
#include "fcmp.h"

#define KFT_WARM_S 10.0f /* s of tracker updates before it may refresh VEH_KF */
#define KFT_VOTES 3u     /* publications in a row that must call for the refresh */
#define IMU_AVG_N 9u     /* frames per sample with the accelerometer (0.1 s at 90 Hz) */
#define IMU_T_MIN_S 1.0f /* the shortest memory then: ten samples */
/* A fold of the rotors' vibration slower than this pauses the publications (env_kf.h); it
 * resumes above FOLD_OFF_HZ. The tracker's sd follows a swing of 0.1 Hz or faster within
 * the test's warm-up (its long windows' and slow parts: kf_track.h); the mean of 8 rotors'
 * reports over 2 s resolves the speed to a few hundredths of a hertz. */
#define KFT_FOLD_HZ 0.1f
#define FOLD_OFF_HZ 0.15f
#define FOLD_AVG_S 2.0f /* s: the rotors' mean speed smoothed over this, while the tracker updates */
#define FOLD_VOTES 5u   /* publications (1 s apart) in a row below KFT_FOLD_HZ: a steady fold, not a passage */

/* The tracker's model of the rotors: the vehicle's motor lag, thrust curve and per-rotor
 * effectiveness, as identified (or given); with the accelerometer, samples of IMU_AVG_N
 * frames (its vibration is coloured at the frame rate: kf_track.h). */
static struct kf_track_params kft_params(const struct app_params *p, enum env_src src)
{
	struct kf_track_params kp = kf_track_params_default();
	if (src == ENV_SRC_IMU) {
		kp.avg_n = IMU_AVG_N;
		kp.t_min_s = sc_from_float(IMU_T_MIN_S);
	}
	kp.drift_per_min = sc_from_float(p->kft_drift);
	kp.tau_lag_s = sc_from_float(p->id_mot_tau);
	kp.curve = sc_from_float(p->mot_curve);
	const float scale[KF_TRACK_ROTORS] = {p->mot_scale1, p->mot_scale2, p->mot_scale3, p->mot_scale4,
					      p->mot_scale5, p->mot_scale6, p->mot_scale7, p->mot_scale8};
	for (int j = 0; j < KF_TRACK_ROTORS; j++)
		kp.scale[j] = sc_from_float(scale[j]);
	return kp;
}

/* What the parameters say of the uncertainty the tracker rests on. */
static void model_sd(struct env_kf *k, const struct app_params *p)
{
	bool kf_ok = ((unsigned)p->id_result & 1u) != 0 && p->id_kf_est > 0.0f && p->id_kf_sd > 0.0f;
	k->model_rsd = kf_ok ? p->id_kf_sd / p->id_kf_est : 0.0f;
	/* with the thrust rows (ID_SRC_USED 1) the identified model's drift share (env_kf_sd_abs) */
	k->drift_span_s = kf_ok && p->id_src_used == 1.0f ? exp_rotor_span_s(p) : 0.0f;
	float w = p->veh_grav > 0.0f ? p->kft_acc_walk / p->veh_grav : 0.0f;
	k->walk_rel2 = w * w;
}

static void start(struct env_kf *k, const struct app_params *p, enum env_src src)
{
	struct kf_track_params kp = kft_params(p, src);
	kf_track_init(&k->kft, &kp, sc_from_float(p->veh_kf));
	k->src = src;
	k->mg = sc_from_float(p->veh_mass * p->veh_grav);
	model_sd(k, p);
	k->votes = 0;
}

void env_kf_init(struct env_kf *k, const struct app_params *p)
{
	start(k, p, k->src == ENV_SRC_IMU ? ENV_SRC_IMU : ENV_SRC_THRUST);
	k->pub_next_t = 1.0;
	k->pub_due = false;
}

void env_kf_model_sync(struct env_kf *k, const struct app_params *p)
{
	/* An estimate made with another rotor model (before identification found the curve,
	 * lag or a weak rotor) would be compared with the new VEH_KF and "refresh" it wrongly. */
	struct kf_track_params kp = kft_params(p, k->src);
	const struct kf_track_params *cur = &k->kft.p;
	bool same = kp.tau_lag_s == cur->tau_lag_s && kp.curve == cur->curve && kp.drift_per_min == cur->drift_per_min;
	for (int j = 0; j < KF_TRACK_ROTORS; j++)
		same = same && kp.scale[j] == cur->scale[j];
	if (k->src == ENV_SRC_IMU) /* the thrust is m a_z: another mass, another measurement */
		same = same && sc_from_float(p->veh_mass * p->veh_grav) == k->mg;
	if (!same)
		start(k, p, k->src);
	model_sd(k, p);
}

float env_kf_sd_abs(const struct env_kf *k, double t_s)
{
	float kf = sc_to_float(k->kft.k), sd = sc_to_float(kf_track_sd(&k->kft));
	float rel2 = k->model_rsd * k->model_rsd;
	if (k->drift_span_s > 0.0f) {
		/* the identified model's share of a drift: k_f drifting over the motor model's last
		 * stage biases the curve, and so the model's hover thrust the tracker divides by, by up
		 * to the drift over that span (the sweep's rises lie in the stage's first part, its
		 * dithers on through the tail: docs/identification.md, "KFT_SD is absolute"). The
		 * drift is the tracker's own (its long windows' slope, bounded by KFT_DRIFT), the bound
		 * until it has measured one. */
		const struct kf_track *t = &k->kft;
		float mem = sc_to_float(t->mem_s);
		float r = t->l_count && mem > 0.0f ? fabsf(sc_to_float(t->l_slope_pct)) / (100.0f * mem)
						   : sc_to_float(t->p.drift_per_min) / 60.0f;
		float d = r * k->drift_span_s;
		rel2 += d * d;
	}
	if (k->src == ENV_SRC_IMU && t_s > k->t_cal)
		rel2 += k->walk_rel2 * (float)(t_s - k->t_cal);
	return sqrtf(sd * sd + kf * kf * rel2);
}

/* The last step's throttles (what the plant answers now) against the thrust measured in
 * this frame: the sum of the rotors' thrust rows, or m g a_z. */
void env_kf_step(struct env_kf *k, const struct env_kf_input *in, const struct app_params *p)
{
	if (in->src != k->src && in->src != ENV_SRC_NONE) /* another measurement: start again */
		start(k, p, in->src);
	k->t_cal = in->t_cal_s;
	struct kf_track *t = &k->kft;
	scalar_t y = SC_ZERO; /* the sum in scalars: float's own sum in the float build */
	if (k->src == ENV_SRC_IMU)
		y = sc_mul(k->mg, in->acc_z_g);
	else if (in->thrust_n)
		for (int j = 0; j < HAL_ROTORS; j++)
			y = sc_add(y, in->thrust_n[j]);
	kf_track_update(t, in->thr, HAL_ROTORS, y, in->dt_s, in->gate && in->src != ENV_SRC_NONE);
	if (k->src == ENV_SRC_IMU && in->speed_rps && in->gate) {
		float w = 0.0f, dt = sc_to_float(in->dt_s);
		for (int j = 0; j < HAL_ROTORS; j++)
			w += in->speed_rps[j];
		float f = w / (6.2831853f * (float)HAL_ROTORS), a = fminf(dt / FOLD_AVG_S, 1.0f);
		k->spd_hz = k->spd_hz > 0.0f && isfinite(f) ? k->spd_hz + a * (f - k->spd_hz) : f;
	} else if (k->src != ENV_SRC_IMU || !in->speed_rps) {
		k->spd_hz = 0.0f;
	}
	/* the publication once a second of plant time, between frames: the step only notes
	 * that this frame is due and whether it flew in HOLD */
	if (!t->started || app_t_before(in->t_s, k->pub_next_t))
		return;
	k->pub_next_t = in->t_s + 1.0;
	k->pub_due = true;
	k->pub_hold = in->hold;
}

bool env_kf_publish(struct env_kf *k, const struct app_params *p, uint64_t now_us, double t_s, float dt_frame,
		    struct env_kf_pub *out)
{
	const struct kf_track *t = &k->kft;
	if (!k->pub_due)
		return false;
	k->pub_due = false;
	/* the fold: the nearest multiple of the frame rate to the first and second harmonics */
	bool was = k->folded;
	float fold = INFINITY;
	if (k->spd_hz > 0.0f && isfinite(k->spd_hz) && dt_frame > 0.0f) {
		float fs = 1.0f / dt_frame;
		for (int h = 1; h <= 2; h++) {
			float x = (float)h * k->spd_hz;
			fold = fminf(fold, fabsf(x - fs * roundf(x / fs)));
		}
	}
	k->fold_votes = fold < KFT_FOLD_HZ ? k->fold_votes + 1u : 0u;
	k->folded = was ? fold < FOLD_OFF_HZ : k->fold_votes >= FOLD_VOTES;
	out->fold = (int8_t)(k->folded == was ? 0 : k->folded ? 1 : -1);
	out->fold_hz = fold;
	out->paused = k->folded;
	if (k->folded) {
		k->votes = 0;
		out->clear_apply = out->refresh = out->announce = false;
		return true;
	}
	/* announced to the ground station at most once a second of wall time, whose rates are
	 * wall-clock: a fast lockstep run must not flood the link */
	out->announce = now_us - k->pub_wall_us >= 1000000u;
	if (out->announce)
		k->pub_wall_us = now_us;
	/* sd: the tracking's (the drift against VEH_KF, whose model error is the same); the
	 * published one is absolute */
	float kf = sc_to_float(t->k), sd = sc_to_float(kf_track_sd(t));
	out->k = kf;
	out->sd = env_kf_sd_abs(k, t_s);
	out->t = (float)t_s;
	out->mem = sc_to_float(t->mem_s);
	out->clear_apply = out->refresh = false;
	out->kf = kf;
	out->why = "";
	if (!k->pub_hold)
		return true;
	if (p->kft_apply >= 0.5f) {
		out->clear_apply = out->refresh = true;
		out->why = "tracked, on request";
		return true;
	}
	float rel = kf / p->veh_kf - 1.0f;
	bool identified = ((unsigned)p->id_result & 1u) != 0; /* k_f accepted by identification */
	/* A refresh needs a warmed-up tracker (KFT_WARM_S of updates since its last start: the
	 * throttles jump when a new rotor model is applied, and the first memories follow that
	 * transient) and a drift seen on KFT_VOTES publications in a row (1 s apart): a battery
	 * sags for minutes, a transient does not last. */
	bool call = p->kft_refresh > 0.0f && identified && fabsf(rel) > p->kft_refresh &&
		    3.0f * sd < p->kft_refresh * kf && (float)t->updates * dt_frame >= KFT_WARM_S;
	k->votes = call ? k->votes + 1u : 0u;
	if (k->votes >= KFT_VOTES) {
		k->votes = 0;
		out->refresh = true;
		out->why = rel < 0.0f ? "tracked drift down" : "tracked drift up";
	}
	return true;
}
