/* app.c - the autopilot's step, modes and commands (see app.h). */
#include "app.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#define FIRST_DT_S (1.0f / 90.0f)
#define MAX_DT_S 0.2f              /* longer gaps are integrated as 200 ms */
#define PERIOD_FRAMES 90u          /* frames over which the frame period is measured */
#define HOVER_Z_TOL_M 0.3f
#define HOVER_TILT_DEG 5.0f

static float clampf(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }

const char *app_mode_name(enum app_mode m)
{
	static const char *const names[] = {"DISARMED", "IDLE", "TAKEOFF", "HOLD", "EXPERIMENT", "LAND"};
	return (unsigned)m < sizeof names / sizeof names[0] ? names[m] : "?";
}

bool app_flying(const struct app *a)
{
	return a->mode == APP_TAKEOFF || a->mode == APP_HOLD || a->mode == APP_EXPERIMENT ||
	       a->mode == APP_LAND;
}

static struct quat frame_q(const struct hal_sensor_frame *f)
{
	struct quat q = {sc_from_float(f->q_ib[0]), sc_from_float(f->q_ib[1]),
			 sc_from_float(f->q_ib[2]), sc_from_float(f->q_ib[3])};
	return quat_normalize(q);
}

static float tilt_deg(const struct hal_sensor_frame *f)
{
	float c = sc_to_float(quat_body_z_up(frame_q(f)));
	return acosf(clampf(c, -1.0f, 1.0f)) / DEG_F;
}

static scalar_t frame_yaw(const struct hal_sensor_frame *f)
{
	return quat_yaw(frame_q(f));
}

/* All throttles to t (the float sent and, in the fixed build, its scalar copy). */
static void set_thr_all(struct app *a, float t)
{
	for (int j = 0; j < HAL_ROTORS; j++)
		a->thr[j] = t;
#if OCTO_FIXED
	scalar_t ts = sc_from_float(t);
	for (int j = 0; j < HAL_ROTORS; j++)
		a->thr_sc[j] = ts;
#endif
}

#if OCTO_FIXED
/* sc_to_float(v) and sc_from_float(f) through a kept pair: the conversion runs only when the
 * value differs from the last one (the zeroed pair is right: 0 converts to +0.0f and +0.0f
 * to 0). The float is compared by its bits: one float converts to one scalar. */
static float to_float_kept(struct app_sc_kept *k, scalar_t v)
{
	if (v != k->v) {
		k->v = v;
		k->f = sc_to_float(v);
	}
	return k->f;
}

static scalar_t from_float_kept(struct app_sc_kept *k, float f)
{
	union { float f; uint32_t u; } x = {f}, y = {k->f};
	if (x.u != y.u) {
		k->f = f;
		k->v = sc_from_float(f);
	}
	return k->v;
}
#define TO_FLOAT_KEPT(a, i, v) to_float_kept(&(a)->log_sp_kept[i], v)
#define FROM_FLOAT_KEPT(a, k, f) from_float_kept(&(a)->k, f)
#else
#define TO_FLOAT_KEPT(a, i, v) ((void)(a), (v))
#define FROM_FLOAT_KEPT(a, k, f) ((void)(a), (f))
#endif

/* the frame's position as scalars */
static void frame_pos(const struct hal_sensor_frame *f, scalar_t pos[3])
{
	for (int i = 0; i < 3; i++)
		pos[i] = sc_from_float(f->pos_i_m[i]);
}

/* what guidance flies in each mode */
static enum guid_mode guid_mode_of(enum app_mode m)
{
	switch (m) {
	case APP_TAKEOFF:
		return GUID_TAKEOFF;
	case APP_HOLD:
	case APP_EXPERIMENT:
		return GUID_HOLD;
	case APP_LAND:
		return GUID_LAND;
	default:
		return GUID_GROUND;
	}
}

bool app_hovering(const struct app *a)
{
	return a->mode == APP_HOLD && a->have_step && a->link_ok &&
	       fabsf(a->fr.pos_i_m[2] - sc_to_float(a->guid.z_target_m)) < HOVER_Z_TOL_M &&
	       fabsf(a->fr.vel_i_mps[2]) < 0.3f && tilt_deg(&a->fr) < HOVER_TILT_DEG;
}

void app_status(struct app *a, enum app_severity severity, const char *fmt, ...)
{
	char text[APP_EVENT_TEXT];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(text, sizeof text, fmt, ap);
	va_end(ap);
	a->hal->report(a->hal->ctx, text);
	hal_log_event(a->hal, a->fr.t_s, (int)severity, text);
	struct app_event e = {.kind = APP_EV_STATUS, .severity = (uint8_t)severity};
	memcpy(e.text, text, sizeof e.text);
	outbox_post(&a->outbox, &e);
}

/* An aborted experiment's reasons (its message and queued lines) go out at once, before the
 * command's final FAILED: a ground station that stops on the FAILED has them already. */
static void exp_flush(struct app *a)
{
	for (int i = 0; i <= EXP_QUEUE; i++) {
		if (!a->exp.msg[0]) {
			a->exp.pump_ready = true;
			exp_pump(&a->exp);
		}
		if (!a->exp.msg[0])
			return;
		app_status(a, a->exp.msg_severity, "%s", a->exp.msg);
		a->exp.msg[0] = 0;
	}
}

/* One result as data: to the log and the outbox, with its place in the run. */
static void post_id(struct app *a, const struct app_id_result *r)
{
	hal_log_id_result(a->hal, a->fr.t_s, r);
	struct app_event e = {.kind = APP_EV_ID_RESULT, .id = *r};
	outbox_post(&a->outbox, &e);
}

/* The results as data of the phase the experiment just closed, numbered within the run;
 * the run's last (ids_final) says the run is done. */
static void publish_ids(struct app *a)
{
	struct app_id_run *run = &a->id_run;
	for (int i = 0; i < a->exp.n_ids && run->count < APP_ID_RUN_MAX; i++) {
		struct app_id_result *r = &run->r[run->count];
		*r = a->exp.ids[i];
		r->run_id = run->run_id;
		r->index = run->count;
		r->count = (uint8_t)(run->count + 1u);
		run->count++;
		run->done = a->exp.ids_final && i == a->exp.n_ids - 1;
		r->run_done = run->done ? 1u : 0u;
		post_id(a, r);
	}
	a->exp.n_ids = 0;
}

