/*
 * experiment.c - in-flight identification experiments; contract and design in
 * experiment.h, estimators in firmware/core/ident.h.
 */
#include "experiment.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "fcmp.h"

enum phase_kind {
	PK_NONE = 0,
	PK_VAL_PRE,  /* validation before rotor identification (ID_VAL_*_PRE) */
	PK_ROTOR,    /* k_f, k_tau */
	PK_VAL_POST, /* validation after it (ID_VAL_*_POST) */
	PK_INR_X,
	PK_INR_Y,
	PK_INR_Z,
	PK_VAL, /* experiment 2 alone: PRE or POST by ID_RESULT bit 1 */
};

static const char *phase_name(int k)
{
	switch (k) {
	case PK_VAL_PRE:
	case PK_VAL_POST:
	case PK_VAL: return "validation";
	case PK_ROTOR: return "rotor coefficients";
	case PK_INR_X: return "inertia Ixx";
	case PK_INR_Y: return "inertia Iyy";
	case PK_INR_Z: return "inertia Izz";
	}
	return "?";
}

#define SETTLE_S 1.0f       /* no excitation, filters run, before each phase's excitation */
#define HEIGHT_ABORT_M 1.5f /* |z - z at start| beyond this aborts */
#define GAP_HOLD 10         /* frames without inertia updates after interpolated lost frames */
/* inertia: lost frames up to this many are interpolated through (ident_inertia_gap); after a
 * longer gap, or one of unknown length, the filters restart and are left GAP_SETTLE_TC of
 * their time constants 1 / (zeta wc) to settle */
#define GAP_INTERP_MAX 4
#define GAP_SETTLE_TC 5.0f
/* inertia: a gyro reading whose change since the filters' last one exceeds, per frame,
 * INR_GATE_W rad/s (5 sds of the change for a gyro noise of 0.04 rad/s) plus
 * INR_GATE_MARGIN times what the torques on either side can do, dt (|tau_k| + |tau_(k-1)|) /
 * VEH_I (a 30 % error in VEH_I covered), is an outlier (an IMU spike): taken as a lost frame */
#define INR_GATE_W 0.3f
#define INR_GATE_MARGIN 1.5f
#define LAG_TOL 0.1f /* lag check off by more (relative): k_f, k_tau rejected */
/* inertia: roll/pitch by a multisine (harmonics 4..15 of 0.5 Hz: 2..7.5 Hz, above the
 * attitude loop, where torque turns into acceleration rather than tilt) of peak ID_INR_AMP,
 * SVF corner 25 rad/s; yaw (weak torque, so the gyro noise matters more) by a PRBS at the
 * ID_EXC_DIV clock, peak ID_INR_AMP / 10, SVF corner 12 rad/s */
#define INR_WC_RP_RPS 25.0f
#define INR_WC_YAW_RPS 12.0f
#define INR_MS_K_FIRST 4u
#define INR_MS_COUNT 12u
#define INR_YAW_DIV 10.0f /* yaw (and validation mu_1) amplitude: ID_INR_AMP / 10 */
#define INR_AMP_DEF 0.8f
#define INR_ZETA 0.7f
#define INR_RAMP_S 0.5f /* the inertia excitation's fade-in */
#define PRBS_ORDER 9u
#define OFS_SEG_FRAMES 45u /* rotor experiment: frames per offset level (0.5 s at 90 Hz) */
#define EST_READ_FRAMES 9u /* steps between reads of the live estimates (10 Hz at 90 Hz) */
#define MOT_NE_MAX 1.3f    /* motor model: largest residual over noise variance */
#define IMU_HAC_MAX 100.0f /* the IMU's collective model: largest cluster factor (sd x 10) */
#define VAL_IMU_F 0.1f     /* IMU validation: mu_1 on the thrust demand, this share of the weight */
#define SCALE_LO 0.3f      /* accepted range of a rotor's effectiveness */
#define SCALE_HI 1.5f

static const char *const est_names[EXP_MAX_EST] = {
	"KF", "KTAU", "KF_PLAIN", "KTAU_PLAIN", "IXX", "IYY", "IZZ", "VAL_NE",
};

/* ---------------------------------------------------------------- helpers */

/* a parameter's value, or def if not finite */
static float cfg_f(float v, float def) { return isfinite(v) ? v : def; }

static uint32_t cfg_u(float v, uint32_t lo, uint32_t hi)
{
	if (!(v >= (float)lo))
		return lo;
	if (v > (float)hi)
		return hi;
	return (uint32_t)(v + 0.5f);
}

/* The experiment's configuration, read once at exp_start: the ID_* parameters are locked
 * while it runs (app_param_write refuses them, and no result writes these). */
static void cfg_resolve(struct exp_cfg *c, const struct app_params *p)
{
	c->exc_amp = cfg_f(p->id_exc_amp, 0.04f);
	c->exc_time = cfg_f(p->id_exc_time, 10.0f);
	c->exc_kind = cfg_u(cfg_f(p->id_exc_kind, 1.0f), 0u, 2u);
	c->exc_div = cfg_u(cfg_f(p->id_exc_div, 9.0f), 1u, 1000u);
	c->exc_null = cfg_f(p->id_exc_null, 1.0f) >= 0.5f;
	c->seed = cfg_u(cfg_f(p->id_seed, 1.0f), 0u, 1000000u);
	c->mot_tau = cfg_f(p->id_mot_tau, 0.03f);
	c->delay_fr = cfg_u(cfg_f(p->id_delay_fr, 0.0f), 0u, FILT_DELAY_MAX);
	c->inr_amp = cfg_f(p->id_inr_amp, INR_AMP_DEF);
	c->inr_time = cfg_f(p->id_inr_time, 10.0f);
	c->val_time = cfg_f(p->id_val_time, 5.0f);
	c->rsd_max = cfg_f(p->id_rsd_max, 0.02f);
	c->exc_ofs = cfg_f(p->id_exc_ofs, 0.03f);
	c->crv_est = cfg_f(p->id_crv_est, 1.0f) >= 0.5f;
	c->rot_to = cfg_f(p->id_rot_to, 0.0f);
	c->inr_to = cfg_f(p->id_inr_to, 0.0f);
	c->val_to = cfg_f(p->id_val_to, 0.0f);
	c->col_amp = cfg_f(p->id_col_amp, 0.03f);
	c->swp_thr = cfg_f(p->id_swp_thr, 0.25f);
	c->swp_dz = cfg_f(p->id_swp_dz, 0.3f);
	c->izz_sd = cfg_f(p->id_izz_pri_sd, 0.0f);
	c->imu_time = cfg_f(p->id_imu_time, 30.0f);
	c->kf = p->veh_kf;
	c->curve = p->mot_curve;
	c->ktau = p->veh_ktau;
	c->kt_rsd = 0.0f;
	c->kt_id = false;
	/* the rotor model flown with: identified if an earlier rotor experiment was accepted */
	float rm = cfg_f(p->id_result, 0.0f);
	c->model_ok = rm >= 0.0f && rm < 256.0f && ((uint32_t)rm & 1u) != 0u;
	/* until this run's IMU rotor experiment says better: k_f's own relative sd (the
	 * slope about hover is known at least as well as the extrapolation to full throttle) */
	float kf_rsd = p->veh_kf > 0.0f ? cfg_f(p->id_kf_sd, 0.0f) / p->veh_kf : 0.0f;
	c->slope_rsd = isfinite(kf_rsd) && kf_rsd > 0.0f ? kf_rsd : 0.0f;
	c->tau_rsd = 0.0f; /* ID_MOT_TAU given: taken as exact */
	/* and the curve's sd through g'(y) = 1 - c + 2 c y, near hover (y << 1): dg'/dc ~ -1 */
	float crv_sd = cfg_f(p->id_crv_sd, 0.0f);
	c->gp_rsd = crv_sd > 0.0f ? crv_sd : 0.0f;
}

/* the experiment measures with the IMU (with or without the rotor speeds) */
static bool imu_src(const struct exp_cfg *c)
{
	return c->src == EXP_SRC_IMU || c->src == EXP_SRC_IMU_RPM || c->src == EXP_SRC_IMU_RPM_TQ;
}

/* ... with the rotor speeds */
static bool rpm_src(const struct exp_cfg *c) { return c->src == EXP_SRC_IMU_RPM || c->src == EXP_SRC_IMU_RPM_TQ; }

/* Status lines are queued with their arguments (line.h) and formatted (vsnprintf with %f:
 * costly) by exp_pump, between frames, not in the 90 Hz step. A %s argument is a string that
 * outlives the experiment: literals only. */