/* A run that ends without its last phase's results (aborted): its last result again, now
 * with run_done, so that a reader knows the count is final. */
static void end_id_run(struct app *a)
{
	struct app_id_run *run = &a->id_run;
	if (run->done || run->count == 0)
		return;
	run->done = true;
	struct app_id_result *r = &run->r[run->count - 1];
	r->count = run->count;
	r->run_done = 1u;
	post_id(a, r);
}

static void set_mode(struct app *a, enum app_mode m)
{
	if (a->mode == m)
		return;
	if (a->mode == APP_EXPERIMENT && a->exp.state == EXP_ABORTED)
		exp_flush(a);
	if (a->mode == APP_EXPERIMENT)
		end_id_run(a);
	if (a->mode == APP_EXPERIMENT && a->exp_ack_pending) {
		/* the final answer to the experiment command: ACCEPTED when it
		 * finished, FAILED when it was aborted (the experiment sets final_result) */
		enum app_result r = a->exp.final_result == APP_ACCEPTED ? APP_ACCEPTED : APP_FAILED;
		struct app_event e = {.kind = APP_EV_CMD_DONE, .cmd = APP_CMD_EXPERIMENT, .result = (uint8_t)r,
				      .progress = r == APP_ACCEPTED ? 100 : 0, .origin = a->exp_origin};
		outbox_post(&a->outbox, &e);
		a->exp_ack_pending = false;
	}
	a->mode = m;
	app_status(a, APP_SEV_INFO, "Mode %s", app_mode_name(m));
	envelope_on_mode(a);
}

/* ---------------------------------------------------------------- parameters -> modules */

/* Parameters -> controllers, mixer and throttle map. Not in the 90 Hz step: a parameter
 * change (PARAM_SET, a parameter load, identification results) sets params_dirty and
 * app_settle() runs this between frames (see "between frames" below). */
static void sync_params(struct app *a)
{
	const struct app_params *p = &a->p;
	struct att_ctrl_params ap = att_ctrl_params_default();
	ap.wn_rps = vec3_make(sc_from_float(p->att_wn_rp), sc_from_float(p->att_wn_rp),
			      sc_from_float(p->att_wn_yaw));
	ap.zeta = vec3_make(sc_from_float(p->att_zeta), sc_from_float(p->att_zeta),
			    sc_from_float(p->att_zeta));
	ap.ki_rps = vec3_make(sc_from_float(p->att_ki), sc_from_float(p->att_ki), sc_from_float(p->att_ki));
	att_ctrl_set_params(&a->att, &ap);   /* not att_ctrl_init: that would drop the integral */

	struct guid_params gp = guid_params_default();
	gp.tko_vel_mps = sc_from_float(p->nav_tko_vel);
	gp.land_vel_mps = sc_from_float(p->nav_land_vel);
	gp.touch_down_s = sc_from_float(p->nav_touch_down_s);
	a->guid.p = gp;

	struct pos_ctrl_params pp = pos_ctrl_params_default();
	pp.pos_gain_rps = sc_from_float(p->pos_gain);
	pp.vel_gain_rad_mps = sc_from_float(p->pos_vel_gain);
	pp.tilt_max_rad = sc_from_float(p->att_tilt_max * DEG_F);
	a->pos = pp;

	struct alt_ctrl_params lp = alt_ctrl_params_default();
	lp.wn_rps = sc_from_float(p->alt_wn);
	lp.zeta = sc_from_float(p->alt_zeta);
	lp.ki_rps = sc_from_float(p->alt_ki);
	lp.g_mps2 = sc_from_float(p->veh_grav);
	lp.vz_max_up_mps = sc_from_float(fmaxf(sc_to_float(lp.vz_max_up_mps), p->nav_tko_vel));
	lp.vz_max_down_mps = sc_from_float(fmaxf(sc_to_float(lp.vz_max_down_mps), p->nav_land_vel));
	lp.f_max_n = sc_from_float(8.0f * p->veh_kf * p->mot_thr_max);
	alt_ctrl_set_params(&a->alt, &lp);   /* keeps the integral */

	a->ps.inertia_kgm2 = vec3_make(sc_from_float(p->veh_ixx), sc_from_float(p->veh_iyy),
				       sc_from_float(p->veh_izz));
	a->ps.mass_kg = sc_from_float(p->veh_mass);
	a->ps.thr_max = sc_from_float(p->mot_thr_max);

	/* the rotors' effectiveness: the mixer allocates around a weak rotor (its box), the
	 * throttle map gives it the throttle for its thrust */
	const float scale[THRMAP_ROTORS] = {p->mot_scale1, p->mot_scale2, p->mot_scale3, p->mot_scale4,
					    p->mot_scale5, p->mot_scale6, p->mot_scale7, p->mot_scale8};
	struct mixer_params mp;
	mixer_default_params(&mp);
	for (int j = 0; j < MIXER_N_ROTORS; j++) {
		mp.scale[j] = sc_from_float(scale[j]);
		if (!(scale[j] > 0.0f))   /* 0: a failed rotor, left out of the allocation */
			mp.rotor_mask &= (uint8_t)~(1u << j);
	}
	mp.arm_l_m = sc_from_float(p->veh_arm_l);
	mp.k_f_n = sc_from_float(p->veh_kf);
	mp.k_tau_nm = sc_from_float(p->veh_ktau);
	mp.t_min = SC(0.0);
	mp.t_max = sc_from_float(p->mot_thr_max);
	mp.mode = p->mix_mode >= 0.5f ? MIXER_MODE_PRIORITY : MIXER_MODE_CLIP;
	mixer_set_params(&a->mix, &mp);   /* recomputes only when something changed */

	struct thrmap_params tp = {sc_from_float(p->veh_kf), sc_from_float(p->mot_curve), {0}};
	for (int j = 0; j < THRMAP_ROTORS; j++)
		tp.scale[j] = sc_from_float(scale[j]);
	thrmap_init(&a->map, &tp);
	rotor_guard_sync(&a->rf, p);
	envelope_model_sync(a);
}

static void reset_control(struct app *a)
{
	att_ctrl_reset(&a->att);
	alt_ctrl_reset(&a->alt, SC_ZERO);
}

void app_init(struct app *a, const struct hal *hal)
{
	memset(a, 0, sizeof *a);
	a->hal = hal;
	params_defaults(&a->p);
	origin_init(&a->orig);
	struct att_ctrl_params ap = att_ctrl_params_default();
	att_ctrl_init(&a->att, &ap);
	struct guid_params gp = guid_params_default();
	guid_init(&a->guid, &gp);
	struct alt_ctrl_params lp = alt_ctrl_params_default();
	alt_ctrl_init(&a->alt, &lp);
	struct mixer_params mp;
	mixer_default_params(&mp);
	mixer_init(&a->mix, &mp);
	char why[64];
	if (app_params_load(a, why, sizeof why) != APP_ACCEPTED)
		hal_reportf(a->hal, "params: %s (defaults in use)", why);
	envelope_init(a);
	a->exp.mix = &a->mix;   /* the inertia phases take the body torque through the mixer's Gamma */
	rotor_guard_init(&a->rf);
	sync_params(a);
	a->params_dirty = false;
	a->mode = APP_DISARMED;
	a->log.q_sp[0] = 1.0f;
}

/* ---------------------------------------------------------------- parameters: storage */

static void report_line(void *ctx, unsigned line, const char *why)
{
	struct app *a = ctx;
	app_status(a, APP_SEV_WARNING, "params line %u: %s, default kept", line, why);
}

enum app_result app_params_load(struct app *a, char *why, size_t cap)
{
	char *text = a->param_text;
	long n = hal_param_fetch(a->hal, text, sizeof a->param_text);
	if (n < 0) {
		snprintf(why, cap, "no parameter file");
		return APP_FAILED;
	}
	struct app_params p = a->p;
	unsigned bad = params_parse(&p, text, (size_t)n, report_line, a);
	a->p = p;
	a->params_dirty = true;
	if (bad)
		hal_reportf(a->hal, "params: %u damaged line(s) ignored", bad);
	return APP_ACCEPTED;
}

enum app_result app_params_save(struct app *a, char *why, size_t cap)
{
	char *text = a->param_text;
	size_t n = params_format(&a->p, text, sizeof a->param_text);
	if (!n || hal_param_store(a->hal, text, n) != 0) {
		snprintf(why, cap, "Parameter save failed");
		return APP_FAILED;
	}
	return APP_ACCEPTED;
}

const char *app_param_write(struct app *a, size_t index, float value)
{
	if (index >= param_count)
		return "unknown parameter";
	if (param_defs[index].flags & PARAM_READONLY)
		return "read-only: written by the autopilot (identification, flight envelope)";
	if (a->mode == APP_EXPERIMENT && (param_defs[index].flags & PARAM_LOCKED))
		return "locked while an experiment runs";
	enum param_set_result r = params_set(&a->p, index, value);
	if (r != PARAM_OK)
		return params_set_result_text(r);
	a->params_dirty = true;
	return NULL;
}

/* ---------------------------------------------------------------- commands */

enum app_result app_cmd_arm(struct app *a, bool arm, bool force, char *why, size_t cap)
{
	if (arm) {
		if (a->mode != APP_DISARMED)
			return APP_ACCEPTED;
		if (!a->have_step || !a->link_ok) {
			snprintf(why, cap, "Arm refused: no complete X-Plane frames");
			return APP_BUSY;
		}
		if (tilt_deg(&a->fr) > 30.0f && !force) {
			snprintf(why, cap, "Arm refused: tilted %.0f deg", (double)tilt_deg(&a->fr));
			return APP_BUSY;
		}
		a->actuating = true;
		scalar_t pos[3];
		frame_pos(&a->fr, pos);
		guid_arm(&a->guid, pos, frame_yaw(&a->fr));
		reset_control(a);
		set_mode(a, APP_IDLE);
		return APP_ACCEPTED;
	}
	if (a->mode == APP_DISARMED)
		return APP_ACCEPTED;
	if (app_flying(a) && !force) {
		snprintf(why, cap, "Disarm refused: flying (land first, or force)");
		return APP_BUSY;
	}
	if (a->mode == APP_EXPERIMENT)
		exp_abort(&a->exp, "disarmed");
	set_thr_all(a, 0.0f);
	set_mode(a, APP_DISARMED);
	return APP_ACCEPTED;
}

enum app_result app_cmd_takeoff(struct app *a, float height_m, app_origin origin, char *why, size_t cap)
{
	if (!isfinite(height_m) || height_m <= 0.0f)
		height_m = a->p.nav_tko_alt;
	if (height_m < 0.5f || height_m > 100.0f) {
		snprintf(why, cap, "Takeoff refused: height %.1f m not in [0.5, 100]", (double)height_m);
		return APP_DENIED;
	}
	if (a->mode == APP_DISARMED) {
		snprintf(why, cap, "Takeoff refused: not armed");
		return APP_BUSY;
	}
	if (a->mode == APP_EXPERIMENT) {
		snprintf(why, cap, "Takeoff refused: experiment running");
		return APP_BUSY;
	}
	scalar_t pos[3];
	frame_pos(&a->fr, pos);
	if (!guid_takeoff(&a->guid, guid_mode_of(a->mode), sc_from_float(height_m), pos, frame_yaw(&a->fr)))
		return APP_ACCEPTED;   /* a retry: nothing changes */
	if (a->mode == APP_IDLE)
		reset_control(a);
	app_status(a, APP_SEV_INFO, "Takeoff to %.2f m", (double)height_m);
	envelope_on_command(a, APP_CMD_TAKEOFF, origin);
	a->mode = APP_HOLD;   /* so that set_mode reports the change even from HOLD */
	set_mode(a, APP_TAKEOFF);
	return APP_ACCEPTED;
}