static void say(struct experiment *e, int sev, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void say(struct experiment *e, int sev, const char *fmt, ...)
{
	if (e->q_n >= EXP_QUEUE)
		return;
	struct line *l = &e->queue[(e->q_head + e->q_n) % EXP_QUEUE];
	va_list ap;
	va_start(ap, fmt);
	line_vset(l, sev, fmt, ap);
	va_end(ap);
	e->q_n++;
}

static void read_estimates(struct experiment *e);
static void scales_early(struct experiment *e);
static void sweep_rotors(struct experiment *e);

/* one queued line into the app's pending slot when it is free and a step ran since the last
 * one (one line per frame, as before: the app sends it on its tick) */
void exp_pump(struct experiment *e)
{
	/* the estimators' updates of the frame the last step took (the motor model's bank update
	 * and grid refinement, rotor 1's and the inertia's RLS) and the next excitation samples,
	 * between frames (the step does them if nobody did), then the live estimates when the
	 * step asked for them */
	if (e->state == EXP_RUNNING && !e->begin_pending) {
		int k = e->phase_kind[e->phase];
		if (!e->reporting)
			excite_prepare(&e->exc); /* the next step's excitation (a multisine's sum) */
		if (!e->reporting && k == PK_ROTOR) {
			if (imu_src(&e->cfg)) {
				imu_id_process(&e->imid);
				if (rpm_src(&e->cfg)) {
					motor_id_refine(&e->mid); /* processes the waiting frame first */
					imu_scale_process(&e->isc);
					scales_early(e);
				}
				excite_prepare(&e->exc2);
				excite_prepare(&e->exc3);
				excite_prepare(&e->exc4);
			} else {
				if (e->cfg.exc_null) {
					motor_id_refine(&e->mid); /* processes the waiting frame first */
					excite_prepare(&e->exc2);
					sweep_rotors(e);
				}
				ident_rotor_process(&e->rot);
			}
		} else if (!e->reporting && (k == PK_INR_X || k == PK_INR_Y || k == PK_INR_Z)) {
			ident_inertia_process(&e->inr);
		}
		if (e->est_wait == EST_READ_FRAMES - 1u) /* read_estimates ran in the last step */
			read_estimates(e);
	}
	if (!e->pump_ready || e->msg[0] || !e->q_n)
		return;
	const struct line *l = &e->queue[e->q_head];
	line_format(l, e->msg, sizeof e->msg);
	e->msg_severity = l->sev;
	e->q_head = (e->q_head + 1) % EXP_QUEUE;
	e->q_n--;
	e->pump_ready = false;
}

static void result(struct experiment *e, int idx, float value)
{
	if (idx < 0 || (size_t)idx >= param_count || e->n_results >= EXP_MAX_RESULTS)
		return;
	e->results[e->n_results].param_index = idx;
	e->results[e->n_results].value = value;
	e->n_results++;
}

/* a parameter result, or `none` when the value is not finite */
static void result_fin(struct experiment *e, int idx, float value, float none)
{
	result(e, idx, isfinite(value) ? value : none);
}

/* A result as data (id_result.h): the quantity, its estimate and verdict; the app numbers it
 * within the run. The phase gives the experiment field: 1 rotor, 2 validation, 3-5 inertia. */
static void id_out(struct experiment *e, enum app_id_param param, int rotor, float value, float sd, bool accepted,
		   enum app_id_reason reason)
{
	if (e->n_ids >= EXP_MAX_IDS)
		return;
	int k = e->phase_kind[e->phase];
	uint8_t x = k == PK_ROTOR ? 1u : (k >= PK_INR_X && k <= PK_INR_Z) ? (uint8_t)(3 + k - PK_INR_X) : 2u;
	e->ids[e->n_ids++] = (struct app_id_result){
		.experiment = x,
		.param = (uint8_t)param,
		.rotor = (uint8_t)rotor,
		.value = value,
		.sd = sd,
		.accepted = accepted ? 1u : 0u,
		.reason = (uint16_t)(accepted ? APP_ID_OK : reason),
		.source = (uint8_t)e->cfg.src,
	};
}

/* The motor model's results as data: one reason for what the model and the ranges decided
 * (the cause, the curve or a rotor out of range, else the partner k_f / k_tau rejected). */
static void rotor_ids(struct experiment *e, const struct motor_id_result *mr, bool ok, enum ident_verdict vf,
		      enum ident_verdict vt, bool curve_bad, int bad_rotor, float kfp, float ktp)
{
	bool model_ok = mr->cause == MOTOR_ID_OK;
	enum app_id_reason common = !model_ok        ? app_id_reason_of_cause(mr->cause)
				    : curve_bad      ? APP_ID_CURVE
				    : bad_rotor >= 0 ? APP_ID_ROTOR
						     : APP_ID_PARTNER_REJECTED;
	int culprit = !model_ok && mr->cause == MOTOR_ID_ROTOR   ? mr->cause_rotor + 1
		      : model_ok && !curve_bad && bad_rotor >= 0 ? bad_rotor + 1
								 : 0;
	int crot = common == APP_ID_ROTOR ? culprit : 0;
	id_out(e, APP_ID_KF, vf == IDENT_ACCEPT ? crot : 0, mr->kf, mr->kf_sd, ok,
	       vf != IDENT_ACCEPT ? app_id_reason_of_verdict(vf) : common);
	id_out(e, APP_ID_KTAU, vt == IDENT_ACCEPT ? crot : 0, mr->ktau, mr->ktau_sd, ok,
	       vt != IDENT_ACCEPT ? app_id_reason_of_verdict(vt) : common);
	id_out(e, APP_ID_KF_PLAIN, 0, kfp, NAN, false, APP_ID_AUXILIARY);
	id_out(e, APP_ID_KTAU_PLAIN, 0, ktp, NAN, false, APP_ID_AUXILIARY);
	id_out(e, APP_ID_MOT_TAU, crot, mr->tau, mr->tau_sd, ok, common);
	id_out(e, APP_ID_DELAY_FR, crot, (float)mr->delay, NAN, ok, common);
	if (e->cfg.crv_est)
		id_out(e, APP_ID_MOT_CURVE, crot, mr->curve, mr->curve_sd, ok, curve_bad ? APP_ID_CURVE : common);
	for (int j = 0; j < HAL_ROTORS; j++)
		id_out(e, APP_ID_MOT_SCALE, j + 1, mr->scale[j], mr->scale_sd[j], ok,
		       culprit == j + 1 ? APP_ID_ROTOR : common);
}

/* ID_RESULT is read live: the results of earlier phases change it during the experiment */
static uint32_t result_mask(const struct app_params *p)
{
	float v = cfg_f(p->id_result, 0.0f);
	return v >= 0.0f && v < 256.0f ? (uint32_t)v : 0u;
}

static void set_result_bit(struct experiment *e, const struct app_params *p, uint32_t bit, bool on)
{
	/* the pending value, if any, is the latest */
	uint32_t m = result_mask(p);
	for (int i = 0; i < e->n_results; i++)
		if (e->results[i].param_index == PX_ID_RESULT)
			m = (uint32_t)e->results[i].value;
	m = on ? (m | bit) : (m & ~bit);
	result(e, PX_ID_RESULT, (float)m);
}

/* ---------------------------------------------------------------- the IMU source */

static float mot_scale(const struct app_params *p, int j)
{
	const float s[HAL_ROTORS] = {p->mot_scale1, p->mot_scale2, p->mot_scale3, p->mot_scale4,
				     p->mot_scale5, p->mot_scale6, p->mot_scale7, p->mot_scale8};
	return isfinite(s[j]) && s[j] >= 0.0f ? s[j] : 1.0f;
}

/* the rotors as the parameters model them (ID_DELAY_FR, ID_MOT_TAU, MOT_CURVE, VEH_KF,
 * MOT_SCALEj, VEH_KTAU), from the throttles thr0 */
static void rmodel_init(struct exp_rmodel *r, const struct app_params *p, const struct exp_cfg *cf, scalar_t dt,
			const scalar_t thr0[HAL_ROTORS])
{
	for (int j = 0; j < HAL_ROTORS; j++) {
		filt_delay_init(&r->d[j], cf->delay_fr, thr0[j]);
		filt_lag_init(&r->l[j], sc_from_float(cf->mot_tau), dt, thr0[j]);
		filt_lag_init(&r->l2[j], sc_from_float(cf->mot_tau), dt, thr0[j]);
		r->kfs[j] = sc_from_float(cf->kf * mot_scale(p, j));
	}
	r->c = sc_from_float(cf->curve);
	r->c1 = sc_sub(SC(1), r->c);
	r->kt = sc_from_float(cf->kf > 0.0f ? cf->ktau / cf->kf : 0.0f);
}

/* n frames of the throttles thr_prev (n > 1 after lost frames: the plant held them); the
 * modelled thrusts f (N) and reaction-torque magnitudes tq (N m); with df, each thrust's
 * derivative in ln tau: y = U / (1 + s tau) gives tau dy/dtau = lag(y) - y */
static void rmodel_step(struct exp_rmodel *r, const scalar_t thr_prev[HAL_ROTORS], int n, scalar_t f[HAL_ROTORS],
			scalar_t tq[HAL_ROTORS], scalar_t *df)
{
	for (int j = 0; j < HAL_ROTORS; j++) {
		scalar_t y = r->l[j].y, y2 = r->l2[j].y;
		for (int i = 0; i < (n > 1 ? n : 1); i++) {
			y = filt_lag_update(&r->l[j], filt_delay_update(&r->d[j], thr_prev[j]));
			if (df)
				y2 = filt_lag_update(&r->l2[j], y);
		}
		f[j] = sc_mul(r->kfs[j], sc_mul(y, sc_add(r->c1, sc_mul(r->c, y))));
		tq[j] = sc_mul(r->kt, f[j]);
		if (df) /* d f / d y = k_f s_j (1 - c + 2 c y) */
			df[j] = sc_mul(sc_mul(r->kfs[j], sc_add(r->c1, sc_mul(sc_add(r->c, r->c), y))), sc_sub(y2, y));
	}
}

/* the force along body z the accelerometer reads, N: m g a_z (a in g) */
static scalar_t imu_force(const struct exp_input *in, const struct app_params *p)
{
	return sc_from_float(p->veh_mass * p->veh_grav * in->frame->accel_b_g[2]);
}

/* its vertical (world) component, N: m g (R a)_z, R the attitude's rotation body to world */
static scalar_t imu_force_up(const struct exp_input *in, const struct app_params *p)
{
	const float *q = in->frame->q_ib, *a = in->frame->accel_b_g; /* q: w x y z */
	float r20 = 2.0f * (q[1] * q[3] - q[0] * q[2]), r21 = 2.0f * (q[2] * q[3] + q[0] * q[1]);
	float r22 = 1.0f - 2.0f * (q[1] * q[1] + q[2] * q[2]);
	return sc_from_float(p->veh_mass * p->veh_grav * (r20 * a[0] + r21 * a[1] + r22 * a[2]));
}

/* rotor phase: the dithers' peak on a rotor (ID_EXC_AMP + ID_EXC_OFS, or ID_COL_AMP) at most
 * this share of the hover throttle; beyond it a rotor's throttle clips at 0 whenever the
 * altitude loop lowers the collective (braking after a sweep step), which raises the
 * collective and leaves a torque: the vehicle cannot brake or hold its attitude */
#define EXC_HOVER_SHARE 0.6f
static scalar_t hover_cap(float thr_h, float peak)
{
	return peak > 0.0f && EXC_HOVER_SHARE * thr_h < peak ? sc_from_float(EXC_HOVER_SHARE * thr_h / peak) : SC(1);
}

/* The rotor experiment's throttle sweep: collective steps above the hover throttle thr_h,
 * at the shares SWP_SHARE_* of ID_SWP_THR in turn (the rotors' speeds, and so the frequencies
 * their vibration aliases to, differ from step to step), each held for the frames whose
 * climb (the step's acceleration a, then coasting up against gravity) stays within
 * ID_SWP_DZ: dz = a T^2 (1 + a / g) / 2. The curve's prior gives a; one step every
 * SWP_PERIOD_S. A step's thrust is at most SWP_A_MAX_G g above the weight: a vehicle of
 * high thrust-to-weight, hovering at a few percent, would otherwise take a step of many g
 * whose few frames the motor's lag and delay stretch, and climb past the height limit; its
 * way down is at most 1 g. With the thrust rows the phase runs SWP_TAIL_S beyond its
 * excitation time without steps (the dithers go on): the vehicle is back at its height when
 * the phase ends, and the last stage of the motor model, which alone makes the estimates
 * (motor_id.h), keeps every step. */
#define SWP_PERIOD_S 1.0f
#define EXP_SPAN_MAX 1000.0f /* frames: a gap longer than this ends the experiment anyway */
#define SWP_A_MAX_G 3.0f
/* With the thrust rows a step's excursion (rows_plan) is this share of ID_SWP_DZ: the rows
 * see each step at their own noise (the accelerometer's vibration needs the IMU's whole
 * climb), and the experiment stays within the hover's height budget under a lossy link */
#define SWP_DZ_ROWS 0.667f
#define SWP_TAIL_S 1.5f
#define SWP_WHITE_TAUS 4.0f  /* lags a step's transient lasts (thrust rows: whiteness) */
#define SWP_WHITE_MIN_S 0.4f /* ... and at least this, s */
/* imu_rpm_torque's levels */
static const float SWP_SHARE_ROWS[EXP_SWP_LEVELS] = {1.0f, 0.55f, 0.8f, 0.35f};
/* Under the IMU without the ESCs' torques the steps stay lower: a step near 3 g turns the
 * rotors near the frame rate, their first harmonic aliases close to 0 Hz and each top is one
 * random offset; lower steps turn them slower (their alias lies higher and swings within the
 * step, which lasts longer for the same climb), so the curve comes out closer although its
 * leverage is less. With the torques SWP_SHARE_ROWS: k_tau's sd needs the higher steps'
 * leverage (docs/identification.md, "The sweep's levels") */
static const float SWP_SHARE_IMU[EXP_SWP_LEVELS] = {0.6f, 0.4f, 0.6f, 0.25f};
/* The thrust rows see no vibration: every step at ID_SWP_THR. Within a given excursion what a
 * step tells of the curve grows about with the cube of its height (a lower step is held
 * longer, but not long enough to make up for its leverage). */
static const float SWP_SHARE_THRUST[EXP_SWP_LEVELS] = {1.0f, 1.0f, 1.0f, 1.0f};
static void sweep_plan(struct experiment *e, const struct app_params *p, float thr_h, float dz,
		       const float share[EXP_SWP_LEVELS])
{
	const struct exp_cfg *cf = &e->cfg;
	float c = p->mot_curve, thr_max = isfinite(p->mot_thr_max) ? p->mot_thr_max : 1.0f, g = p->veh_grav;
	float gh = (1.0f - c) * thr_h + c * thr_h * thr_h;
	e->swp_per = (uint32_t)(SWP_PERIOD_S * e->inv_dt_nom + 0.5f);
	/* the throttle of the largest step: g(top) = (1 + SWP_A_MAX_G) g(thr_h) */
	float gm = (1.0f + SWP_A_MAX_G) * gh, b = 1.0f - c;
	float top_max = c > 1e-4f ? (sqrtf(b * b + 4.0f * c * gm) - b) / (2.0f * c) : gm / fmaxf(b, 1e-4f);
	for (int k = 0; k < EXP_SWP_LEVELS; k++) {
		float top = fminf(fminf(thr_h + share[k] * cf->swp_thr, thr_max), top_max);
		float gt = (1.0f - c) * top + c * top * top, a = gh > 0.0f ? g * (gt / gh - 1.0f) : 0.0f;
		e->swp_len[k] = 0u;
		e->swp_thr[k] = SC_ZERO;
		if (!(a > 0.0f) || !(cf->swp_thr > 0.0f))
			continue;
		float t = sqrtf(2.0f * dz / (a * (1.0f + a / g)));
		uint32_t n = (uint32_t)(t * e->inv_dt_nom + 0.5f);
		e->swp_len[k] = n < 1u ? 1u : (n > e->swp_per / 2u ? e->swp_per / 2u : n);
		e->swp_thr[k] = sc_from_float(top - thr_h);
	}
}

/* the thrust curve g(s) = (1 - c) s + c s^2 and its inverse */
static float curve_g(float c, float s) { return (1.0f - c) * s + c * s * s; }
static float curve_inv(float c, float gt)
{
	float b = 1.0f - c;
	return c > 1e-4f ? (sqrtf(b * b + 4.0f * c * gt) - b) / (2.0f * c) : gt / fmaxf(b, 1e-4f);
}

/* With the thrust rows each step of the sweep is a dip, the rise to its level and a dip
 * again: the first dip sinks the vehicle to -v0, the rise (a_u) carries it through to +v0 and
 * the second dip (a_d) brings it to rest at its start height. The experiment brakes the climb
 * itself rather than the altitude loop, whose collective goes through the mixer's MOT_SCALEj
 * and so leaves a torque on a weaker rotor; and the excursion, v0^2 (1 / a_d + 1 / a_u) / 2
 * below the start, is a quarter of a rise of the same frames braked at a_d, so each rise is
 * held longer within the height budget dz. A dip's thrust is SWP_DN of the hover's: deeper
 * dips would let the rise be held longer, but with the altitude loop's own answer to the
 * step they take a slow, late attitude loop's authority (dips to half the hover thrust
 * stopped several times as many such vehicles at the tilt limit as steps braked by the
 * altitude loop alone; dips to SWP_DN, as many).
 * The dithers pause through a dip (their trough, up to 0.6 of the hover throttle, would clip
 * at 0 and leave the attitude loop no room). The pattern takes at most SWP_PATTERN of a period, rise
 * and dips shortened alike; the dips' depth then balances the rise's impulse over the frames
 * as rounded. The whiteness test leaves out the rise with the motor's settling after it
 * (swp_white) and each dip's first transient (swp_white_dn). */
#define SWP_DN 0.7f
#define SWP_DN_FLOOR 0.3f /* a dip never deeper than this share of the hover's thrust */
#define SWP_PATTERN 0.8f  /* a pattern's frames at most this share of the period */
#define SWP_HEADROOM 0.5f /* sweep_rotors */
/* On a lossy link a pattern's rise is cut to SWP_A_LOSSY_G g above the weight (plan
 * EXP_SWP_LEVELS, the dips balancing it as for a full rise) when a frame was lost within
 * SWP_LOSS_S before the pattern (rows_level). The plant holds the last throttles through lost
 * frames: each one lost at a rise's end holds the rise instead of the dip, (r_u - r_d) g dt of
 * vertical speed the altitude loop must brake; at a full rise of 2.5-3 g that is 0.3 m/s a frame
 * on a 90 Hz link, and a run of lost frames there took the vehicle 0.4-0.55 m past its height
 * under 20 % loss. */
#define SWP_A_LOSSY_G 1.0f
#define SWP_LOSS_S 2.0f
static void rows_plan(struct experiment *e, const struct app_params *p, float thr_h, float dz)
{
	const struct exp_cfg *cf = &e->cfg;
	float c = p->mot_curve, g = p->veh_grav, gh = curve_g(c, thr_h);
	float ad = g * (1.0f - SWP_DN), cap = SWP_PATTERN * (float)e->swp_per;
	for (int k = 0; k < EXP_SWP_PLANS; k++) {
		bool lossy = k == EXP_SWP_LEVELS; /* the lossy link's rise: the first level's, cut */
		float top = thr_h + sc_to_float(e->swp_thr[lossy ? 0 : k]),
		      ru = gh > 0.0f ? curve_g(c, top) / gh : 1.0f;
		if (lossy) {
			ru = fminf(ru, 1.0f + SWP_A_LOSSY_G);
			e->swp_thr[k] = ru > 1.0f ? sc_from_float(curve_inv(c, ru * gh) - thr_h) : SC_ZERO;
		}
		float au = g * (ru - 1.0f);
		e->swp_len[k] = e->swp_dn_len[k] = 0u;
		e->swp_ratio[k] = e->swp_dn_ratio[k] = 1.0f;
		e->swp_dn[k] = SC_ZERO;
		if (!(au > 0.0f) || !(cf->swp_thr > 0.0f))
			continue;
		float v0 = sqrtf(2.0f * dz / (1.0f / ad + 1.0f / au));
		float n = 2.0f * v0 / au * e->inv_dt_nom, m = v0 / ad * e->inv_dt_nom;
		float sh = 2.0f * m + n > cap ? cap / (2.0f * m + n) : 1.0f;
		uint32_t nn = (uint32_t)(n * sh), mm = (uint32_t)ceilf(m * sh);
		nn = nn < 1u ? 1u : nn;
		mm = mm < 1u ? 1u : mm;
		float rdk = fmaxf(1.0f - (ru - 1.0f) * (float)nn / (2.0f * (float)mm), SWP_DN_FLOOR);
		e->swp_len[k] = nn;
		e->swp_dn_len[k] = mm;
		e->swp_ratio[k] = ru;
		e->swp_dn_ratio[k] = rdk;
		e->swp_dn[k] = sc_from_float(curve_inv(c, rdk * gh) - thr_h);
	}
	/* the excited frames by the end of the steps (swp_end): a pattern ends before it */
	e->swp_kmax = (uint32_t)(cf->exc_time * e->inv_dt_nom + 0.5f);
}

/* With the thrust rows each rotor's rise and dips multiply its own hover thrust by the
 * level's ratios (swp_ratio, swp_dn_ratio): a rotor weaker than its MOT_SCALEj hovers at a
 * higher throttle (the attitude integral's torque makes up for it), and a step of the same
 * throttle on every rotor would move its thrust less than the others', a torque step as
 * large as the step's thrust times the rotor's shortfall. Scaled alike, the thrusts keep the
 * hover's balance of torques through the step. The rise takes the rotor of the highest hover
 * throttle at most SWP_HEADROOM of its way to MOT_THR_MAX (the dips shallower with it): the
 * attitude loop, the dithers and the altitude loop's answer to the step need the rest; a
 * vehicle of low thrust-to-weight otherwise holds the rise at MOT_THR_MAX on every rotor,
 * without authority over its attitude. Each rotor's hover
 * throttle is its mean over the settle (no excitation), the curve MOT_CURVE's. Once,
 * between frames, when the settle ended; until then the step takes the common steps. */
static void sweep_rotors(struct experiment *e)
{
	if (e->swp_rotors || e->thr_n == 0u || !app_f_le(e->t_settle, e->t_phase))
		return;
	float c = e->swp_curve, tm = e->swp_thr_max, y[HAL_ROTORS], ym = 0.0f;
	for (int j = 0; j < HAL_ROTORS; j++) {
		y[j] = sc_to_float(e->thr_sum[j]) / (float)e->thr_n;
		ym = fmaxf(ym, y[j]);
	}
	float gm = curve_g(c, ym), rmax = gm > 0.0f ? curve_g(c, ym + SWP_HEADROOM * (tm - ym)) / gm : 1.0f;
	for (int k = 0; k < EXP_SWP_PLANS; k++) {
		float ru = e->swp_ratio[k], r = fminf(ru, rmax), rd = e->swp_dn_ratio[k];
		if (r < ru && ru > 1.0f) /* the dips balance the lower rise */
			rd = 1.0f - (1.0f - rd) * (r - 1.0f) / (ru - 1.0f);
		for (int j = 0; j < HAL_ROTORS; j++) {
			float gy = curve_g(c, y[j]);
			float top = fminf(curve_inv(c, r * gy), tm), dn = fmaxf(curve_inv(c, rd * gy), 0.0f);
			e->swp_thr_r[k][j] = r > 1.0f && top > y[j] ? sc_from_float(top - y[j]) : SC_ZERO;
			e->swp_dn_r[k][j] = rd < 1.0f && dn < y[j] ? sc_from_float(dn - y[j]) : SC_ZERO;
		}
	}
	e->swp_rotors = true;
}

/* ---------------------------------------------------------------- contract */

bool exp_available(int id) { return id >= 1 && id <= 6; }

float exp_rotor_span_s(const struct app_params *p)
{
	struct exp_cfg c;
	cfg_resolve(&c, p);
	if (!c.exc_null || !(c.swp_thr > 0.0f))
		return 0.0f;
	return c.exc_time * (1.0f - 0.01f * (float)MOTOR_ID_LAST_PCT) + SWP_TAIL_S;
}

int exp_start(struct experiment *e, int id, const struct app_params *p, enum exp_source src, char *why, size_t cap)
{
	const struct mixer *mix = e->mix; /* set once by the app, kept across experiments */
	memset(e, 0, sizeof *e);
	e->mix = mix;
	if (!exp_available(id)) {
		snprintf(why, cap, "Experiment %d unknown (1..6)", id);
		return APP_DENIED;
	}
	cfg_resolve(&e->cfg, p);
	e->cfg.src = src;
	if (!imu_src(&e->cfg))
		e->cfg.src = EXP_SRC_THRUST;
	if (!(e->cfg.exc_amp > 0.0f) || !(e->cfg.exc_time > 0.0f)) {
		snprintf(why, cap, "Experiment %d refused: ID_EXC_AMP/ID_EXC_TIME not > 0", id);
		return APP_DENIED;
	}
	switch (id) {
	case 1: e->phase_kind[e->n_phases++] = PK_ROTOR; break;
	case 2: e->phase_kind[e->n_phases++] = PK_VAL; break;
	case 3:
	case 4:
	case 5: e->phase_kind[e->n_phases++] = PK_INR_X + (id - 3); break;
	case 6: {
		static const int seq[] = {PK_VAL_PRE, PK_ROTOR, PK_VAL_POST, PK_INR_X, PK_INR_Y, PK_INR_Z};
		for (int i = 0; i < 6; i++)
			e->phase_kind[e->n_phases++] = seq[i];
		break;
	}
	}
	e->id = id;
	e->phase = 0;
	e->n_est = EXP_MAX_EST;
	for (int i = 0; i < EXP_MAX_EST; i++)
		snprintf(e->est_name[i], sizeof e->est_name[i], "%s", est_names[i]);
	e->state = EXP_RUNNING;
	return APP_ACCEPTED;
}

void exp_abort(struct experiment *e, const char *reason)
{
	if (e->state == EXP_RUNNING) {
		e->state = EXP_ABORTED;
		e->n_results = 0;
		e->n_ids = 0;
		e->q_n = 0;
		e->est_live = 0;
		e->final_result = APP_FAILED;
		/* "ID aborted: <reason>" without a format: it may be the step that aborts, and the
		 * reason may be the caller's (a rotor named): copied, by the library's word copies */
		static const char head[] = "ID aborted: ";
		size_t h = sizeof head - 1u, n = strlen(reason);
		if (n > sizeof e->msg - 1u - h)
			n = sizeof e->msg - 1u - h;
		memcpy(e->msg, head, h);
		memcpy(e->msg + h, reason, n);
		e->msg[h + n] = 0;
		e->msg_severity = APP_SEV_WARNING;
	}
}

/* ---------------------------------------------------------------- phases */

/* what a phase's start needs of the step that started it (exp_input: the step's frame and
 * the throttle / thrust commands before the step's own) */
static void snapshot(struct exp_turn *t, const struct exp_input *in)
{
	t->thr_prev0 = in->thr_prev[0];
	t->rotor_f_cmd0 = in->rotor_f_cmd[0];
	/* by assignment: the library's memcpy costs more for these few words */
	SC_HOT_UNROLL
	for (int j = 0; j < HAL_ROTORS; j++) {
		t->thr_prev_all[j] = in->thr_prev[j];
		t->thrust_n[j] = in->thrust_n[j];
		/* from the frame: exp_input has them only for some phases */
		t->torque_nm[j] = sc_from_float(in->frame->rotor_torque_nm[j]);
		t->speed_rps[j] = in->frame->rotor_speed_rps[j];
	}
	SC_HOT_UNROLL
	for (int i = 0; i < 3; i++)
		t->rate_b_rps[i] = in->rate_b_rps[i];
}

static float phase_limit(const struct experiment *e, const char **name);

/* The motor model of every rotor (motor_id.h) for an excitation of run_s: ID_MOT_TAU centres
 * the first lag grid, VEH_KF and MOT_CURVE are the reference model */
static void motor_model_begin(struct experiment *e, const struct app_params *p, const struct exp_turn *in, float run_s)
{
	const struct exp_cfg *cf = &e->cfg;
	struct motor_id_cfg mc = {
		.dt_s = sc_from_float(e->dt_nom),
		.tau0_s = cf->mot_tau,
		.kf0 = p->veh_kf,
		.curve0 = p->mot_curve,
		.est_curve = cf->crv_est,
		.n_frames = (uint32_t)(run_s / e->dt_nom + 0.5f),
	};
	_Static_assert(MOTOR_ID_ROTORS == HAL_ROTORS, "the motor model covers every rotor");
	motor_id_init(&e->mid, &mc, in->thr_prev_all);
}

/* With the rotor speeds (ESC telemetry) the motor model is seen rotor by rotor: thrust goes
 * with speed^2 (rpm^2 = rpm_max^2 g(y), the effectiveness aside), so motor_id (motor_id.h)
 * reads w2_gain w_j^2 as rotor j's "thrust": its delay, lag and curve are the motor's; its
 * k_f and scales are the speed's, not the propellers', and are not used. The gain makes the
 * start's speeds match the prior model's thrusts (k_f g(y)), so the sums stay well scaled. */
static void speed_model_begin(struct experiment *e, const struct app_params *p, const struct exp_turn *in)
{
	const struct exp_cfg *cf = &e->cfg;
	float gsum = 0.0f, wsum = 0.0f, c = p->mot_curve;
	for (int j = 0; j < HAL_ROTORS; j++) {
		float y = sc_to_float(in->thr_prev_all[j]), w = in->speed_rps[j];
		gsum += (1.0f - c) * y + c * y * y;
		wsum += w * w;
	}
	e->w2_gain = wsum > 0.0f && isfinite(wsum) ? p->veh_kf * gsum / wsum : 0.0f;
	motor_model_begin(e, p, in, cf->imu_time);
}

/* a frame of the speed model: the speeds as thrusts (no torques: not read) */
static void speed_model_step(struct experiment *e, const struct exp_input *in, int n, bool use)
{
	scalar_t f[HAL_ROTORS], tq[HAL_ROTORS];
	for (int j = 0; j < HAL_ROTORS; j++) {
		float w = in->frame->rotor_speed_rps[j];
		f[j] = sc_from_float(isfinite(w) ? e->w2_gain * w * w : 0.0f);
		tq[j] = SC_ZERO;
	}
	for (int i = 1; i < n; i++)
		motor_id_hold(&e->mid, in->thr_prev);
	if (n >= 1)
		motor_id_step(&e->mid, in->thr_prev, f, tq, use);
}

/* the rotor experiment's dither: ID_EXC_KIND at ID_EXC_AMP (multisine: 8 harmonics of 0.5 Hz,
 * 0.5 .. 4 Hz at 90 Hz) */
static void rotor_dither_params(const struct experiment *e, struct excite_params *xp)
{
	uint32_t kind = e->cfg.exc_kind;
	xp->kind = kind == 0u ? EXCITE_UNIFORM : (kind == 1u ? EXCITE_PRBS : EXCITE_MULTISINE);
	xp->amplitude = sc_from_float(e->cfg.exc_amp);
	xp->ms_period_frames = (uint32_t)(2.0f / e->dt_nom + 0.5f);
}

/* the dithers' cap, said when it holds them below their amplitude */
static void cap_say(struct experiment *e, float thr_h)
{
	if (e->exc_cap < SC(1))
		say(e, APP_SEV_INFO, "ID excitation x%.3f: hover throttle %.3f", (double)sc_to_float(e->exc_cap),
		    (double)thr_h);
}

/* With the rotor speeds, each rotor's effectiveness from the accelerometer and the gyro
 * (imu_scale.h). The geometry is the mixer's Gamma, each column divided by its rotor's scale
 * (per newton of thrust): only each row's shape enters. Without a mixer only the force is
 * read, which cannot separate the rotors (the solve says so). */
static void scales_begin(struct experiment *e)
{
	struct imu_scale_cfg sc = {
		.dt_s = e->dt_nom,
		.block_frames = (uint32_t)(SWP_PERIOD_S / e->dt_nom + 0.5f),
		.sd_max = e->cfg.rsd_max,
	};
	_Static_assert(IMU_SCALE_ROTORS == HAL_ROTORS && MIXER_N_ROTORS == HAL_ROTORS, "every rotor's scale");
	const struct mixer *mx = e->mix;
	for (int i = 0; mx && i < 3; i++)
		for (int j = 0; j < HAL_ROTORS; j++) {
			float rd = sc_to_float(mx->row_div[i + 1]), s = sc_to_float(mx->p.scale[j]);
			float v = rd > 0.0f && s > 0.0f ? sc_to_float(mx->gn[i + 1][j]) / (rd * s) : 0.0f;
			sc.geo[i][j] = isfinite(v) ? v : 0.0f;
		}
	for (int j = 0; j < HAL_ROTORS; j++)
		e->yaw_sign[j] = (int8_t)(sc.geo[2][j] > 0.0f ? 1 : (sc.geo[2][j] < 0.0f ? -1 : 0));
	imu_scale_init(&e->isc, &sc);
}

/* Shortly before the collective model refines its grid (IMU_ID_FREEZE of the planned frames,
 * where its sums restart): the scales so far, if they separate every rotor and lie in range,
 * become its regressors' (imu_id_set_scales), so the rest of the run fits the force with them
 * rather than with MOT_SCALE. Once, between frames. */
#define SCALES_EARLY_MARGIN 10u /* frames before the refinement */
static void scales_early(struct experiment *e)
{
	float due = IMU_ID_FREEZE * (float)e->imid.cfg.n_frames;
	if (e->isc_early || (float)(e->rot_k + SCALES_EARLY_MARGIN) < due)
		return;
	e->isc_early = true;
	struct imu_scale_result sr;
	imu_scale_solve(&e->isc, &sr);
	imu_scale_per_throttle(&e->isc, e->cfg.curve, 0.0f, NULL, NULL, &sr);
	bool in = sr.cause == IMU_SCALE_OK;
	for (int j = 0; j < HAL_ROTORS; j++)
		in = in && sr.scale[j] >= SCALE_LO && sr.scale[j] <= SCALE_HI;
	if (in)
		imu_id_set_scales(&e->imid, sr.scale);
}

/* The IMU rotor experiment's start: the accelerometer sees the rotors' sum, so the null-space
 * dithers (the vehicle still) get a collective dither (a fast vertical jiggle) and the
 * throttle sweep beside them (docs/identification.md, "From the IMU"). */
static void imu_rotor_begin(struct experiment *e, const struct app_params *p, const struct exp_turn *in,
			    struct excite_params *xpp)
{
	const struct exp_cfg *cf = &e->cfg;
	struct excite_params xp = *xpp;
	e->t_run = cf->imu_time;
	e->swp_end = e->t_settle + e->t_run;
	rotor_dither_params(e, &xp);
	struct imu_id_cfg ic = {
		.dt_s = e->dt_nom,
		.mass_kg = p->veh_mass,
		.g = p->veh_grav,
		.kf0 = p->veh_kf,
		.curve0 = p->mot_curve,
		.est_curve = cf->crv_est,
		.n_frames = (uint32_t)(cf->imu_time / e->dt_nom + 0.5f),
		.block_frames = (uint32_t)(SWP_PERIOD_S / e->dt_nom + 0.5f),
		.torque = cf->src == EXP_SRC_IMU_RPM_TQ,
		.kt0 = p->veh_ktau,
	};
	float thr_h = 0.0f;
	for (int j = 0; j < HAL_ROTORS; j++) {
		ic.scale[j] = mot_scale(p, j);
		thr_h += sc_to_float(in->thr_prev_all[j]) / (float)HAL_ROTORS;
	}
	excite_null_pattern(0, e->pat[0]);
	excite_null_pattern(1, e->pat[1]);
	for (int j = 0; j < HAL_ROTORS; j++) {
		ic.pat[0][j] = sc_to_float(e->pat[0][j]);
		ic.pat[1][j] = sc_to_float(e->pat[1][j]);
	}
	imu_id_init(&e->imid, &ic, in->thr_prev_all);
	struct excite_params xp2 = xp, xp3 = xp;
	xp2.seed = xp.seed * 2654435761u + 12345u;
	excite_init(&e->exc2, &xp2);
	xp3.seed = xp.seed * 2246822519u + 777u;
	xp3.kind = EXCITE_PRBS;
	xp3.amplitude = sc_from_float(cf->col_amp);
	excite_init(&e->exc3, &xp3);
	struct excite_params xp4 = xp3;
	xp4.seed = xp.seed * 3266489917u + 4099u;
	excite_init(&e->exc4, &xp4);
	e->rot_k = 0;
	e->swp_k = 0;
	e->ofs = sc_from_float(cf->exc_ofs);
	e->exc_cap = hover_cap(thr_h, fmaxf(cf->exc_amp + cf->exc_ofs, cf->col_amp));
	cap_say(e, thr_h);
	sweep_plan(e, p, thr_h, cf->swp_dz, cf->src == EXP_SRC_IMU_RPM_TQ ? SWP_SHARE_ROWS : SWP_SHARE_IMU);
	if (rpm_src(cf)) {
		speed_model_begin(e, p, in);
		scales_begin(e);
	}
	for (int j = 0; j < HAL_ROTORS; j++)
		e->thr_h[j] = sc_to_float(in->thr_prev_all[j]);
	e->isc_early = false; /* the union's memory held an earlier phase's estimator */
	e->est_live = 0;
	*xpp = xp;
}

/* The rotor experiment's start with the thrust rows: rotor 1's model given (the paper's and the
 * lag-aware estimators) and the motor model of every rotor, on the null-space dithers and the
 * throttle sweep. */
static void thrust_rotor_begin(struct experiment *e, const struct app_params *p, const struct exp_turn *in,
			       struct excite_params *xpp)
{
	const struct exp_cfg *cf = &e->cfg;
	struct excite_params xp = *xpp;
	scalar_t dt = sc_from_float(e->dt_nom);
	e->t_run = cf->exc_time + (cf->exc_null && cf->swp_thr > 0.0f ? SWP_TAIL_S : 0.0f);
	e->swp_end = e->t_settle + cf->exc_time;
	rotor_dither_params(e, &xp);
	struct ident_rotor_cfg c = {
		.dt_s = dt,
		.mot_tau_s = sc_from_float(cf->mot_tau),
		.delay_frames = cf->delay_fr,
		.curve = sc_from_float(p->mot_curve),
		.thr0 = in->thr_prev0,
		.kf0 = p->veh_kf,
		.ktau0 = p->veh_ktau,
		.p0 = 1e6f,
	};
	ident_rotor_init(&e->rot, &c);
	/* the motor model of every rotor: delay, lag, curve, k_f, k_tau, scales (priors:
	 * ID_MOT_TAU centres the first lag grid, VEH_KF and MOT_CURVE the reference model) */
	motor_model_begin(e, p, in, cf->exc_time);
	struct excite_params xp2 = xp;
	xp2.seed = xp.seed * 2654435761u + 12345u;
	excite_init(&e->exc2, &xp2);
	e->rot_k = 0;
	e->swp_k = 0;
	excite_null_pattern(0, e->pat[0]);
	excite_null_pattern(1, e->pat[1]);
	e->ofs = sc_from_float(cf->exc_ofs);
	float thr_h = 0.0f;
	for (int j = 0; j < HAL_ROTORS; j++)
		thr_h += sc_to_float(in->thr_prev_all[j]) / (float)HAL_ROTORS;
	if (cf->exc_null) /* rotor 1's excitation alone (the paper's) keeps its amplitude */
		e->exc_cap = hover_cap(thr_h, cf->exc_amp + cf->exc_ofs);
	cap_say(e, thr_h);
	sweep_plan(e, p, thr_h, SWP_DZ_ROWS * cf->swp_dz, SWP_SHARE_THRUST);
	rows_plan(e, p, thr_h, SWP_DZ_ROWS * cf->swp_dz);
	e->swp_curve = p->mot_curve;
	e->swp_thr_max = isfinite(p->mot_thr_max) ? p->mot_thr_max : 1.0f;
	for (int j = 0; j < HAL_ROTORS; j++)
		e->thr_sum[j] = SC_ZERO;
	e->thr_n = 0u;
	e->swp_rotors = false; /* the union's memory held an earlier phase's estimator */
	e->swp_lost = e->swp_cut = false;
	e->swp_lost_k = e->swp_pat = e->swp_pat_n = e->swp_n_pat = e->swp_n_cut = 0u;
	/* a step and the motor's settling after it (the lags of the test's range, up to a
	 * slow prior's, and the longest delay) stay out of the whiteness test */
	float settle = fmaxf(SWP_WHITE_TAUS * cf->mot_tau, SWP_WHITE_MIN_S);
	e->swp_white = (uint16_t)((float)MOTOR_ID_DELAYS + settle * e->inv_dt_nom + 0.5f);
	e->swp_white_dn = (uint16_t)((float)MOTOR_ID_DELAYS + SWP_WHITE_TAUS * cf->mot_tau * e->inv_dt_nom + 0.5f);
	e->est_live = 0x0Fu;
	*xpp = xp;
}

/* the body torque (N m) of the rotors' thrusts f and reaction torques tq: by the mixer's
 * geometry, or a plain octocopter of arm arm_l */
static void body_torque(const struct experiment *e, const scalar_t *f, const scalar_t *tq, float arm_l, scalar_t tau[3])
{
	if (e->mix)
		ident_body_torque_mixer(e->mix, f, tq, tau);
	else
		ident_body_torque(sc_from_float(arm_l), f, tq, tau);
}

/* An inertia phase's body torque (N m) of this frame: from the rotors' measured thrusts fm
 * and torques tm, or under the IMU from the rotor model (rmodel, n frames of the throttles
 * thr), whose torque's derivative in ln tau (the lag's uncertainty) goes to the estimator;
 * arm_l: the arm's length where no mixer gives the geometry. */
static void inertia_torque(struct experiment *e, const scalar_t *fm, const scalar_t *tm, float arm_l,
			   const scalar_t thr[HAL_ROTORS], int n, scalar_t tau[3])
{
	if (imu_src(&e->cfg)) {
		scalar_t df[HAL_ROTORS], dtq[HAL_ROTORS], dtau[3];
		rmodel_step(&e->rm, thr, n, e->f_model, e->tq_model, df);
		for (int j = 0; j < HAL_ROTORS; j++)
			dtq[j] = sc_mul(e->rm.kt, df[j]);
		body_torque(e, df, dtq, arm_l, dtau);
		ident_inertia_sensitivity(&e->inr, dtau[(e->phase_kind[e->phase] - PK_INR_X) % 3]);
		fm = e->f_model;
		tm = e->tq_model;
	}
	body_torque(e, fm, tm, arm_l, tau);
}

static void phase_begin(struct experiment *e, const struct app_params *p, const struct exp_turn *in)
{
	const struct exp_cfg *cf = &e->cfg;
	int k = e->phase_kind[e->phase];
	e->t_phase = 0.0f;
	e->t_settle = SETTLE_S;
	e->exc_gain = SC(1);
	e->exc_cap = SC(1);
	e->exc_cut_t = -1.0f;
	e->exc_over_t = -1.0f;
	e->exc_top = SC(1);
	e->exc_up = false;
	e->ext_done = false;
	e->est_live = 0;
	e->est_wait = 0u;
	say(e, APP_SEV_INFO, "ID %d/%d: %s", e->phase + 1, e->n_phases, phase_name(k));

	struct excite_params xp = excite_params_default();
	xp.seed = cf->seed * 8u + (uint32_t)e->phase;
	xp.clock_div = cf->exc_div;
	xp.prbs_order = PRBS_ORDER;
	scalar_t dt = sc_from_float(e->dt_nom);

	if (k == PK_ROTOR && imu_src(cf)) {
		imu_rotor_begin(e, p, in, &xp);
	} else if (k == PK_ROTOR) {
		thrust_rotor_begin(e, p, in, &xp);
	} else if (k == PK_INR_X || k == PK_INR_Y || k == PK_INR_Z) {
		unsigned ax = (unsigned)(k - PK_INR_X);
		e->t_run = cf->inr_time;
		float amp = cf->inr_amp;
		xp.kind = ax == 2u ? EXCITE_PRBS : EXCITE_MULTISINE;
		xp.ms_period_frames = (uint32_t)(2.0f / e->dt_nom + 0.5f);
		xp.ms_k_first = INR_MS_K_FIRST;
		xp.ms_count = INR_MS_COUNT;
		xp.amplitude = sc_from_float(ax == 2u ? amp / INR_YAW_DIV : amp);
		scalar_t tau[3],
			inertia[3] = {sc_from_float(p->veh_ixx), sc_from_float(p->veh_iyy), sc_from_float(p->veh_izz)};
		if (imu_src(cf)) /* the torque the identified rotor model gives */
			rmodel_init(&e->rm, p, cf, dt, in->thr_prev_all);
		inertia_torque(e, in->thrust_n, in->torque_nm, p->veh_arm_l, in->thr_prev_all, 1, tau);
		scalar_t alpha = ident_torque_weight(sc_from_float(cf->mot_tau), dt);
		ident_inertia_init(&e->inr, ax, ax == 2u ? SC(INR_WC_YAW_RPS) : SC(INR_WC_RP_RPS), SC(INR_ZETA), dt,
				   alpha, inertia, in->rate_b_rps, tau);
		e->inr_u_prev = SC_ZERO;
		/* the instrument: the excitation through the motor model the phase flies with
		 * (ID_DELAY_FR, ID_MOT_TAU), in phase with the torque it makes */
		filt_delay_init(&e->inr_delay, cf->delay_fr, SC_ZERO);
		filt_lag_init(&e->inr_lag, sc_from_float(cf->mot_tau), dt, SC_ZERO);
		float i_ax = ax == 0u ? p->veh_ixx : ax == 1u ? p->veh_iyy : p->veh_izz;
		e->inr_gate_k = sc_from_float(i_ax > 0.0f ? INR_GATE_MARGIN * sc_to_float(dt) / i_ax : 0.0f);
		e->inr_skip = 0;
		e->est_live = 1u << (4u + ax);
	} else {
		e->t_run = cf->val_time;
		/* mu_1: the paper's uniform random signal, on the yaw torque demand (yaw moves
		 * single rotor thrusts most for the least attitude change) */
		xp.kind = EXCITE_UNIFORM;
		xp.amplitude = sc_from_float(cf->inr_amp / INR_YAW_DIV);
		if (imu_src(cf)) { /* on the thrust demand: the accelerometer sees the sum */
			xp.amplitude = sc_from_float(VAL_IMU_F * p->veh_mass * p->veh_grav);
			rmodel_init(&e->rm, p, cf, dt, in->thr_prev_all);
		}
		filt_delay_init(&e->val_delay, cf->delay_fr, in->rotor_f_cmd0);
		filt_lag_init(&e->val_lag, sc_from_float(cf->mot_tau), dt, in->rotor_f_cmd0);
		ident_fit_init(&e->fit);
		e->est_live = 1u << 7;
	}
	excite_init(&e->exc, &xp);
	/* the progress over the phase's time: products per step, no division */
	float total = e->t_settle + e->t_run;
	const char *lim_name;
	e->t_total = total;
	e->t_limit = phase_limit(e, &lim_name);
	e->fr_dt = -1.0f; /* no step yet */
	e->prog_base = (float)(e->phase + (total > 0.0f ? 0 : 1)) / (float)e->n_phases;
	e->prog_rate = total > 0.0f ? 1.0f / (total * (float)e->n_phases) : 0.0f;
}

/* The motor model's results (the lag found and its sd, the curve's sd, NE) and, accepted, the
 * model itself (ID_MOT_TAU, ID_DELAY_FR, MOT_CURVE when estimated), which the later phases
 * (validation, inertia) also fly with. */
static void motor_results(struct experiment *e, float tau, float tau_sd, uint32_t delay, float curve, float curve_sd,
			  float ne, bool ok)
{
	result_fin(e, PX_ID_TAU_CHECK, tau, -1.0f);
	result_fin(e, PX_ID_TAU_SD, tau_sd, 0.0f);
	result_fin(e, PX_ID_CRV_SD, curve_sd, 0.0f);
	result_fin(e, PX_ID_MOT_NE, ne, 0.0f);
	if (!ok)
		return;
	result(e, PX_ID_MOT_TAU, tau);
	result(e, PX_ID_DELAY_FR, (float)delay);
	if (e->cfg.crv_est)
		result(e, PX_MOT_CURVE, curve);
	e->cfg.mot_tau = tau;
	e->cfg.delay_fr = delay;
}

/* The rotor experiment's end with the null-space dither: the motor model of every rotor
 * (motor_id.h), its acceptance, results and status lines. Nothing is applied unless the model
 * explains the data (its cause) and every value is in range; ID_MOT_TAU, ID_DELAY_FR,
 * MOT_CURVE (when estimated) and MOT_SCALE1..8 are then results like VEH_KF and VEH_KTAU. */
static void rotor_end(struct experiment *e, const struct app_params *p)
{
	struct motor_id_result mr;
	motor_id_process(&e->mid);
	motor_id_solve(&e->mid, MOT_NE_MAX, &mr);
	float rsd = e->cfg.rsd_max;
	float kfp = ident_rotor_plain(&e->rot, 0), ktp = ident_rotor_plain(&e->rot, 1);
	enum ident_verdict vf = ident_accept(mr.kf, mr.kf_sd, p->veh_kf, rsd);
	enum ident_verdict vt = ident_accept(mr.ktau, mr.ktau_sd, p->veh_ktau, rsd);
	bool model_ok = mr.cause == MOTOR_ID_OK;
	int bad_rotor = -1;
	bool curve_bad = !(mr.curve >= THRMAP_CURVE_MIN && mr.curve <= THRMAP_CURVE_MAX);
	for (int j = 0; j < HAL_ROTORS; j++)
		if (!(mr.scale[j] >= SCALE_LO && mr.scale[j] <= SCALE_HI) && bad_rotor < 0)
			bad_rotor = j;
	bool range_ok = !curve_bad && bad_rotor < 0;
	bool ok = vf == IDENT_ACCEPT && vt == IDENT_ACCEPT && model_ok && range_ok;
	result_fin(e, PX_ID_KF_EST, mr.kf, 0.0f);
	result_fin(e, PX_ID_KF_SD, mr.kf_sd, 0.0f);
	result_fin(e, PX_ID_KF_PLAIN, kfp, 0.0f);
	result_fin(e, PX_ID_KTAU_EST, mr.ktau, 0.0f);
	result_fin(e, PX_ID_KTAU_SD, mr.ktau_sd, 0.0f);
	result_fin(e, PX_ID_KTAU_PLAIN, ktp, 0.0f);
	motor_results(e, mr.tau, mr.tau_sd, mr.delay, mr.curve, mr.curve_sd, mr.ne_all, ok);
	if (ok) {
		result(e, PX_VEH_KF, mr.kf);
		result(e, PX_VEH_KTAU, mr.ktau);
		for (int j = 0; j < HAL_ROTORS; j++)
			result(e, PX_MOT_SCALE1 + j, mr.scale[j]);
	}
	set_result_bit(e, p, 1u, ok);
	rotor_ids(e, &mr, ok, vf, vt, curve_bad, bad_rotor, kfp, ktp);
	const char *why = !model_ok ? "motor model" : !range_ok ? "out of range" : "";
	const char *why_f = ok                   ? "accepted"
			    : vf != IDENT_ACCEPT ? ident_verdict_text(vf)
			    : why[0]             ? why
						 : "ktau rejected";
	const char *why_t = ok                   ? "accepted"
			    : vt != IDENT_ACCEPT ? ident_verdict_text(vt)
			    : why[0]             ? why
						 : "kf rejected";
	int sev = ok ? APP_SEV_INFO : APP_SEV_WARNING;
	if (e->swp_n_cut > 0u) /* the lossy link's rule (rows_plan) */
		say(e, APP_SEV_INFO, "ID sweep: %d/%d rises cut to %.1f g, frames lost", (int)e->swp_n_cut,
		    (int)e->swp_n_pat, (double)(e->swp_ratio[EXP_SWP_LEVELS] - 1.0f));
	say(e, sev, "ID kf %.3f +/- %.3f %s%s", (double)mr.kf, (double)mr.kf_sd, ok ? "N " : "rejected: ", why_f);
	say(e, sev, "ID ktau %.4f +/- %.4f %s%s", (double)mr.ktau, (double)mr.ktau_sd,
	    ok ? "N m " : "rejected: ", why_t);
	say(e, APP_SEV_INFO, "ID plain (eq. 20) kf %.3f N ktau %.4f N m", (double)kfp, (double)ktp);
	say(e, sev, "ID motor lag %.4f +/- %.4f s delay %d fr", (double)mr.tau, (double)mr.tau_sd, (int)mr.delay);
	if (e->cfg.crv_est)
		say(e, sev, "ID curve %.3f +/- %.3f", (double)mr.curve, (double)mr.curve_sd);
	else
		say(e, APP_SEV_INFO, "ID curve %.3f given (ID_CRV_EST 0)", (double)mr.curve);
	say(e, sev, "ID scale 1-4 %.4f %.4f %.4f %.4f", (double)mr.scale[0], (double)mr.scale[1], (double)mr.scale[2],
	    (double)mr.scale[3]);
	say(e, sev, "ID scale 5-8 %.4f %.4f %.4f %.4f", (double)mr.scale[4], (double)mr.scale[5], (double)mr.scale[6],
	    (double)mr.scale[7]);
	say(e, APP_SEV_INFO, "ID motor model NE %.3f noise %.4f N", (double)mr.ne_all, (double)mr.noise_sd);
	if (mr.white_have) /* the one-step prediction errors' whiteness (motor_id.h) */
		say(e, mr.white_ok ? APP_SEV_INFO : APP_SEV_WARNING, "ID whiteness %.0f limit %.0f: %s",
		    (double)mr.white_q, (double)mr.white_lim, mr.white_ok ? "white" : "coloured");
	if (!model_ok) {
		if (mr.cause == MOTOR_ID_ROTOR)
			say(e, APP_SEV_WARNING, "ID rejected: rotor %d unexplained, NE %.2f", mr.cause_rotor + 1,
			    (double)mr.ne[mr.cause_rotor]);
		else
			say(e, APP_SEV_WARNING, "ID rejected: %s", motor_id_cause_text(mr.cause));
		if (mr.cause == MOTOR_ID_LAG_REACH) /* the prior, not the data: start from what they say */
			say(e, APP_SEV_WARNING, "ID remedy: ID_MOT_TAU %.4f (the lag found), fly again",
			    (double)mr.tau);
		else
			say(e, APP_SEV_WARNING, "ID remedy: %s", motor_id_cause_remedy(mr.cause));
	} else if (curve_bad) {
		say(e, APP_SEV_WARNING, "ID rejected: curve %.3f outside %.2f to %.2f", (double)mr.curve,
		    (double)THRMAP_CURVE_MIN, (double)THRMAP_CURVE_MAX);
	} else if (bad_rotor >= 0) {
		say(e, APP_SEV_WARNING, "ID rejected: rotor %d scale %.3f outside 0.3-1.5", bad_rotor + 1,
		    (double)mr.scale[bad_rotor]);
	}
	/* a weak rotor is reported whenever the model holds (applied or not: the data show it) */
	float smin = cfg_f(p->mot_scale_min, 0.8f);
	if (model_ok)
		for (int j = 0; j < HAL_ROTORS; j++)
			if (mr.scale[j] < smin)
				say(e, APP_SEV_WARNING, "ID rotor %d degraded: effectiveness %.3f", j + 1,
				    (double)mr.scale[j]);
}

static enum app_id_reason imu_reason(enum imu_id_cause c)
{
	switch (c) {
	case IMU_ID_OK: return APP_ID_OK;
	case IMU_ID_NO_DATA: return APP_ID_NO_DATA;
	case IMU_ID_NOISE_UNKNOWN: return APP_ID_NOISE_UNKNOWN;
	case IMU_ID_LAG_RANGE: return APP_ID_LAG_RANGE;
	case IMU_ID_DELAY_RANGE: return APP_ID_DELAY_RANGE;
	case IMU_ID_DELAY_AMBIGUOUS: return APP_ID_DELAY_AMBIGUOUS;
	case IMU_ID_MODEL: return APP_ID_MODEL;
	case IMU_ID_CURVE_WEAK: return APP_ID_UNCERTAIN;
	case IMU_ID_SCALES: return APP_ID_ROTOR;
	}
	return APP_ID_MODEL;
}

/* k_tau under the IMU source: from the ESCs' torques (imu_rpm_torque) on the collective
 * model's hypothesis, accepted only with the force's model (ok: k_f accepted); else not
 * identifiable (the ratio k_tau / I_z comes from the yaw phase). Accepted, the later phases
 * model the yaw torque with it, and I_z is estimated as the roll and pitch inertias are. */
static void imu_ktau_end(struct experiment *e, const struct app_params *p, const struct imu_id_result *r, bool ok)
{
	if (e->cfg.src != EXP_SRC_IMU_RPM_TQ) {
		id_out(e, APP_ID_KTAU, 0, NAN, NAN, false, APP_ID_NOT_IDENTIFIABLE);
		return;
	}
	if (r->tq_moved) {
		id_out(e, APP_ID_KTAU, 0, NAN, NAN, false, APP_ID_DELAY_AMBIGUOUS);
		/* the torque's sums were kept for the delay frozen at the refinement alone */
		say(e, APP_SEV_WARNING, "ID ktau rejected: delay moved %d -> %d fr", (int)r->cl_delay, (int)r->delay);
		return;
	}
	if (!r->tq_ok) {
		id_out(e, APP_ID_KTAU, 0, NAN, NAN, false, APP_ID_NOT_FINITE);
		say(e, APP_SEV_WARNING, "ID ktau rejected: ESC torque readings lost");
		return;
	}
	enum ident_verdict v = ident_accept(r->ktau, r->ktau_sd, p->veh_ktau, e->cfg.rsd_max);
	bool kt_ok = ok && v == IDENT_ACCEPT;
	result_fin(e, PX_ID_KTAU_EST, r->ktau, 0.0f);
	result_fin(e, PX_ID_KTAU_SD, r->ktau_sd, 0.0f);
	if (kt_ok) {
		result(e, PX_VEH_KTAU, r->ktau);
		/* the yaw phase's modelled torque k_tau g(y) takes the force's curve: its k_tau is
		 * the one whose slope at hover is the torques' (what they measured best) */
		float gp = 1.0f - e->cfg.curve + 2.0f * e->cfg.curve * r->thr_hover;
		e->cfg.ktau = gp > 0.0f ? r->tq_slope / gp : r->ktau;
		e->cfg.kt_rsd = r->tq_slope_rsd;
		e->cfg.kt_id = true;
	}
	id_out(e, APP_ID_KTAU, 0, r->ktau, r->ktau_sd, kt_ok,
	       v != IDENT_ACCEPT ? app_id_reason_of_verdict(v) : APP_ID_PARTNER_REJECTED);
	say(e, kt_ok ? APP_SEV_INFO : APP_SEV_WARNING, "ID ktau %.4f +/- %.4f %s%s", (double)r->ktau,
	    (double)r->ktau_sd, kt_ok ? "N m (ESC torque) " : "rejected: ",
	    kt_ok               ? "accepted"
	    : v != IDENT_ACCEPT ? ident_verdict_text(v)
				: "kf rejected");
	say(e, APP_SEV_INFO, "ID ESC torque residual %.5f N m, sd x %.2f (clusters)", (double)r->tq_noise,
	    (double)sqrtf(r->tq_hac));
}

/* The speeds' scales at the IMU rotor phase's end (imu_scale.h) into *sr (mr: the speeds'
 * motor model when it holds, for the scales per throttle); *bad: the first rotor out of
 * SCALE_LO..SCALE_HI. Separated and in range they take the place of the scales the collective
 * model's regressors carried (s0: MOT_SCALE, or the early scales after its refinement,
 * scales_early); the sweep and the collective dither move every rotor alike, so its k_f (and
 * k_tau) is the true one times sum s0_j g_j / sum s_j g_j (g_j at the phase's starting
 * throttles). The scales' share joins k_f's sd, and the scales' check (IMU_ID_SCALES) is
 * answered. The scales' share of each inertia phase's modelled torque goes to cfg.sc_rsd.
 * Returns whether they are used. */
static bool scales_end(struct experiment *e, const struct motor_id_result *mr, struct imu_id_result *r,
		       struct imu_scale_result *sr, int *bad)
{
	imu_scale_process(&e->isc);
	imu_scale_solve(&e->isc, sr);
	/* per throttle: the speed model's shares (its delay and lag) when it holds, else the
	 * run's w^2 over g(y) */
	imu_scale_per_throttle(&e->isc, r->curve, r->curve_sd, mr ? mr->scale : NULL, mr ? mr->scale_sd : NULL, sr);
	*bad = -1;
	for (int j = 0; j < HAL_ROTORS; j++)
		if (!(sr->scale[j] >= SCALE_LO && sr->scale[j] <= SCALE_HI) && *bad < 0)
			*bad = j;
	if (sr->cause != IMU_SCALE_OK || *bad >= 0)
		return false;
	float gw[HAL_ROTORS], s0g = 0.0f, sg = 0.0f, c = r->curve;
	for (int j = 0; j < HAL_ROTORS; j++) {
		float y = e->thr_h[j];
		gw[j] = (1.0f - c) * y + c * y * y;
		s0g += e->imid.cfg.scale[j] * gw[j]; /* what the collective model's regressors carried */
		sg += sr->scale[j] * gw[j];
	}
	float k = sg > 0.0f ? s0g / sg : NAN;
	if (!(k > 0.0f) || !isfinite(k))
		return false;
	float rs = imu_scale_ratio_rsd(sr, gw, NULL);
	float rel = r->kf > 0.0f ? r->kf_sd / r->kf : INFINITY;
	r->kf *= k;
	r->kf_sd = r->kf * sqrtf(rel * rel + rs * rs);
	r->slope *= k; /* its rsd stays k_f's own: the inertia phases add the scales' share */
	if (r->tq_ok) {
		float relt = r->ktau > 0.0f ? r->ktau_sd / r->ktau : INFINITY;
		r->ktau *= k;
		r->ktau_sd = r->ktau * sqrtf(relt * relt + rs * rs);
		r->tq_slope *= k;
	}
	if (r->cause == IMU_ID_SCALES)
		r->cause = IMU_ID_OK;
	/* an inertia phase models torque k_f s_j g(y_j) with k_f ~ 1 / sum s g; its excitation
	 * moves rotor j's throttle along its arm, so the torque's gain goes with sum a_j^2 s_j
	 * over sum g_j s_j (roll, pitch); the yaw torque's with sum s_j (VEH_KTAU) or over
	 * sum g_j s_j (the ESCs' k_tau, corrected as k_f) */
	float a[HAL_ROTORS], one[HAL_ROTORS];
	for (int ax = 0; ax < 2; ax++) {
		for (int j = 0; j < HAL_ROTORS; j++)
			a[j] = e->isc.cfg.geo[ax][j] * e->isc.cfg.geo[ax][j];
		e->cfg.sc_rsd[ax] = imu_scale_ratio_rsd(sr, a, gw);
	}
	for (int j = 0; j < HAL_ROTORS; j++)
		one[j] = 1.0f;
	e->cfg.sc_rsd[2] = imu_scale_ratio_rsd(sr, one, NULL);
	e->cfg.sc_rsd[3] = imu_scale_ratio_rsd(sr, one, gw);
	return true;
}

/* The speeds' scales as results and status lines: each with its sd, applied (MOT_SCALEj)
 * when used and the rotor model accepted; a degraded rotor named whenever they are used; a
 * rotor the excitation did not separate named, nothing published for it. */
static void scales_report(struct experiment *e, const struct app_params *p, const struct imu_scale_result *sr,
			  bool used, int bad, bool ok, enum app_id_reason common)
{
	bool sep = sr->cause == IMU_SCALE_OK;
	for (int j = 0; j < HAL_ROTORS; j++) {
		enum app_id_reason why =
			!sep       ? (sr->cause == IMU_SCALE_NOT_SEPARATED ? APP_ID_UNCERTAIN : APP_ID_NO_DATA)
			: bad >= 0 ? (bad == j ? APP_ID_OUT_OF_RANGE : APP_ID_ROTOR)
				   : common;
		id_out(e, APP_ID_MOT_SCALE, j + 1, sr->scale[j], sr->scale_sd[j], used && ok, why);
		if (used && ok)
			result(e, PX_MOT_SCALE1 + j, sr->scale[j]);
	}
	int sev = used && ok ? APP_SEV_INFO : APP_SEV_WARNING;
	if (!sep) {
		if (sr->cause == IMU_SCALE_NOT_SEPARATED)
			say(e, APP_SEV_WARNING, "ID scales not separated: rotor %d sd %.4f", sr->worst + 1,
			    (double)sr->scale_sd[sr->worst]);
		else
			say(e, APP_SEV_WARNING, "ID scales: %s", imu_scale_cause_text(sr->cause));
		return;
	}
	say(e, sev, "ID scale 1-4 %.4f %.4f %.4f %.4f", (double)sr->scale[0], (double)sr->scale[1],
	    (double)sr->scale[2], (double)sr->scale[3]);
	say(e, sev, "ID scale 5-8 %.4f %.4f %.4f %.4f", (double)sr->scale[4], (double)sr->scale[5],
	    (double)sr->scale[6], (double)sr->scale[7]);
	say(e, APP_SEV_INFO, "ID scale sd 1-4 %.4f %.4f %.4f %.4f", (double)sr->scale_sd[0], (double)sr->scale_sd[1],
	    (double)sr->scale_sd[2], (double)sr->scale_sd[3]);
	say(e, APP_SEV_INFO, "ID scale sd 5-8 %.4f %.4f %.4f %.4f", (double)sr->scale_sd[4], (double)sr->scale_sd[5],
	    (double)sr->scale_sd[6], (double)sr->scale_sd[7]);
	if (bad >= 0) {
		say(e, APP_SEV_WARNING, "ID scales not used: rotor %d scale %.3f outside 0.3-1.5", bad + 1,
		    (double)sr->scale[bad]);
		return;
	}
	float smin = cfg_f(p->mot_scale_min, 0.8f);
	for (int j = 0; j < HAL_ROTORS; j++)
		if (sr->scale[j] < smin)
			say(e, APP_SEV_WARNING, "ID rotor %d degraded: effectiveness %.3f", j + 1,
			    (double)sr->scale[j]);
}

/* The IMU rotor experiment's end: the collective model (imu_id.h), its acceptance, results
 * and status lines. k_tau is not seen by the accelerometer: it is reported as such (k_tau /
 * I_z comes from the yaw inertia phase). With the rotor speeds each rotor's effectiveness is
 * identified (scales_end) and the collective model's k_f and k_tau rest on it. */
static void imu_rotor_end(struct experiment *e, const struct app_params *p)
{
	struct imu_id_result r;
	imu_id_process(&e->imid);
	imu_id_solve(&e->imid, IMU_HAC_MAX, &r);
	/* with the rotor speeds the motor's lag and delay are theirs (seen rotor by rotor); the
	 * IMU's own stay as a check (said); k_f and its curve are the IMU's (the speeds do not
	 * see the propellers' thrust) */
	struct motor_id_result mr;
	bool by_speed = rpm_src(&e->cfg);
	float tau_imu = r.tau;
	if (by_speed) {
		motor_id_process(&e->mid);
		motor_id_solve(&e->mid, MOT_NE_MAX, &mr);
		/* a speed model its own checks reject (the sweep's throttle levels lie outside
		 * what its whiteness test was made for) leaves the accelerometer's lag and delay,
		 * which passed theirs: said, never silently */
		by_speed = mr.cause == MOTOR_ID_OK;
		if (by_speed) {
			r.tau = mr.tau;
			r.tau_sd = mr.tau_sd;
			r.delay = mr.delay;
		}
	}
	struct imu_scale_result sr;
	int bad = -1;
	bool sc_used = rpm_src(&e->cfg) && scales_end(e, by_speed ? &mr : NULL, &r, &sr, &bad);
	enum ident_verdict vf = ident_accept(r.kf, r.kf_sd, p->veh_kf, e->cfg.rsd_max);
	bool model_ok = r.cause == IMU_ID_OK;
	bool curve_bad = e->cfg.crv_est && !(r.curve >= THRMAP_CURVE_MIN && r.curve <= THRMAP_CURVE_MAX);
	bool ok = vf == IDENT_ACCEPT && model_ok && !curve_bad;
	result_fin(e, PX_ID_KF_EST, r.kf, 0.0f);
	result_fin(e, PX_ID_KF_SD, r.kf_sd, 0.0f);
	motor_results(e, r.tau, r.tau_sd, r.delay, r.curve, r.curve_sd, r.ne, ok);
	if (ok) {
		result(e, PX_VEH_KF, r.kf);
		e->cfg.slope_rsd = r.slope_rsd;
		e->cfg.tau_rsd = r.tau > 0.0f && isfinite(r.tau_sd) ? r.tau_sd / r.tau : 0.0f;
		e->cfg.model_ok = true;
		e->cfg.kf = r.kf;
		if (e->cfg.crv_est)
			e->cfg.curve = r.curve;
		float gp = 1.0f - r.curve + 2.0f * r.curve * r.thr_hover;
		e->cfg.gp_rsd = gp > 0.0f ? fabsf(2.0f * r.thr_hover - 1.0f) * r.curve_sd / gp : INFINITY;
	}
	set_result_bit(e, p, 1u, ok);
	enum app_id_reason common = !model_ok   ? imu_reason(r.cause)
				    : curve_bad ? APP_ID_CURVE
						: APP_ID_PARTNER_REJECTED;
	id_out(e, APP_ID_KF, 0, r.kf, r.kf_sd, ok, vf != IDENT_ACCEPT ? app_id_reason_of_verdict(vf) : common);
	id_out(e, APP_ID_MOT_TAU, 0, r.tau, r.tau_sd, ok, common);
	id_out(e, APP_ID_DELAY_FR, 0, (float)r.delay, NAN, ok, common);
	if (e->cfg.crv_est)
		id_out(e, APP_ID_MOT_CURVE, 0, r.curve, r.curve_sd, ok, curve_bad ? APP_ID_CURVE : common);
	if (!sc_used)
		for (int i = 0; i < 4; i++)
			e->cfg.sc_rsd[i] = 0.0f;
	int sev = ok ? APP_SEV_INFO : APP_SEV_WARNING;
	say(e, APP_SEV_INFO,
	    e->cfg.src == EXP_SRC_IMU_RPM_TQ ? "ID source imu_rpm_torque: accelerometer, mass, throttles, rotor "
					       "speeds, ESC torques"
	    : e->cfg.src == EXP_SRC_IMU_RPM  ? "ID source imu_rpm: accelerometer, mass, throttles, rotor speeds"
					     : "ID source imu: accelerometer, mass, throttles");
	say(e, sev, "ID kf %.3f +/- %.3f %s%s", (double)r.kf, (double)r.kf_sd, ok ? "N " : "rejected: ",
	    ok                   ? "accepted"
	    : vf != IDENT_ACCEPT ? ident_verdict_text(vf)
	    : model_ok           ? "out of range"
				 : "motor model");
	imu_ktau_end(e, p, &r, ok);
	say(e, sev, "ID motor lag %.4f +/- %.4f s delay %d fr", (double)r.tau, (double)r.tau_sd, (int)r.delay);
	if (by_speed)
		say(e, APP_SEV_INFO, "ID lag from the speeds; the accelerometer's %.4f s", (double)tau_imu);
	else if (rpm_src(&e->cfg))
		say(e, APP_SEV_WARNING, "ID speeds' model rejected (%s): the accelerometer's lag",
		    motor_id_cause_text(mr.cause));
	if (e->cfg.crv_est)
		say(e, sev, "ID curve %.3f +/- %.3f", (double)r.curve, (double)r.curve_sd);
	say(e, APP_SEV_INFO, "ID collective NE %.3f noise %.4f N", (double)r.ne, (double)r.noise_sd);
	say(e, APP_SEV_INFO, "ID sd x %.2f (vibration), %.1f dof of %d clusters", (double)sqrtf(r.hac), (double)r.dof,
	    (int)r.blocks);
	say(e, APP_SEV_INFO, "ID accelerometer scale %.4f +/- %.4f (in flight)", (double)r.kappa, (double)r.kappa_sd);
	if (e->cfg.src != EXP_SRC_IMU_RPM_TQ)
		say(e, APP_SEV_INFO, "ID ktau: not seen by the IMU (the ratio: Izz phase)");
	if (rpm_src(&e->cfg))
		scales_report(e, p, &sr, sc_used, bad, ok, common);
	if (!model_ok) {
		say(e, APP_SEV_WARNING, "ID rejected: %s", imu_id_cause_text(r.cause));
		say(e, APP_SEV_WARNING, "ID remedy: %s", imu_id_cause_remedy(r.cause));
	} else if (curve_bad) {
		say(e, APP_SEV_WARNING, "ID rejected: curve %.3f outside %.2f to %.2f", (double)r.curve,
		    (double)THRMAP_CURVE_MIN, (double)THRMAP_CURVE_MAX);
	}
}

/* The inertia excitation's largest useful ID_INR_AMP on axis ax: the amplitude at which the
 * rotor thrusts it moves swing by half the hover thrust f_h = m g / 8 (beyond, rotors near
 * idle or saturation distort the torque). Roll/pitch: the multisine's peak torque tau moves
 * rotor j by tau y_j / sum y^2, at most tau / (4 l) on the octocopter's circle; yaw (peak
 * ID_INR_AMP / 10): tau / (8 k), k = k_tau / k_f. Bounded by the parameter's own maximum. */
static float inr_amp_limit(const struct app_params *p, unsigned ax)
{
	float fh = p->veh_mass * p->veh_grav / (float)HAL_ROTORS, lim;
	if (ax == 2u)
		lim = INR_YAW_DIV * 0.5f * fh * (float)HAL_ROTORS * (p->veh_kf > 0.0f ? p->veh_ktau / p->veh_kf : 0.0f);
	else
		lim = 0.5f * fh * 4.0f * p->veh_arm_l;
	int i = PX_ID_INR_AMP;
	float pmax = param_defs[i].max;
	return isfinite(lim) && lim > 0.0f && lim < pmax ? lim : pmax;
}

#define INR_ADVICE_MARGIN \
	2.0f /* the std's scaling with amplitude and time holds only roughly (rotors nearer idle or full): aim lower */

/* Asked accuracy (ID_RSD_MAX) not reached: the std falls as 1 / (amplitude sqrt(time)), so
 * the estimate needs raise x the amplitude or raise^2 x the time (with a margin). The
 * amplitude goes up to its limit (inr_amp_limit); what it cannot give, the time does, up to
 * ID_INR_TIME's maximum. Beyond that the advice is the longest experiment at the largest
 * amplitude, with the std expected there (no margin): below ID_RSD_MAX it may pass; above, the
 * asked accuracy is out of reach on this vehicle and the warning says so. Advice never names
 * a value the parameter would refuse. */
static void inertia_advice(struct experiment *e, const struct app_params *p, unsigned ax, const char *nm, float raise)
{
	float r = raise * INR_ADVICE_MARGIN, amp = e->cfg.inr_amp, t = e->cfg.inr_time;
	float lim = inr_amp_limit(p, ax), tmax = param_defs[PX_ID_INR_TIME].max;
	if (amp * r <= lim) {
		if (t * r * r <= tmax)
			say(e, APP_SEV_WARNING, "ID %s: ID_INR_AMP %.2f or ID_INR_TIME %.0f s", nm, (double)(amp * r),
			    (double)(t * r * r));
		else
			say(e, APP_SEV_WARNING, "ID %s: ID_INR_AMP %.2f and ID_INR_TIME %.0f s", nm, (double)(amp * r),
			    (double)t);
		return;
	}
	float a = lim > amp ? lim / amp : 1.0f, tr = r / a;
	if (t * tr * tr <= tmax) {
		say(e, APP_SEV_WARNING, "ID %s: ID_INR_AMP %.2f and ID_INR_TIME %.0f s", nm, (double)(amp * a),
		    (double)(t * tr * tr));
		return;
	}
	float rsd_at = raise * e->cfg.rsd_max / (a * sqrtf(tmax / t));
	if (rsd_at < e->cfg.rsd_max)
		say(e, APP_SEV_WARNING,
		    "ID %s: ID_INR_AMP %.2f and ID_INR_TIME %.0f s (the longest: rsd %.5f expected)", nm,
		    (double)(amp * a), (double)tmax, (double)rsd_at);
	else
		say(e, APP_SEV_WARNING,
		    "ID %s: ID_RSD_MAX %g out of reach: ID_INR_AMP %.2f and ID_INR_TIME %.0f s give rsd %.5f", nm,
		    (double)e->cfg.rsd_max, (double)(amp * a), (double)tmax, (double)rsd_at);
}

/* The yaw inertia phase under the IMU source: the yaw torque was modelled with the prior
 * VEH_KTAU, so the estimate is I_z VEH_KTAU / k_tau and the gyro gives only the ratio
 * k_tau / I_z = VEH_KTAU / estimate. k_tau follows from it only with a prior on I_z
 * (ID_IZZ_PRI_SD > 0: VEH_IZZ with that relative sd, carried); I_z is never published alone. */
static void izz_imu_end(struct experiment *e, const struct app_params *p, float est, float sd)
{
	/* the yaw torque was veh_ktau g(y): its swings scale with g'(y_h), the curve's */
	float rsd_max = e->cfg.rsd_max, rel0 = est > 0.0f ? sd / est : INFINITY, gp = e->cfg.gp_rsd;
	float rs = e->cfg.sc_rsd[2]; /* the identified scales' share of the yaw torque (scales_end) */
	float rel = sqrtf(rel0 * rel0 + gp * gp + rs * rs);
	float ratio = est > 0.0f ? p->veh_ktau / est : NAN, ratio_sd = ratio * rel;
	bool fin = isfinite(ratio) && isfinite(ratio_sd) && ratio > 0.0f;
	bool r_ok = fin && rel < rsd_max;
	result(e, PX_ID_KTIZ, fin ? ratio : 0.0f);
	result(e, PX_ID_KTIZ_SD, fin ? ratio_sd : 0.0f);
	id_out(e, APP_ID_KTAU_OVER_IZZ, 0, ratio, ratio_sd, r_ok, fin ? APP_ID_UNCERTAIN : APP_ID_NOT_FINITE);
	say(e, r_ok ? APP_SEV_INFO : APP_SEV_WARNING, "ID ktau/Izz %.4f +/- %.4f 1/s^2 %s", (double)ratio,
	    (double)ratio_sd, r_ok ? "(gyro: the ratio)" : "rejected: uncertain");
	float izz_sd = e->cfg.izz_sd;
	if (r_ok && izz_sd > 0.0f) {
		float kt = ratio * p->veh_izz, kt_sd = kt * sqrtf(rel * rel + izz_sd * izz_sd);
		enum ident_verdict v = ident_accept(kt, kt_sd, p->veh_ktau, rsd_max);
		bool ok = v == IDENT_ACCEPT;
		result_fin(e, PX_ID_KTAU_EST, kt, 0.0f);
		result_fin(e, PX_ID_KTAU_SD, kt_sd, 0.0f);
		if (ok)
			result(e, PX_VEH_KTAU, kt);
		id_out(e, APP_ID_KTAU, 0, kt, kt_sd, ok, app_id_reason_of_verdict(v));
		say(e, ok ? APP_SEV_INFO : APP_SEV_WARNING, "ID ktau %.4f +/- %.4f %s%s", (double)kt, (double)kt_sd,
		    ok ? "N m (VEH_IZZ prior) " : "rejected: ", ok ? "accepted" : ident_verdict_text(v));
	} else {
		id_out(e, APP_ID_KTAU, 0, NAN, NAN, false, APP_ID_NOT_IDENTIFIABLE);
		say(e, APP_SEV_INFO, "ID ktau, Izz: the ratio only (ID_IZZ_PRI_SD: a prior)");
	}
	id_out(e, APP_ID_IZZ, 0, NAN, NAN, false, APP_ID_NOT_IDENTIFIABLE);
	set_result_bit(e, p, 2u << 2, false);
}

/* An inertia phase's end: the estimate with its sd (the gyro's scale, and under the IMU the
 * modelled torque's), its acceptance, results and status lines; under the IMU the yaw phase
 * gives the ratio k_tau / I_z (izz_imu_end). */
static void inertia_end(struct experiment *e, const struct app_params *p, unsigned ax)
{
	float rsd = e->cfg.rsd_max;
	static const char *const nm[3] = {"Ixx", "Iyy", "Izz"};
	static const int pe[3] = {PX_ID_IXX_EST, PX_ID_IYY_EST, PX_ID_IZZ_EST};
	static const int ps[3] = {PX_ID_IXX_SD, PX_ID_IYY_SD, PX_ID_IZZ_SD};
	static const int pv[3] = {PX_VEH_IXX, PX_VEH_IYY, PX_VEH_IZZ};
	float est = ident_inertia_est(&e->inr), sd = ident_inertia_sd(&e->inr);
	/* the gyro's scale error scales the angular acceleration, so the estimate, by
	 * (1 - s): the data cannot tell it, its calibration's sd joins the published sd */
	float gs = cfg_f(p->id_gyr_scl_sd, 0.0f) * est, sd_data = sd;
	if (isfinite(sd) && isfinite(gs))
		sd = sqrtf(sd * sd + gs * gs);
	bool yaw_tq = ax == 2u && e->cfg.kt_id; /* the yaw torque from k_tau identified */
	if (imu_src(&e->cfg) && (ax != 2u || yaw_tq)) {
		/* the torque is the model's, its swings about hover scaled by the thrust's (the
		 * reaction torque's) slope there: the slope's uncertainty passes one for one
		 * into the inertia; and the identified scales' share (scales_end) */
		float rk = ax != 2u ? e->cfg.slope_rsd : e->cfg.kt_rsd, rs = e->cfg.sc_rsd[ax != 2u ? ax : 3u];
		rk = sqrtf(rk * rk + rs * rs);
		if (isfinite(sd) && rk > 0.0f)
			sd = sqrtf(sd * sd + rk * est * rk * est);
	}
	if (imu_src(&e->cfg) && isfinite(sd)) {
		/* the torque's dynamics are the modelled lag's: its sd through the estimate's own
		 * sensitivity to it (ident_inertia_sens_rel) */
		float rl = ident_inertia_sens_rel(&e->inr) * e->cfg.tau_rsd * est;
		sd = sqrtf(sd * sd + rl * rl);
	}
	if (imu_src(&e->cfg) && !e->cfg.model_ok) {
		/* the torque is the rotor model's: without an identified model the estimate
		 * rests on priors (ID_MOT_TAU, MOT_CURVE, VEH_KF), never to be applied */
		static const int pi[3] = {APP_ID_IXX, APP_ID_IYY, APP_ID_KTAU_OVER_IZZ};
		result(e, pe[ax], isfinite(est) ? est : 0.0f);
		result(e, ps[ax], isfinite(sd) ? sd : 0.0f);
		set_result_bit(e, p, 2u << ax, false);
		id_out(e, (enum app_id_param)pi[ax], 0, ax == 2u ? NAN : est, ax == 2u ? NAN : sd, false,
		       APP_ID_PARTNER_REJECTED);
		say(e, APP_SEV_WARNING, "ID %s rejected: rotor model not identified (experiment 1)", nm[ax]);
		return;
	}
	if (imu_src(&e->cfg) && ax == 2u && !yaw_tq) {
		izz_imu_end(e, p, est, sd);
		return;
	}
	float lo, hi, raise;
	enum ident_verdict v = ident_inertia_accept(est, sd, p->veh_mass, p->veh_arm_l, rsd, &lo, &hi, &raise);
	/* only the data's part shrinks with a stronger or longer excitation: the advice aims
	 * it at what the calibration's part leaves of the asked sd */
	float room = rsd * est * rsd * est - gs * gs;
	if (v == IDENT_UNCERTAIN && raise > 1.0f && gs > 0.0f)
		raise = room > 0.0f ? sd_data / sqrtf(room) : INFINITY;
	bool ok = v == IDENT_ACCEPT;
	result(e, pe[ax], isfinite(est) ? est : 0.0f);
	result(e, ps[ax], isfinite(sd) ? sd : 0.0f);
	if (ok)
		result(e, pv[ax], est);
	set_result_bit(e, p, 2u << ax, ok);
	id_out(e, (enum app_id_param)(APP_ID_IXX + (int)ax), 0, est, sd, ok, app_id_reason_of_verdict(v));
	say(e, ok ? APP_SEV_INFO : APP_SEV_WARNING, "ID %s %.5f +/- %.5f %s%s", nm[ax], (double)est, (double)sd,
	    ok ? "kg m^2 " : "rejected: ", ident_verdict_text(v));
	/* a rejection says what would have been accepted, or what to change */
	if (v == IDENT_OUT_OF_RANGE)
		say(e, APP_SEV_WARNING, "ID %s accepted in [%.4g, %.4g] kg m^2", nm[ax], (double)lo, (double)hi);
	else if (v == IDENT_UNCERTAIN && !isfinite(raise))
		say(e, APP_SEV_WARNING,
		    "ID %s: ID_RSD_MAX %g out of reach: the gyro scale's sd (ID_GYR_SCL_SD %g) alone", nm[ax],
		    (double)rsd, (double)cfg_f(p->id_gyr_scl_sd, 0.0f));
	else if (v == IDENT_UNCERTAIN && raise > 1.0f)
		inertia_advice(e, p, ax, nm[ax], raise);
}

static void phase_end(struct experiment *e, const struct app_params *p)
{
	int k = e->phase_kind[e->phase];
	result(e, PX_ID_SRC_USED, (float)e->cfg.src);
	float rsd = e->cfg.rsd_max;
	if (k == PK_ROTOR && imu_src(&e->cfg)) {
		imu_rotor_end(e, p);
	} else if (k == PK_ROTOR && e->cfg.exc_null) {
		rotor_end(e, p);
	} else if (k == PK_ROTOR) {
		float kf = ident_rotor_est(&e->rot, 0), kf_sd = ident_rotor_sd(&e->rot, 0);
		float kt = ident_rotor_est(&e->rot, 1), kt_sd = ident_rotor_sd(&e->rot, 1);
		float kfp = ident_rotor_plain(&e->rot, 0), ktp = ident_rotor_plain(&e->rot, 1);
		enum ident_verdict vf = ident_accept(kf, kf_sd, p->veh_kf, rsd);
		enum ident_verdict vt = ident_accept(kt, kt_sd, p->veh_ktau, rsd);
		/* the lag model, checked by a Gauss-Newton step (ident.h). Data that show another
		 * lag than the model (a wrong ID_MOT_TAU, an undeclared transport delay, a lockstep
		 * loop that slipped a frame) bias k_f by about 0.03 % per % of lag: beyond LAG_TOL
		 * the estimates are not applied */
		float tau_m = e->cfg.mot_tau, tau_c = ident_rotor_tau_check(&e->rot);
		bool lag_off = tau_c >= 0.0f && isfinite(tau_c) && fabsf(tau_c - tau_m) > LAG_TOL * tau_m;
		bool ok = vf == IDENT_ACCEPT && vt == IDENT_ACCEPT && !lag_off;
		result_fin(e, PX_ID_KF_EST, kf, 0.0f);
		result_fin(e, PX_ID_KF_SD, kf_sd, 0.0f);
		result_fin(e, PX_ID_KF_PLAIN, kfp, 0.0f);
		result_fin(e, PX_ID_KTAU_EST, kt, 0.0f);
		result_fin(e, PX_ID_KTAU_SD, kt_sd, 0.0f);
		result_fin(e, PX_ID_KTAU_PLAIN, ktp, 0.0f);
		if (ok) {
			result(e, PX_VEH_KF, kf);
			result(e, PX_VEH_KTAU, kt);
		}
		set_result_bit(e, p, 1u, ok);
		enum app_id_reason partner = lag_off ? APP_ID_LAG_OFF : APP_ID_PARTNER_REJECTED;
		id_out(e, APP_ID_KF, 0, kf, kf_sd, ok, vf != IDENT_ACCEPT ? app_id_reason_of_verdict(vf) : partner);
		id_out(e, APP_ID_KTAU, 0, kt, kt_sd, ok, vt != IDENT_ACCEPT ? app_id_reason_of_verdict(vt) : partner);
		id_out(e, APP_ID_KF_PLAIN, 0, kfp, NAN, false, APP_ID_AUXILIARY);
		id_out(e, APP_ID_KTAU_PLAIN, 0, ktp, NAN, false, APP_ID_AUXILIARY);
		if (tau_c >= 0.0f && isfinite(tau_c)) /* the lag check: shown, never applied */
			id_out(e, APP_ID_MOT_TAU, 0, tau_c, NAN, false, lag_off ? APP_ID_LAG_OFF : APP_ID_AUXILIARY);
		const char *why_f = ok                   ? "accepted"
				    : vf != IDENT_ACCEPT ? ident_verdict_text(vf)
				    : lag_off            ? "motor lag off"
							 : "ktau rejected";
		const char *why_t = ok                   ? "accepted"
				    : vt != IDENT_ACCEPT ? ident_verdict_text(vt)
				    : lag_off            ? "motor lag off"
							 : "kf rejected";
		/* STATUSTEXT holds 50 characters: the unit goes when a reason has to fit */
		say(e, ok ? APP_SEV_INFO : APP_SEV_WARNING, "ID kf %.3f +/- %.3f %s%s", (double)kf, (double)kf_sd,
		    ok ? "N " : "rejected: ", why_f);
		say(e, ok ? APP_SEV_INFO : APP_SEV_WARNING, "ID ktau %.4f +/- %.4f %s%s", (double)kt, (double)kt_sd,
		    ok ? "N m " : "rejected: ", why_t);
		say(e, APP_SEV_INFO, "ID plain (eq. 20) kf %.3f N ktau %.4f N m", (double)kfp, (double)ktp);
		result_fin(e, PX_ID_TAU_CHECK, tau_c, -1.0f);
		if (tau_c >= 0.0f && isfinite(tau_c))
			say(e, lag_off ? APP_SEV_WARNING : APP_SEV_INFO, "ID motor lag %.4f s%s (ID_MOT_TAU %.4f)",
			    (double)tau_c, lag_off ? " DIFFERS" : "", (double)tau_m);
	} else if (k == PK_INR_X || k == PK_INR_Y || k == PK_INR_Z) {
		inertia_end(e, p, (unsigned)(k - PK_INR_X));
	} else {
		bool post = k == PK_VAL_POST || (k == PK_VAL && (result_mask(p) & 1u));
		float ne = ident_fit_ne(&e->fit), fit = ident_fit_pct(&e->fit);
		result(e, post ? PX_ID_VAL_NE_POST : PX_ID_VAL_NE_PRE, ne);
		result(e, post ? PX_ID_VAL_FIT_POST : PX_ID_VAL_FIT_PRE, fit);
		id_out(e, post ? APP_ID_VAL_NE_AFTER : APP_ID_VAL_NE_BEFORE, 0, ne, fit, isfinite(ne),
		       APP_ID_NOT_FINITE);
		say(e, APP_SEV_INFO, "ID validation %s: NE %.4f fit %.1f %%", post ? "after" : "before", (double)ne,
		    (double)fit);
	}
	e->est_live = 0;
}

/* The null-space dithers: d on the first pattern, a second dither on the other, plus an
 * offset on their sum (below); into out->thr_delta, counting the excited frames in rot_k. */
static void null_dither(struct experiment *e, bool running, scalar_t d, struct exp_output *out)
{
	/* two dithers on the null-space patterns of Gamma_o (excite.h: rotors 1, 5
		 * against 3, 7 and 2, 6 against 4, 8; thrust, roll, pitch and yaw all cancel
		 * whatever k_f and k_tau are, so the vehicle stays still), plus an offset on
		 * their sum cycling +o, 0, -o, 0 every half second: every rotor is excited,
		 * each over three mean throttles (the curve) */
	scalar_t d2 = running ? excite_update(&e->exc2) : SC_ZERO;
	scalar_t o = running ? sc_mul(e->ofs, excite_offset_level(e->rot_k, OFS_SEG_FRAMES)) : SC_ZERO;
	if (running)
		e->rot_k++;
	const scalar_t *p1 = e->pat[0], *p2 = e->pat[1];
	/* in scalars: integer in the fixed build, the same float operations in the other */
	const scalar_t gn = sc_mul(e->exc_gain, e->exc_cap);
	scalar_t a1 = sc_mul(gn, sc_add(d, o)), a2 = sc_mul(gn, sc_add(d2, o));
#if OCTO_FIXED
	/* a1 p1 + a2 p2 with every p 1, -1 or 0: in Q16.16 a product by +/-1 rounds
		 * nothing (and |a| <= INT32_MAX negates without overflow), so the products are
		 * +/-a or 0 exactly, without the multiplications */
	for (int j = 0; j < HAL_ROTORS; j++) {
		scalar_t v1 = p1[j] > 0 ? a1 : (p1[j] < 0 ? -a1 : SC_ZERO);
		scalar_t v2 = p2[j] > 0 ? a2 : (p2[j] < 0 ? -a2 : SC_ZERO);
		out->thr_delta[j] = sc_add(v1, v2);
	}
#else
	for (int j = 0; j < HAL_ROTORS; j++)
		out->thr_delta[j] = sc_add(sc_mul(a1, p1[j]), sc_mul(a2, p2[j]));
#endif
}

/* The rotor experiment's throttle sweep: this frame's collective step (sweep_plan; 0
 * between steps), the steps half a period into the excitation, at the levels in turn. Before
 * the null dither (which counts the excited frames in rot_k). The caller scales it by the
 * tilt's back-off: a collective step is a torque step on a rotor weaker than its MOT_SCALEj. */
/* The sweep's clock, once per running frame: the plant's frames since the excitation began,
 * lost ones included. Through lost frames the plant held the last throttles, a step's among
 * them, so a step lasts its planned time, not its planned count of delivered frames (under
 * 20 % loss that is a quarter longer, and a step's climb grows as its time squared). */
static uint32_t sweep_clock(struct experiment *e)
{
	if (e->rot_k > 0u)
		e->swp_k += e->fr_span - 1u;
	return e->swp_k++;
}

static scalar_t sweep_step(struct experiment *e, bool running)
{
	if (!running)
		return SC_ZERO;
	uint32_t per = e->swp_per ? e->swp_per : 1u, kk = sweep_clock(e) + per / 2u;
	uint32_t ph = kk % per, lv = (kk / per) % EXP_SWP_LEVELS;
	return ph < e->swp_len[lv] && app_f_lt(e->t_phase, e->swp_end) ? e->swp_thr[lv] : SC_ZERO;
}

/* The thrust rows' sweep (rows_plan): this frame's plan (-1: none) and whether it is the
 * rise (else a dip), at the sweep's clock k (sweep_clock). The first pattern starts half a
 * period into the excitation, and a pattern only if it ends by swp_kmax. At a pattern's first
 * frame its plan is chosen: its level's, or the lossy link's cut rise (EXP_SWP_LEVELS) when
 * a frame was lost within SWP_LOSS_S before it. */
static int rows_level(struct experiment *e, bool running, uint32_t k, bool *up)
{
	uint32_t per = e->swp_per ? e->swp_per : 1u, kk = k + per / 2u;
	uint32_t ph = kk % per, pat = kk / per, lv = pat % EXP_SWP_LEVELS;
	if (!running || kk < per)
		return -1;
	if (pat != e->swp_pat) {
		e->swp_pat = pat;
		uint32_t k0 = k - ph; /* the pattern's first frame; a frame lost since counts too */
		e->swp_cut = e->swp_lost &&
			     (e->swp_lost_k >= k0 || (float)(k0 - e->swp_lost_k) < SWP_LOSS_S * e->inv_dt_nom);
	}
	lv = e->swp_cut ? EXP_SWP_LEVELS : lv;
	uint32_t n = e->swp_len[lv], m = e->swp_dn_len[lv], len = 2u * m + n;
	if (n == 0u || ph >= len || k + (len - ph) > e->swp_kmax)
		return -1;
	if (pat != e->swp_pat_n) { /* flown: counted once */
		e->swp_pat_n = pat;
		e->swp_n_pat++;
		e->swp_n_cut += e->swp_cut ? 1u : 0u;
	}
	*up = ph >= m && ph < m + n;
	return (int)lv;
}

/* The inertia axis' gyro reading w an outlier (INR_GATE_W): its change since the filters'
 * last reading, over m frames, beyond what noise and the torques can make it (scalar_t). */
static bool inr_gyro_outlier(const struct experiment *e, scalar_t w, scalar_t tau, int m)
{
	scalar_t dw = sc_abs(sc_sub(w, e->inr.w_prev));
	scalar_t lim = sc_add(SC(INR_GATE_W), sc_mul(e->inr_gate_k, sc_add(sc_abs(tau), sc_abs(e->inr.tau_prev))));
	return dw > sc_mul(lim, sc_from_int((int32_t)m));
}

/* With the rotor speeds, a yaw dither (ID_COL_AMP, the collective dither's amplitude and cap;
 * its own PRBS): every rotor of one spin direction up, the other's down, by the sign of the
 * mixer's yaw column (yaw_sign, set by scales_begin). The null-space dithers and the sweep
 * leave the spin directions' contrast to the yaw loop's corrections, which answer the gyro's
 * own noise: the yaw axis then reads a gain too high and the scales' contrast too small (docs/identification.md, "Each rotor's
 * effectiveness, with the rotor speeds"). This dither moves that contrast independently of the
 * noise, and the force sees it as well as the gyro. */
static void yaw_dither(struct experiment *e, bool running, struct exp_output *out)
{
	scalar_t dy = running ? sc_mul(sc_mul(e->exc_gain, e->exc_cap), excite_update(&e->exc4)) : SC_ZERO;
	for (int j = 0; j < HAL_ROTORS; j++) {
		if (e->yaw_sign[j] > 0)
			out->thr_delta[j] = sc_add(out->thr_delta[j], dy);
		else if (e->yaw_sign[j] < 0)
			out->thr_delta[j] = sc_sub(out->thr_delta[j], dy);
	}
}

/* The IMU rotor phase's frame: the collective model (imu_id), with the rotor speeds the
 * motor's speed model and each rotor's effectiveness (imu_scale); the null-space dithers, the
 * throttle sweep and the collective dither out. */
static void imu_rotor_step(struct experiment *e, const struct exp_input *in, struct exp_output *out, int n,
			   bool running, bool use)
{
	const struct app_params *p = in->params;
	const scalar_t *tp = in->thr_prev;
	for (int i = 1; i < n; i++)
		imu_id_hold(&e->imid, tp);
	scalar_t tq = SC_ZERO;
	if (e->cfg.src == EXP_SRC_IMU_RPM_TQ && in->torque_nm)
		for (int j = 0; j < HAL_ROTORS; j++)
			tq = sc_add(tq, in->torque_nm[j]);
	if (n >= 1)
		imu_id_step(&e->imid, tp, imu_force(in, p), imu_force_up(in, p), sc_from_float(in->frame->vel_i_mps[2]),
			    tq, use);
	if (rpm_src(&e->cfg)) {
		speed_model_step(e, in, n, use);
		for (int i = 1; i < n; i++)
			imu_scale_hold(&e->isc);
		if (n >= 1)
			imu_scale_step(&e->isc, tp, in->frame->rotor_speed_rps, imu_force(in, p), in->rate_b_rps, use);
	}
	scalar_t d0 = sweep_step(e, running);
	null_dither(e, running, running ? excite_update(&e->exc) : SC_ZERO, out);
	scalar_t dc = running ? sc_mul(e->exc_cap, excite_update(&e->exc3)) : SC_ZERO;
	d0 = sc_mul(e->exc_gain, sc_add(d0, dc));
	for (int j = 0; j < HAL_ROTORS; j++)
		out->thr_delta[j] = sc_add(out->thr_delta[j], d0);
	if (rpm_src(&e->cfg))
		yaw_dither(e, running, out);
}

/* An inertia phase's frame about axis ax: the body torque (measured, or the rotor model's
 * under the IMU), the gyro's outliers and lost frames bridged, the filters and the instrument
 * updated; the torque excitation out. */
static void inertia_step(struct experiment *e, const struct exp_input *in, struct exp_output *out, unsigned ax, int n,
			 bool running, bool use)
{
	scalar_t tau[3];
	inertia_torque(e, in->thrust_n, in->torque_nm, in->params->veh_arm_l, in->thr_prev, n, tau);
	/* the instrument: the excitation sent on the previous step, which acted over the
	 * frame this update closes (and, the plant holding it, over the frames lost before),
	 * through the motor model's delay and lag: the torque it makes at the frame's end. A
	 * function of the excitation alone, so independent of every noise; in phase with the
	 * torque, so its correlation with the regressor does not cancel across the multisine's
	 * band on slow or late motors (where the excitation itself lags the torque by up to
	 * half a period) */
	scalar_t zi = SC_ZERO;
	for (int i = 0; i < (n > 1 ? n : 1); i++)
		zi = filt_lag_update(&e->inr_lag, filt_delay_update(&e->inr_delay, e->inr_u_prev));
	ident_inertia_instrument(&e->inr, zi);
	int m = n + e->inr_skip; /* frames since the filters' last */
	if (n >= 1 && m <= GAP_INTERP_MAX && inr_gyro_outlier(e, in->rate_b_rps[ax], tau[ax], m)) {
		/* never into the filters: interpolated through at the next frame, as a lost
		 * one, the updates held after it */
		e->inr_skip = m;
		e->gap_hold = GAP_HOLD;
	} else {
		e->inr_skip = 0;
		if (m >= 2 && m <= GAP_INTERP_MAX + 1) {
			ident_inertia_gap(&e->inr, tau, in->rate_b_rps, (unsigned)(m - 1));
		} else if (m != 1) {
			ident_inertia_restart(&e->inr, tau, in->rate_b_rps);
			float wc = ax == 2u ? INR_WC_YAW_RPS : INR_WC_RP_RPS;
			e->gap_hold = (int)(GAP_SETTLE_TC * e->inv_dt_nom / (INR_ZETA * wc) + 0.5f);
		}
		ident_inertia_update(&e->inr, tau, in->rate_b_rps, use && m == 1 && e->gap_hold == 0);
	}
	scalar_t u = SC_ZERO;
	if (running) {
		/* faded in over INR_RAMP_S: the multisine's abrupt start kicks a weakly damped
		 * attitude loop past the tilt's budget, and the back-off then halves the whole
		 * phase's excitation for a transient */
		float r = (e->t_phase - e->t_settle) * (1.0f / INR_RAMP_S);
		u = sc_mul(e->exc_gain, excite_update(&e->exc));
		if (r < 1.0f)
			u = sc_mul(sc_from_float(r > 0.0f ? r : 0.0f), u);
	}
	out->tau_delta[ax] = u;
	e->inr_u_prev = u;
}

static void phase_step(struct experiment *e, const struct exp_input *in, struct exp_output *out)
{
	const struct app_params *p = in->params;
	int k = e->phase_kind[e->phase];
	bool running = app_f_le(e->t_settle, e->t_phase); /* the step's comparisons: fcmp.h */
	/* frames since the last step: more than one when frames were lost on the link (the
	 * plant then held the last throttles); the rotor and validation models advance through
	 * the gap, and so do the inertia filters (uniform sampling: interpolated, or restarted
	 * after a long gap), their updates held for gap_hold frames after it */
	if (!app_f_eq(in->dt_s, e->fr_dt)) { /* the same period as the last step: the same count */
		float fr = in->dt_s * e->inv_dt_nom;
		e->fr_n = fr > 0.5f && fr < (float)FILT_DELAY_MAX + 0.5f ? (int)(fr + 0.5f) : 0;
		e->fr_span = fr > 0.5f && fr < EXP_SPAN_MAX ? (uint32_t)(fr + 0.5f) : 1u;
		e->fr_dt = in->dt_s;
	}
	int n = e->fr_n;
	if (n != 1)
		e->gap_hold = GAP_HOLD;
	else if (e->gap_hold > 0)
		e->gap_hold--;
	bool use = running && n >= 1;

	if (k == PK_ROTOR && imu_src(&e->cfg)) {
		imu_rotor_step(e, in, out, n, running, use);
	} else if (k == PK_ROTOR) {
		const scalar_t *tp = in->thr_prev, *fm = in->thrust_n, *tm = in->torque_nm;
		for (int i = 1; i < n; i++) {
			ident_rotor_hold(&e->rot, tp[0]);
			motor_id_hold(&e->mid, tp);
		}
		ident_rotor_update(&e->rot, tp[0], fm[0], tm[0], use);
		/* the motor model needs every rotor excited: the null-space dither only */
		if (e->cfg.exc_null && n >= 1)
			motor_id_step(&e->mid, tp, fm, tm, use);
		scalar_t d = running ? excite_update(&e->exc) : SC_ZERO;
		bool up = false;
		if (e->fr_span > 1u) { /* frames lost before this one (the lossy link's rule) */
			e->swp_lost = true;
			e->swp_lost_k = e->swp_k;
		}
		int lv = e->cfg.exc_null && running ? rows_level(e, running, sweep_clock(e), &up) : -1;
		if (lv >= 0)
			motor_id_white_pause(&e->mid, up ? e->swp_white : e->swp_white_dn);
		if (!running && n >= 1) { /* each rotor's hover throttle (sweep_rotors) */
			for (int j = 0; j < HAL_ROTORS; j++)
				e->thr_sum[j] = sc_add(e->thr_sum[j], tp[j]);
			e->thr_n++;
		}
		out->thr_delta[0] = sc_mul(sc_mul(e->exc_gain, e->exc_cap), d);
		if (e->cfg.exc_null) {
			null_dither(e, running, d, out);
			for (int j = 0; lv >= 0 && !up && j < HAL_ROTORS; j++) /* a dip: the dithers pause */
				out->thr_delta[j] = SC_ZERO;
			/* each rotor's rise or dip once planned, the common one before */
			int l = lv >= 0 ? lv : 0;
			const scalar_t *st = !e->swp_rotors ? NULL : (up ? e->swp_thr_r[l] : e->swp_dn_r[l]);
			scalar_t d0 = lv >= 0 ? sc_mul(e->exc_gain, up ? e->swp_thr[l] : e->swp_dn[l]) : SC_ZERO;
			for (int j = 0; lv >= 0 && j < HAL_ROTORS; j++)
				out->thr_delta[j] = sc_add(out->thr_delta[j], st ? sc_mul(e->exc_gain, st[j]) : d0);
		}
	} else if (k == PK_INR_X || k == PK_INR_Y || k == PK_INR_Z) {
		inertia_step(e, in, out, (unsigned)(k - PK_INR_X), n, running, use);
	} else {
		/* the model's prediction of rotor 1's thrust: the allocation behind the throttle
		 * sent on the previous frame, through the modelled delay and lag */
		if (imu_src(&e->cfg)) {
			/* the specific force's prediction: the modelled thrusts' sum */
			rmodel_step(&e->rm, in->thr_prev, n, e->f_model, e->tq_model, NULL);
			scalar_t y_hat = SC_ZERO;
			for (int j = 0; j < HAL_ROTORS; j++)
				y_hat = sc_add(y_hat, e->f_model[j]);
			if (use)
				ident_fit_add(&e->fit, imu_force(in, p), y_hat);
			out->f_delta = running ? sc_mul(e->exc_gain, excite_update(&e->exc)) : SC_ZERO;
			return;
		}
		scalar_t fc = in->rotor_f_cmd[0], y_hat = SC_ZERO;
		for (int i = 0; i < (n > 1 ? n : 1); i++)
			y_hat = filt_lag_update(&e->val_lag, filt_delay_update(&e->val_delay, fc));
		if (use)
			ident_fit_add(&e->fit, in->thrust_n[0], y_hat);
		out->tau_delta[2] = running ? sc_mul(e->exc_gain, excite_update(&e->exc)) : SC_ZERO;
	}
}

/* The current phase's live estimates into est[] / est_sd[] (telemetry at a few Hz, the log,
 * the status lines): est[0..3] rotor 1's k_f and k_tau, lag-aware and plain; est[4 + axis]
 * the inertia; est[7] the validation's NE and fit %. An estimator whose frame still waits
 * for its update (the step's call) is read by exp_pump after the update, between frames. */
static void read_estimates(struct experiment *e)
{
	int k = e->phase_kind[e->phase];
	if (k == PK_ROTOR && imu_src(&e->cfg)) {
		return; /* no live estimate: the IMU's solve runs once, at the phase's end */
	} else if (k == PK_ROTOR) {
		if (!e->rot.q_pending)
			ident_rotor_read(&e->rot, e->est, e->est_sd);
	} else if (k == PK_INR_X || k == PK_INR_Y || k == PK_INR_Z) {
		if (e->inr.q_pending)
			return;
		unsigned ax = (unsigned)(k - PK_INR_X);
		e->est[4 + ax] = ident_inertia_est(&e->inr);
		e->est_sd[4 + ax] = ident_inertia_sd(&e->inr);
	} else {
		e->est[7] = ident_fit_ne(&e->fit);
		e->est_sd[7] = ident_fit_pct(&e->fit);
	}
}

#define EXT_MAX 4.0f      /* a phase excites at most this many times its planned time */
#define EXT_AIM 0.8f      /* an extension aims the sd at this share of ID_RSD_MAX */
#define EXT_GAIN_MAX 2.5f /* and raises an inertia phase's amplitude at most so much */

/* An inertia phase's relative sd that no more data reduce, as inertia_end and izz_imu_end
 * add it to the data's: the gyro scale's calibration (ID_GYR_SCL_SD) and, under the IMU,
 * the modelled torque's (the thrust's or the reaction torque's slope, the scales' share; for
 * the yaw ratio the curve's slope and the scales'; the lag's) */
static float inertia_rsd_fixed(struct experiment *e, const struct app_params *p, unsigned ax)
{
	float g = cfg_f(p->id_gyr_scl_sd, 0.0f), v = g * g;
	if (imu_src(&e->cfg)) {
		float a, b;
		if (ax != 2u) {
			a = e->cfg.slope_rsd;
			b = e->cfg.sc_rsd[ax];
		} else if (e->cfg.kt_id) {
			a = e->cfg.kt_rsd;
			b = e->cfg.sc_rsd[3];
		} else {
			a = e->cfg.gp_rsd;
			b = e->cfg.sc_rsd[2];
		}
		float l = ident_inertia_sens_rel(&e->inr) * e->cfg.tau_rsd; /* the modelled lag's */
		v += a * a + b * b + l * l;
	}
	return sqrtf(v);
}

/* The largest relative sd among what the phase would publish, from its data as they stand
 * (NAN where its model is rejected for another cause, or for phases that are not extended);
 * *fixed: the part of it more data do not reduce (inertia_rsd_fixed; 0 for the rotor phase) */
static float phase_rsd(struct experiment *e, const struct app_params *p, float *fixed)
{
	int k = e->phase_kind[e->phase];
	*fixed = 0.0f;
	if (k == PK_ROTOR && imu_src(&e->cfg)) {
		struct imu_id_result r;
		imu_id_process(&e->imid);
		imu_id_solve(&e->imid, IMU_HAC_MAX, &r);
		return r.cause == IMU_ID_OK && r.kf > 0.0f ? r.kf_sd / r.kf : NAN;
	}
	if (k == PK_ROTOR && e->cfg.exc_null) {
		struct motor_id_result mr;
		motor_id_process(&e->mid);
		motor_id_solve(&e->mid, MOT_NE_MAX, &mr);
		if (mr.cause != MOTOR_ID_OK || !(mr.kf > 0.0f) || !(mr.ktau > 0.0f))
			return NAN;
		return fmaxf(mr.kf_sd / mr.kf, mr.ktau_sd / mr.ktau);
	}
	if (k == PK_INR_X || k == PK_INR_Y || k == PK_INR_Z) {
		if (imu_src(&e->cfg) && !e->cfg.model_ok) /* rejected whatever its sd */
			return NAN;
		float est = ident_inertia_est(&e->inr), sd = ident_inertia_sd(&e->inr), rd = sd / est;
		float fx = inertia_rsd_fixed(e, p, (unsigned)(k - PK_INR_X));
		*fixed = fx;
		return est > 0.0f ? sqrtf(rd * rd + fx * fx) : NAN;
	}
	return NAN;
}

/* At the planned end of a rotor or inertia phase whose sd is above ID_RSD_MAX: the excitation
 * goes on, once, until the information (time x amplitude^2: the sd falls as its square root)
 * brings the sd to EXT_AIM of it: up to EXT_MAX times the planned time, and for an inertia
 * phase whose need the time alone cannot meet, at a larger amplitude (up to inr_amp_limit
 * and EXT_GAIN_MAX, not after a back-off; the tilt's back-off still guards it), within the phase's time limit, said; beyond
 * twice that reach the phase ends as planned (its rejection says what to change). The
 * progress carries on from where it was. */
static bool phase_extend(struct experiment *e, const struct app_params *p)
{
	if (e->ext_done)
		return false;
	float fx, rsd = phase_rsd(e, p, &fx), lim = e->cfg.rsd_max;
	if (!(rsd > lim) || !isfinite(rsd) || !(lim > 0.0f))
		return false;
	/* the data's part of the sd to the room the fixed part leaves of the aim */
	float aim = EXT_AIM * lim, room = aim * aim - fx * fx;
	if (!(room > 0.0f))
		return false;
	float need = (rsd * rsd - fx * fx) / room;
	int k = e->phase_kind[e->phase];
	float a = 1.0f, a_max = 1.0f;
	if (k == PK_INR_X || k == PK_INR_Y || k == PK_INR_Z) {
		float amp = e->cfg.inr_amp;
		a_max = amp > 0.0f ? fminf(EXT_GAIN_MAX, inr_amp_limit(p, (unsigned)(k - PK_INR_X)) / amp) : 1.0f;
		/* not where the tilt already made the excitation back off */
		a_max = a_max > 1.0f && !(e->exc_cut_t >= 0.0f) ? a_max : 1.0f;
		if (need > EXT_MAX)
			a = fminf(a_max, sqrtf((need - 1.0f) / (EXT_MAX - 1.0f)));
	}
	if (need > 2.0f * (1.0f + (EXT_MAX - 1.0f) * a_max * a_max))
		return false;
	float add = e->t_run * (fminf(need, EXT_MAX) - 1.0f);
	float user = k == PK_ROTOR ? e->cfg.rot_to : e->cfg.inr_to;
	if (user > 0.0f)
		add = fminf(add, user - 0.5f - e->t_total);
	if (!(add >= 1.0f))
		return false;
	e->ext_done = true;
	float p0 = e->prog_base + e->t_phase * e->prog_rate, p1 = (float)(e->phase + 1) / (float)e->n_phases;
	e->t_run += add;
	e->t_total += add;
	e->swp_end += add;
	const char *lim_name;
	e->t_limit = phase_limit(e, &lim_name);
	float left = e->t_total - e->t_phase;
	e->prog_rate = left > 0.0f && p1 > p0 ? (p1 - p0) / left : 0.0f;
	e->prog_base = p0 - e->t_phase * e->prog_rate;
	e->exc_gain = sc_mul(e->exc_gain, sc_from_float(a));
	if (!(e->exc_cut_t >= 0.0f))
		e->exc_top = e->exc_gain;
	say(e, APP_SEV_INFO, "ID excitation %.0f s longer: sd %.4f above ID_RSD_MAX %.4f", (double)add, (double)rsd,
	    (double)lim);
	if (a > 1.0f)
		say(e, APP_SEV_INFO, "ID excitation x%.2f for it", (double)a);
	return true;
}

void exp_turn(struct experiment *e, const struct app_params *p)
{
	if (e->begin_pending) { /* the experiment's first step ran: its first phase begins */
		e->begin_pending = false;
		if (e->state == EXP_RUNNING)
			phase_begin(e, p, &e->turn);
		return;
	}
	if (!e->turn_pending)
		return;
	e->turn_pending = false;
	if (e->state != EXP_RUNNING)
		return;
	if (phase_extend(e, p))
		return;
	phase_end(e, p);
	e->phase++;
	if (e->phase >= e->n_phases) {
		e->phase = e->n_phases - 1;
		e->progress = 1.0f;
		e->reporting = true;
		e->ids_final = true;
		say(e, APP_SEV_INFO, "ID done");
	} else {
		phase_begin(e, p, &e->turn);
	}
}

/* The current phase's time limit (plant time, settling included) and its parameter's name:
 * ID_ROT_TO, ID_INR_TO or ID_VAL_TO, or with 0 twice the phase's planned time plus 5 s (a
 * guard: a phase runs its planned time unless something holds it up). */
static float phase_limit(const struct experiment *e, const char **name)
{
	int k = e->phase_kind[e->phase];
	float lim = k == PK_ROTOR ? e->cfg.rot_to : (k >= PK_INR_X && k <= PK_INR_Z) ? e->cfg.inr_to : e->cfg.val_to;
	*name = k == PK_ROTOR ? "ID_ROT_TO" : (k >= PK_INR_X && k <= PK_INR_Z) ? "ID_INR_TO" : "ID_VAL_TO";
	return lim > 0.0f ? lim : 2.0f * (e->t_settle + e->t_run) + 5.0f;
}

/* A phase over its time limit: the experiment fails with the reason (severity ERROR, the
 * limit and the phase's planned time) and its final answer FAILED; results not yet applied
 * are dropped. */
static void limit_fail(struct experiment *e, const char *name, float lim)
{
	int k = e->phase_kind[e->phase];
	e->q_n = 0;
	e->n_results = 0;
	e->est_live = 0;
	say(e, APP_SEV_ERROR, "ID %s failed: %s %.1f s", phase_name(k), name, (double)lim);
	say(e, APP_SEV_ERROR, "ID aborted: time limit, phase planned %.1f s", (double)(e->t_settle + e->t_run));
	e->state = EXP_ABORTED;
	e->final_result = APP_FAILED;
}

bool exp_reads_torque(const struct experiment *e)
{
	if (e->state != EXP_RUNNING || e->reporting)
		return false;
	if (e->turn_pending || e->begin_pending) /* the phase may change first (exp_turn in exp_step) */
		return true;
	int k = e->phase_kind[e->phase];
	return k == PK_ROTOR || k == PK_INR_X || k == PK_INR_Y || k == PK_INR_Z;
}

/* The excitation against the attitude and height budgets: beyond EXP_TILT_SOFT_DEG (the
 * body's z axis against its cosine: 1 - 2 (qx^2 + qy^2)) or EXP_HEIGHT_SOFT_M from the height
 * at the start, the phase's excitation (the sweep's steps included) halves, at most every
 * EXC_CUT_S and down to EXP_GAIN_MIN, and says so; EXC_RECOVER_S within both it doubles back,
 * up to half the scale it was over at (a sweep step's kick passes, the loop's response to it
 * does not); the estimators regress on what was sent,
 * so a smaller excitation costs precision, not bias. EXP_TILT_ABORT_DEG and the height limit
 * still abort. */
#define EXC_CUT_S 0.1f
#define EXC_RECOVER_S 2.0f
static void exc_backoff(struct experiment *e, const struct hal_sensor_frame *f)
{
	const float cos_soft = 0.98768834f; /* cos(EXP_TILT_SOFT_DEG) */
	float ct = 1.0f - 2.0f * (f->q_ib[1] * f->q_ib[1] + f->q_ib[2] * f->q_ib[2]);
	bool tilt = ct < cos_soft, high = app_f_lt(EXP_HEIGHT_SOFT_M, fabsf(f->pos_i_m[2] - e->z0));
	if (tilt || high) {
		e->exc_over_t = e->t_phase;
	} else if (e->exc_cut_t >= 0.0f && e->exc_gain < e->exc_top && e->t_phase - e->exc_over_t >= EXC_RECOVER_S &&
		   e->t_phase - e->exc_cut_t >= EXC_RECOVER_S) {
		/* EXC_RECOVER_S within both budgets since the last halving or doubling: doubles
		 * back, up to the phase's scale (what tilted it may have been a passing kick) */
		scalar_t g = sc_mul(e->exc_gain, SC(2));
		e->exc_gain = g < e->exc_top ? g : e->exc_top;
		e->exc_cut_t = e->t_phase;
		e->exc_up = true;
		say(e, APP_SEV_INFO, "ID excitation x%.3f: within the budgets again", (double)sc_to_float(e->exc_gain));
		return;
	}
	if (!(tilt || high) || e->t_phase - e->exc_cut_t < EXC_CUT_S || e->exc_cut_t > e->t_phase)
		return;
	if (e->exc_gain < SC(0.25)) /* 2 EXP_GAIN_MIN: one more halving would pass it */
		return;
	/* over at a scale it had not been cut from since: a recovery comes back to half of it */
	if (!(e->exc_cut_t >= 0.0f) || e->exc_up)
		e->exc_top = sc_mul(e->exc_gain, SC(0.5));
	e->exc_up = false;
	e->exc_gain = sc_mul(e->exc_gain, SC(0.5));
	e->exc_cut_t = e->t_phase;
	if (tilt)
		say(e, APP_SEV_WARNING, "ID excitation x%.3f: tilt beyond %.0f deg", (double)sc_to_float(e->exc_gain),
		    (double)EXP_TILT_SOFT_DEG);
	else
		say(e, APP_SEV_WARNING, "ID excitation x%.3f: height beyond %.2f m", (double)sc_to_float(e->exc_gain),
		    (double)EXP_HEIGHT_SOFT_M);
}

enum exp_state exp_step(struct experiment *e, const struct exp_input *in, struct exp_output *out)
{
	if (e->state != EXP_RUNNING)
		return e->state;
	exp_turn(e, in->params); /* normally done between frames already (nothing left here) */
	const struct hal_sensor_frame *f = in->frame;
	if (!e->started) {
		e->started = true;
		/* the frame period: the app's (not this step's dt, which after a lost frame is
		 * two periods: the models then ran at half rate and k_f came out 1.5 % low) */
		float dtn = in->dt_frame_s > 0.0f ? in->dt_frame_s : in->dt_s;
		e->dt_nom = dtn > 0.001f && dtn < 0.1f ? dtn : 1.0f / 90.0f;
		e->inv_dt_nom = 1.0f / e->dt_nom;
		e->z0 = f->pos_i_m[2];
		/* the first phase begins between frames (exp_turn), from what this step saw, as
		 * every later one does: its set-up (the estimators' initialisation, many steps'
		 * worth on Cortex-M) stays out of the step, which sends no excitation yet */
		snapshot(&e->turn, in);
		e->begin_pending = true;
		e->pump_ready = true;
		return e->state;
	}
	if (app_f_lt(HEIGHT_ABORT_M, fabsf(f->pos_i_m[2] - e->z0))) {
		exp_abort(e, "height limit");
		return e->state;
	}
	if (!e->reporting) {
		exc_backoff(e, f);
		phase_step(e, in, out);
		e->t_phase += in->dt_s;
		float total = e->t_total;
		if (app_f_lt(e->t_limit, e->t_phase)) {
			const char *lim_name;
			float lim = phase_limit(e, &lim_name);
			memset(out, 0, sizeof *out);
			limit_fail(e, lim_name, lim);
			return e->state;
		}
		/* min(t_phase, total): t_phase is never NaN, total always finite (so "not over" is
		 * t_phase < total) */
		bool over = app_f_le(total, e->t_phase);
		e->progress = e->prog_base + (over ? total : e->t_phase) * e->prog_rate;
		/* the estimates (soft float on a core without FPU) every EST_READ_FRAMES steps, on
		 * the phase's first step and on its last, which the phase's end and the log's last
		 * frame of the phase see */
		if (e->est_wait == 0u || over) {
			read_estimates(e);
			e->est_wait = EST_READ_FRAMES;
		}
		e->est_wait--;
		if (over) {
			/* the phase is over: its end (estimates, results, verdicts) and the next one's
			 * start run between frames (exp_turn), from what this step saw */
			snapshot(&e->turn, in);
			e->turn_pending = true;
		}
	}
	e->pump_ready = true; /* exp_pump may hand out the next line (between frames) */
	/* finished once every line has gone out (exp_pump and the app's tick send them) */
	if (e->reporting && !e->q_n && !e->msg[0]) {
		e->state = EXP_FINISHED;
		e->final_result = APP_ACCEPTED;
	}
	return e->state;
}