enum app_result app_cmd_land(struct app *a, app_origin origin, char *why, size_t cap)
{
	(void)why;
	(void)cap;
	switch (a->mode) {
	case APP_DISARMED:
	case APP_LAND:
		return APP_ACCEPTED;
	case APP_IDLE:
		set_thr_all(a, 0.0f);
		set_mode(a, APP_DISARMED);
		return APP_ACCEPTED;
	case APP_EXPERIMENT:
		exp_abort(&a->exp, "landing");
		/* fall through */
	case APP_TAKEOFF:
	case APP_HOLD:
		guid_land(&a->guid, sc_from_float(a->fr.pos_i_m[2]));
		envelope_on_command(a, APP_CMD_LAND, origin);
		set_mode(a, APP_LAND);
		return APP_ACCEPTED;
	}
	return APP_FAILED;
}

enum app_result app_cmd_experiment(struct app *a, float id_f, app_origin origin, char *why, size_t cap)
{
	if (!isfinite(id_f) || id_f != floorf(id_f) || id_f < 0.0f || id_f > 6.0f) {
		snprintf(why, cap, "Experiment %g unknown (1..6, 0 = stop)", (double)id_f);
		return APP_DENIED;
	}
	int id = (int)id_f;
	if (id == 0) {
		if (a->mode == APP_EXPERIMENT) {
			exp_abort(&a->exp, "stopped by command");
			set_mode(a, APP_HOLD);
		}
		return APP_ACCEPTED;
	}
	if (a->mode == APP_EXPERIMENT) {
		if (a->exp.id == id)
			return APP_IN_PROGRESS;   /* a retry: still running */
		snprintf(why, cap, "Experiment %d running", a->exp.id);
		return APP_BUSY;
	}
	if (!app_hovering(a)) {
		snprintf(why, cap, "Experiment %d refused: not hovering", id);
		return APP_DENIED;
	}
	if (envelope_oscillating(a)) {   /* its excitation would take the tilt past the limit */
		snprintf(why, cap, "Experiment %d refused: attitude oscillating (%.0f deg/s rms)", id,
			 (double)envelope_osc_rms_dps(a));
		return APP_BUSY;
	}
	/* every experiment regresses on each rotor's measured thrust and torque (X-Plane's rows
	 * 35 and 36): without them it cannot run, and says so rather than fit zeros */
	const uint32_t rows = HAL_FRAME_THRUST | HAL_FRAME_TORQUE;
	if ((a->fr.valid & rows) != rows) {
		snprintf(why, cap, "Experiment %d refused: no rotor thrust/torque rows (IMU-only identification not available)",
			 id);
		return APP_DENIED;
	}
	envelope_seed_kf(a, id);
	int r = exp_start(&a->exp, id, &a->p, why, cap);
	if (r == APP_ACCEPTED || r == APP_IN_PROGRESS) {
		a->id_run.run_id++;
		a->id_run.count = 0;
		a->id_run.done = false;
		set_mode(a, APP_EXPERIMENT);
		a->exp_ack_pending = true;
		a->exp_origin = origin;
		r = APP_IN_PROGRESS;
	}
	return r;
}

/* ---------------------------------------------------------------- the control step */

/* Results are applied as soon as the experiment posts them (at the frame
 * boundary after its step: app_settle), not only when it finishes: in the full
 * sequence (experiment 6) the validation after identification and the inertia
 * phases must already fly with the new VEH_* values. Applied results are
 * broadcast as PARAM_VALUE, removed from the list, and saved to the parameter
 * file by app_tick (save_pending). */
_Static_assert(APP_OUTBOX_LEN >= EXP_MAX_RESULTS + EXP_MAX_IDS + 8,
	       "the outbox holds a turn's results and the status lines of the same pass");

static void apply_results(struct app *a)
{
	int n = a->exp.n_results < EXP_MAX_RESULTS ? a->exp.n_results : EXP_MAX_RESULTS;
	if (n <= 0)
		return;
	for (int i = 0; i < n; i++) {
		int idx = a->exp.results[i].param_index;
		if (idx < 0 || (size_t)idx >= param_count)
			continue;
		enum param_set_result r = params_set(&a->p, (size_t)idx, a->exp.results[i].value);
		if (r != PARAM_OK)
			app_status(a, APP_SEV_WARNING, "%s not applied: %s", param_defs[idx].name,
				   params_set_result_text(r));
		struct app_event e = {.kind = APP_EV_PARAM, .param_index = (uint16_t)idx};
		outbox_post(&a->outbox, &e);
	}
	a->exp.n_results = 0;
	/* bumpless without more: the height controller's hover thrust is 8 VEH_KF u_h with
	 * the learned (physical) u_h, so a new k_f leaves the throttles where they were */
	a->params_dirty = true;
	a->save_pending = true;
}

/* ---------------------------------------------------------------- between frames
 *
 * The 90 Hz step (control_step) only reads what the parameters imply: gains, mixer
 * (pseudo-inverse, facets) and throttle map. Whatever changes them runs between
 * frames, after the frame's actuation has gone out and before the next frame's step:
 *   app_settle()  publishes what the last step's envelope noted (envelope_publish: a
 *                 HOLD entry's HOV_* and status line, the tracked k_f's KFT_* each second
 *                 and a VEH_KF refresh), ends an experiment phase that ended in the last step and starts the
 *                 next (exp_turn: estimates, verdicts, status lines), applies results the
 *                 experiment posted (PARAM_VALUE for each) and,
 *                 when a parameter changed (params_dirty), rebuilds gains, mixer and
 *                 throttle map (sync_params; the mixer's set-up is ~370,000
 *                 instructions on Cortex-M4F, ~75 steps' worth). It runs first
 *                 in app_tick (the main loop's pass after the frame), and as a
 *                 fallback at the start of app_on_frame and app_on_ground, so that no
 *                 step, command or PARAM_SET ever sees a result half applied or the
 *                 old mixer beside new parameters (the mixer and throttle map are
 *                 rebuilt at a frame boundary);
 *   app_tick()    then writes the parameter file when results were applied
 *                 (save_pending).
 * On an MCU the step runs in the frame interrupt (or a high-priority task) and this in a
 * low-priority task: it would build a shadow struct mixer / struct thrmap from a copy
 * of the parameters and swap a pointer at a frame boundary (the step reads the pointer
 * once at its start), so that the step is never delayed by the set-up and never reads a
 * half-built mixer. That double buffer costs a second struct mixer (2.7 KB, more than the
 * 4 KB core RAM budget leaves) and is not implemented here: the host runs both paths in
 * one thread, so a rebuild between frames is already atomic for the step. If the
 * low-priority work has not finished when the next frame comes (or, on the host, several
 * frames arrive in one pass of the main loop), the step starts with app_settle and waits
 * for it: a late step, never an inconsistent one. */
void app_settle(struct app *a)
{
	envelope_publish(a);        /* what the last step noted: HOV_* of a HOLD entry, KFT_*, a VEH_KF refresh */
	envelope_torque_scale(a);   /* the torque demands' gain, from the hover throttle learned so far */
	exp_turn(&a->exp, &a->p);   /* a phase that ended in the last step: close it, start the next */
	if (a->exp.n_ids > 0)
		publish_ids(a);
	if (a->exp.n_results > 0)
		apply_results(a);
	if (a->params_dirty) {
		a->params_dirty = false;
		sync_params(a);
	}
}

static void experiment_step(struct app *a, float dt)
{
	/* the rotor torques: only the rotor and inertia phases read them */
	const scalar_t *torque = NULL;
	if (exp_reads_torque(&a->exp)) {
#if OCTO_FIXED
		for (int j = 0; j < HAL_ROTORS; j++)
			a->fs.rotor_torque_nm[j] = sc_from_float(a->fr.rotor_torque_nm[j]);
#endif
		torque = app_in(a)->rotor_torque_nm;
	}
	/* the thrusts allocated last step: the mixer's output (the log's rotor_f in floats) */
	struct exp_input in = {&a->fr, app_in(a)->rotor_thrust_n, torque,
			       app_in(a)->rate_b_rps, dt, &a->p, a->wrench_dem, a->mix_out.f_n,
			       app_thr_sc(a), a->dt_frame};
	enum exp_state st = exp_step(&a->exp, &in, &a->exp_out);
	if (st != EXP_RUNNING) {
		memset(&a->exp_out, 0, sizeof a->exp_out);
		set_mode(a, APP_HOLD);
	}
}

/* The frame's float inputs as scalars, once per step (the fixed build; the rotor torques
 * only for the experiments: experiment_step). */
static void frame_to_sc(struct app *a)
{
#if OCTO_FIXED
	const struct hal_sensor_frame *f = &a->fr;
	struct app_frame_sc *s = &a->fs;
	for (int i = 0; i < 4; i++)
		s->q_ib[i] = sc_from_float(f->q_ib[i]);
	for (int i = 0; i < 3; i++) {
		s->rate_b_rps[i] = sc_from_float(f->rate_b_rps[i]);
		s->pos_i_m[i] = sc_from_float(f->pos_i_m[i]);
		s->vel_i_mps[i] = sc_from_float(f->vel_i_mps[i]);
	}
	for (int j = 0; j < HAL_ROTORS; j++)
		s->rotor_thrust_n[j] = sc_from_float(f->rotor_thrust_n[j]);
#else
	(void)a;
#endif
}

static void control_step(struct app *a, float dt)
{
	const struct app_params *p = &a->p;
	frame_to_sc(a);
	const scalar_t *pos = app_in(a)->pos_i_m, *vel = app_in(a)->vel_i_mps, *qf = app_in(a)->q_ib;
	struct quat q = quat_normalize((struct quat){qf[0], qf[1], qf[2], qf[3]});

	memset(&a->exp_out, 0, sizeof a->exp_out);
	struct guid_input gi = {pos[2], vel[2], FROM_FLOAT_KEPT(a, dt_kept, dt), false};
	if (a->mode == APP_DISARMED || a->mode == APP_IDLE) {
		set_thr_all(a, a->mode == APP_IDLE ? p->mot_thr_idle : 0.0f);
		reset_control(a);
		guid_ground(&a->guid, gi.z_m, a->mode == APP_IDLE);
		memset(a->wrench_dem, 0, sizeof a->wrench_dem);
		memset(a->log.rotor_f, 0, sizeof a->log.rotor_f);
		a->mix_out.limits = 0;
		return;
	}

	envelope_limits(a, dt);   /* take-off and landing time limits */

	/* guidance: set points and mode transitions (take-off ends once the hover is learned) */
	gi.hold_ready = a->mode == APP_TAKEOFF && envelope_hover_ready(a);
	uint32_t ev = guid_update(&a->guid, guid_mode_of(a->mode), &gi);
	if (ev & GUID_HOLD_REACHED)
		set_mode(a, APP_HOLD);
	if (ev & GUID_LANDED) {
		set_thr_all(a, 0.0f);
		app_status(a, APP_SEV_INFO, "Landed");
		set_mode(a, APP_DISARMED);
		return;
	}

	/* horizontal: hold the position of the take-off through small tilts (level near the
	 * ground during take-off) */
	struct pos_ctrl_input pi = {
		.pos_sp_m = {a->guid.pos_sp_m[0], a->guid.pos_sp_m[1]},
		.pos_m = {pos[0], pos[1]},
		.vel_mps = {vel[0], vel[1]},
		.q_b2i = q,
	};
	struct pos_ctrl_output po = pos_ctrl_update(&a->pos, &pi);
	if (guid_level_only(&a->guid, guid_mode_of(a->mode), gi.z_m))
		po.roll_rad = po.pitch_rad = SC_ZERO;
	if (!a->yaw_half_ok || a->guid.yaw_sp_rad != a->yaw_half_of) {
		a->yaw_half_of = a->guid.yaw_sp_rad;
		a->yaw_half = quat_yaw_half(a->yaw_half_of);
		a->yaw_half_ok = true;
	}
	struct quat q_sp = quat_from_euler_yh(po.roll_rad, po.pitch_rad, a->yaw_half);
	a->log.q_sp[0] = sc_to_float(q_sp.w);
	a->log.q_sp[1] = sc_to_float(q_sp.x);
	a->log.q_sp[2] = sc_to_float(q_sp.y);
	a->log.q_sp[3] = sc_to_float(q_sp.z);

	/* attitude and height control; what the allocation cut on the previous step stops
	 * their integrals from winding further that way */
	uint8_t short_pos, short_neg;
	mixer_shortfall(&a->mix_out, &short_pos, &short_neg);
	struct att_ctrl_input ai = {
		.q_sp_b2i = q_sp,
		.rate_ff_b = vec3_zero(),
		.q_b2i = q,
		.rate_b_rps = vec3_make(app_in(a)->rate_b_rps[0], app_in(a)->rate_b_rps[1],
					app_in(a)->rate_b_rps[2]),
		.inertia_kgm2 = a->ps.inertia_kgm2,
		.dt_s = gi.dt_s,
		.alloc_short_pos = (uint8_t)(short_pos >> 1),
		.alloc_short_neg = (uint8_t)(short_neg >> 1),
	};
	struct vec3 tau;
	att_ctrl_update(&a->att, &ai, &tau);
	tau = envelope_torque(a, tau);   /* the throttle map's error at hover taken out */
	envelope_osc_step(a);            /* the rates into the oscillation guard's second */
	scalar_t cos_tilt = quat_body_z_up(q);
	struct alt_ctrl_input li = {
		.z_sp_m = a->guid.z_sp_m,
		.vz_ff_mps = a->guid.vz_ff_mps,
		.z_m = gi.z_m,
		.vz_mps = gi.vz_mps,
		.q_b2i = q,
		.mass_kg = a->ps.mass_kg,
		.dt_s = gi.dt_s,
		.hover_f_n = envelope_hover_f(a, gi.dt_s, cos_tilt),
		.alloc_short_up = (short_pos & 1u) != 0,
		.alloc_short_down = (short_neg & 1u) != 0,
	};
	scalar_t fz = alt_ctrl_update(&a->alt, &li);
	a->wrench_dem[0] = sc_to_float(fz);
	a->wrench_dem[1] = sc_to_float(tau.x);
	a->wrench_dem[2] = sc_to_float(tau.y);
	a->wrench_dem[3] = sc_to_float(tau.z);

	/* experiment: excitation on top of the hover control */
	if (a->mode == APP_EXPERIMENT) {
		/* tilt > EXP_TILT_ABORT_DEG, without acosf: the body's z axis vs cos(limit) */
		if (cos_tilt < sc_from_float(cosf(EXP_TILT_ABORT_DEG * DEG_F))) {
			exp_abort(&a->exp, "attitude limit");
		}
		experiment_step(a, dt);
	}

	/* allocation and throttle map, in scalars (the same float operations in the float
	 * build; integer ones in the fixed build); outside an experiment the excitation is zero
	 * (cleared above) and adds nothing */
	bool excited = a->mode == APP_EXPERIMENT;
	scalar_t demand[MIXER_N_AXES] = {fz, tau.x, tau.y, tau.z};
	if (excited) {
		demand[0] = sc_add(demand[0], a->exp_out.f_delta);
		for (int i = 0; i < 3; i++)
			demand[i + 1] = sc_add(demand[i + 1], a->exp_out.tau_delta[i]);
	}
	mixer_update(&a->mix, demand, &a->mix_out);
	scalar_t thr[HAL_ROTORS];
	a->thr_clamped = thrmap_update(&a->map, a->mix_out.f_n, thr, HAL_ROTORS);
	const scalar_t thr_max = a->ps.thr_max;   /* read once: the stores below are floats too */
	for (int j = 0; j < HAL_ROTORS; j++) {
		a->log.rotor_f[j] = sc_to_float(a->mix_out.f_n[j]);
		scalar_t t = excited ? sc_add(thr[j], a->exp_out.thr_delta[j]) : thr[j];
		t = sc_clamp(sc_isfinite(t) ? t : SC_ZERO, SC_ZERO, thr_max);
		a->thr[j] = sc_to_float(t);
#if OCTO_FIXED
		a->thr_sc[j] = t;   /* sc_from_float(thr[j]) exactly: a throttle in [0, 1] is a float */
#endif
	}
}

/* ---------------------------------------------------------------- per frame */

/* Float arrays of the log by assignment, not memcpy: the library call costs more than the
 * copy for these few words on Cortex-M0 (alignment checks, a loop, no inlining). copy4n
 * loads four words before it stores them, which the compiler keeps as a plain copy (a loop
 * of single copies it would turn back into a memcpy call). */
static inline void copy3(float d[3], const float s[3])
{
	d[0] = s[0];
	d[1] = s[1];
	d[2] = s[2];
}

static inline void copy4n(float *restrict d, const float *restrict s, int n)
{
	for (int i = 0; i < n; i += 4) {
		float x0 = s[i], x1 = s[i + 1], x2 = s[i + 2], x3 = s[i + 3];
		d[i] = x0;
		d[i + 1] = x1;
		d[i + 2] = x2;
		d[i + 3] = x3;
	}
}

/* The excitation's throttles as floats. A dither gives the rotors a few values and their
 * negations (the rotor experiment: two magnitudes per step), and a Q16.16 value and its
 * negation convert to floats of opposite sign: each magnitude is converted once (the last
 * two kept). */
static void excitation_to_float(float out[HAL_ROTORS], const scalar_t d[HAL_ROTORS])
{
#if OCTO_FIXED
	uint32_t m0 = 0u, m1 = 0u;
	float f0 = 0.0f, f1 = 0.0f;
	for (int j = 0; j < HAL_ROTORS; j++) {
		scalar_t v = d[j];
		uint32_t m = v < 0 ? 0u - (uint32_t)v : (uint32_t)v;
		float f;
		if (m == m0) {
			f = f0;
		} else if (m == m1) {
			f = f1;
		} else if (m > (uint32_t)INT32_MAX) {   /* INT32_MIN: no positive twin */
			out[j] = sc_to_float(v);
			continue;
		} else {
			f = sc_to_float((scalar_t)m);
			m1 = m0;
			f1 = f0;
			m0 = m;
			f0 = f;
		}
		out[j] = v < 0 ? -f : f;
	}
#else
	for (int j = 0; j < HAL_ROTORS; j++)
		out[j] = d[j];
#endif
}

#define LOG_LEN(field) (sizeof ((struct app_log_frame *)0)->field / sizeof(float))
_Static_assert(LOG_LEN(q) == 4 && LOG_LEN(rotor_thrust) == HAL_ROTORS && LOG_LEN(rotor_torque) == HAL_ROTORS &&
		       LOG_LEN(rotor_speed) == HAL_ROTORS &&
		       LOG_LEN(throttle) == HAL_ROTORS && LOG_LEN(est) == EXP_MAX_EST && LOG_LEN(est_sd) == EXP_MAX_EST &&
		       HAL_ROTORS % 4 == 0 && EXP_MAX_EST % 4 == 0,
	       "the log's arrays are copied whole, four floats at a time");

static void fill_log(struct app *a, bool stepped, float dt)
{
	struct app_log_frame *l = &a->log;
	const struct hal_sensor_frame *f = &a->fr;
	/* every field is set below but q_sp and rotor_f, which the step writes (the platform
	 * serialises the record field by field, so padding is not cleared on every frame) */
	l->seq = f->seq;
	l->t = f->t_s;
	l->dt = stepped ? dt : 0.0f;
	l->stepped = stepped;
	l->armed = a->mode != APP_DISARMED;
	l->link_ok = a->link_ok;
	l->mode = (int8_t)a->mode;
	l->valid = (int32_t)f->valid;
	copy4n(l->q, f->q_ib, 4);
	copy3(l->rate_b, f->rate_b_rps);
	copy3(l->pos_i, f->pos_i_m);
	copy3(l->vel_i, f->vel_i_mps);
	copy4n(l->rotor_thrust, f->rotor_thrust_n, HAL_ROTORS);
	copy4n(l->rotor_torque, f->rotor_torque_nm, HAL_ROTORS);
	copy3(l->accel_b, f->accel_b_g);
	copy4n(l->rotor_speed, f->rotor_speed_rps, HAL_ROTORS);
	l->z_sp = TO_FLOAT_KEPT(a, 0, a->guid.z_sp_m);
	l->vz_ff = TO_FLOAT_KEPT(a, 1, a->guid.vz_ff_mps);
	l->pos_sp[0] = TO_FLOAT_KEPT(a, 2, a->guid.pos_sp_m[0]);
	l->pos_sp[1] = TO_FLOAT_KEPT(a, 3, a->guid.pos_sp_m[1]);
	l->f_dem = a->wrench_dem[0];
	for (int i = 0; i < 3; i++)
		l->tau_dem[i] = a->wrench_dem[i + 1];
	l->f_alloc = sc_to_float(a->mix_out.achieved[0]);
	for (int i = 0; i < 3; i++)
		l->tau_alloc[i] = sc_to_float(a->mix_out.achieved[i + 1]);
	excitation_to_float(l->excitation, a->exp_out.thr_delta);
	copy4n(l->throttle, a->thr, HAL_ROTORS);
	l->att_flags = (int32_t)a->att.flags;
	l->alt_flags = (int32_t)a->alt.flags;
	l->mix_flags = (int32_t)a->mix_out.limits;
	l->thr_clamped = (int32_t)a->thr_clamped;
	l->exp_id = (int8_t)(a->mode == APP_EXPERIMENT ? a->exp.id : 0);
	l->exp_phase = (int8_t)a->exp.phase;
	l->exp_progress = a->exp.progress;
	copy4n(l->est, a->exp.est, EXP_MAX_EST);
	copy4n(l->est_sd, a->exp.est_sd, EXP_MAX_EST);
	l->kf = a->p.veh_kf;
	l->ktau = a->p.veh_ktau;
	l->inertia[0] = a->p.veh_ixx;
	l->inertia[1] = a->p.veh_iyy;
	l->inertia[2] = a->p.veh_izz;
	l->mass = a->p.veh_mass;
	if (a->env.kft.started) {
		l->kft = sc_to_float(a->env.kft.k);
		l->kft_sd = sc_to_float(kf_track_sd(&a->env.kft));
	} else {
		l->kft = l->kft_sd = 0.0f;
	}
}

static void link_back(struct app *a, float gap_s)
{
	a->link_ok = true;
	if (!a->link_ever) {
		a->link_ever = true;
		app_status(a, APP_SEV_INFO, "X-Plane link up");
		return;
	}
	app_status(a, APP_SEV_WARNING, "X-Plane link back after %.2f s", (double)gap_s);
	if (gap_s > a->p.fs_land_after && app_flying(a) && a->mode != APP_LAND) {
		app_status(a, APP_SEV_CRITICAL, "Link was lost for more than %.1f s: landing",
			   (double)a->p.fs_land_after);
		char why[8];
		app_cmd_land(a, APP_ORIGIN_NONE, why, sizeof why);
	}
}

static void abort_experiment(struct app *a, const char *reason)
{
	if (a->mode != APP_EXPERIMENT)
		return;
	exp_abort(&a->exp, reason);
	memset(&a->exp_out, 0, sizeof a->exp_out);
	set_mode(a, APP_HOLD);
}

static void link_lost(struct app *a, const char *what)
{
	a->link_ok = false;
	app_status(a, APP_SEV_CRITICAL, "X-Plane link lost (%s)", what);
	abort_experiment(a, "X-Plane link lost");
}

/* One line per gap, or, within a wall second of the last, a count folded into the next line
 * (the gap's consequences, an aborted experiment or a landing, are not delayed). */
static void say_gap(struct app *a, float gap_s, uint64_t now_us)
{
	if (a->gap_said_us != 0 && now_us - a->gap_said_us < 1000000u) {
		a->gaps_unsaid++;
		a->gap_max_unsaid_s = fmaxf(a->gap_max_unsaid_s, gap_s);
		return;
	}
	if (a->gaps_unsaid > 0)
		app_status(a, APP_SEV_WARNING, "X-Plane frames missing: %u gaps, longest %.2f s",
			   (unsigned)a->gaps_unsaid + 1u, (double)fmaxf(gap_s, a->gap_max_unsaid_s));
	else
		app_status(a, APP_SEV_WARNING, "X-Plane frames missing for %.2f s", (double)gap_s);
	a->gap_said_us = now_us > 0u ? now_us : 1u;
	a->gaps_unsaid = 0;
	a->gap_max_unsaid_s = 0.0f;
}

/* The time of k frames (k >= 1 since the last step): k frame periods, never a difference of
 * plant stamps. The period is measured on the platform's integer clock, over the first step
 * and then every PERIOD_FRAMES frames (a difference of integers first), and moves half way
 * to a measurement that differs from it by more than the microseconds can tell (a quarter
 * off: all the way); so it stays the same from step to step while the clock keeps time. */
static float step_gap(struct app *a, const struct hal_sensor_frame *f, uint64_t k)
{
	if (!a->have_step) {
		a->per_n = f->frame_n;
		a->per_us = f->t_us;
		return FIRST_DT_S;
	}
	uint64_t span = f->frame_n - a->per_n;
	if (!(a->dt_frame > 0.0f) || span >= PERIOD_FRAMES) {
		float p = (float)(f->t_us - a->per_us) * 1e-6f / (float)span, d = p - a->dt_frame;
		if (!(a->dt_frame > 0.0f) || fabsf(d) > 0.25f * a->dt_frame)
			a->dt_frame = p;
		else if (fabsf(d) * (float)span > 2e-6f)
			a->dt_frame += 0.5f * d;
		a->per_n = f->frame_n;
		a->per_us = f->t_us;
	}
	return (float)k * a->dt_frame;
}

void app_on_frame(struct app *a, const struct hal_sensor_frame *f)
{
	app_settle(a);   /* normally done by app_tick already (nothing left here) */
	uint64_t now = hal_wall_us(a->hal);
	a->fr = *f;
	if (origin_correct(&a->orig, &a->fr))
		app_status(a, APP_SEV_INFO, "Plant moved its local origin (%.0f m): position re-referenced",
			   (double)sqrtf(a->orig.last_step[0] * a->orig.last_step[0] +
					 a->orig.last_step[1] * a->orig.last_step[1] +
					 a->orig.last_step[2] * a->orig.last_step[2]));
	a->have_frame = true;
	if (!a->link_ok)
		link_back(a, a->link_ever ? (float)(now - a->link_lost_at_us) * 1e-6f : 0.0f);
	a->wall_last_frame_us = now;

	bool complete = (f->valid & HAL_FRAME_NEEDED) == HAL_FRAME_NEEDED;
	float dt = 0.0f;
	bool stepped = false;
	if (complete) {
		/* frames since the last step, as the platform counts them (lost ones included; a
		 * frame without a newer count, a duplicate or an older one, brings none) */
		uint64_t k = !a->have_step ? 1u : f->frame_n > a->n_prev ? f->frame_n - a->n_prev : 0u;
		float gap = k > 0u ? step_gap(a, f, k) : 0.0f;
		if (app_f_lt(0.0f, gap)) {   /* the frame's comparisons: fcmp.h */
			bool missing = a->have_step && app_f_lt(a->p.fs_link_to, gap);
			if (missing) {
				/* frames missing in plant time (lockstep bursts, reload) */
				say_gap(a, gap, now);
				abort_experiment(a, "X-Plane frames missing");
				if (gap > a->p.fs_land_after && app_flying(a) && a->mode != APP_LAND) {
					char why[8];
					app_cmd_land(a, APP_ORIGIN_NONE, why, sizeof why);
				}
			}
			dt = app_f_lt(MAX_DT_S, gap) ? MAX_DT_S : gap;
			a->n_prev = f->frame_n;
			a->have_step = true;
			rotor_guard_step(a, dt);   /* a failed rotor: its scale set, the vehicle told to land */
			/* After frames missing the controllers were out of the loop (their last
			 * command held): they take one frame period, not the gap, so that their
			 * integrators do not wind up over time they could not act in. */
			control_step(a, missing && a->dt_frame > 0.0f ? a->dt_frame : dt);
			a->steps++;
			stepped = true;
		}
	}
	/* One actuation per frame that brings a time not answered yet: a duplicate
	 * or a reordered (older) frame is not answered again. Free-running X-Plane
	 * keeps the last command anyway; a lockstep simulator would otherwise take
	 * the extra command for its next frame and run one frame ahead of us. */
	if (a->actuating && (!a->have_actuated || a->n_actuated < f->frame_n)) {
		hal_actuate(a->hal, a->thr);
		a->have_actuated = true;
		a->n_actuated = f->frame_n;
	}
	fill_log(a, stepped, dt);
	hal_log_frame(a->hal, &a->log);
}

struct app_view app_view(const struct app *a)
{
	bool ok = a->have_step && a->link_ok;
	return (struct app_view){
		.mode = a->mode,
		.armed = a->mode != APP_DISARMED,
		.flying = app_flying(a),
		.link_ok = a->link_ok,
		.frames_ok = ok,
		.fr = &a->fr,
		.thr = a->thr,
		.params = &a->p,
		.exp_progress = a->exp.progress,
		.n_est = a->exp.n_est,
		.est_live = a->exp.est_live,
		.est_name = a->exp.est_name,
		.est = a->exp.est,
		.est_sd = a->exp.est_sd,
		.id_run = &a->id_run,
		.rotor_failed = rotor_guard_failed(&a->rf),
	};
}

bool app_next_event(struct app *a, struct app_event *e)
{
	return outbox_pop(&a->outbox, e);
}

void app_tick(struct app *a)
{
	app_settle(a);
	if (a->save_pending) {
		a->save_pending = false;
		char why[64];
		if (app_params_save(a, why, sizeof why) != APP_ACCEPTED)
			app_status(a, APP_SEV_ERROR, "%s", why);
	}
	uint64_t now = hal_wall_us(a->hal);
	uint64_t to = (uint64_t)(a->p.fs_link_to * 1e6f);
	if (a->link_ok && a->have_frame && now - a->wall_last_frame_us > to) {
		a->link_lost_at_us = a->wall_last_frame_us;
		link_lost(a, "no frames");
	}
	exp_pump(&a->exp);   /* the experiment's next status line, formatted here */
	if (a->exp.msg[0]) {
		app_status(a, a->exp.msg_severity, "%s", a->exp.msg);
		a->exp.msg[0] = 0;
	}
}
