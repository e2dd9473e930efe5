/* app.c - the autopilot's modes, commands, parameters and frame handling (see app.h); the
 * control step itself is step.c. */
#include "app.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#define FIRST_DT_S (1.0f / 90.0f)
#define MAX_DT_S 0.2f     /* longer gaps are integrated as 200 ms */
#define PERIOD_FRAMES 90u /* frames over which the frame period is measured */
#define HOVER_Z_TOL_M 0.3f
#define HOVER_TILT_DEG 5.0f
#define HOVER_VZ_MPS 0.3f
#define EXP_WAIT_S 30.0 /* plant time an experiment waits for the hover before it fails */

static float clampf(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }

const char *app_mode_name(enum app_mode m)
{
	static const char *const names[] = {"DISARMED", "IDLE", "TAKEOFF", "HOLD", "EXPERIMENT", "LAND"};
	return (unsigned)m < sizeof names / sizeof names[0] ? names[m] : "?";
}

bool app_flying(const struct app *a)
{
	return a->mode == APP_TAKEOFF || a->mode == APP_HOLD || a->mode == APP_EXPERIMENT || a->mode == APP_LAND;
}

static struct quat frame_q(const struct hal_sensor_frame *f)
{
	struct quat q = {sc_from_float(f->q_ib[0]), sc_from_float(f->q_ib[1]), sc_from_float(f->q_ib[2]),
			 sc_from_float(f->q_ib[3])};
	return quat_normalize(q);
}

static float tilt_deg(const struct hal_sensor_frame *f)
{
	float c = sc_to_float(quat_body_z_up(frame_q(f)));
	return acosf(clampf(c, -1.0f, 1.0f)) / DEG_F;
}

static scalar_t frame_yaw(const struct hal_sensor_frame *f) { return quat_yaw(frame_q(f)); }

void app_set_thr_all(struct app *a, float t)
{
	for (int j = 0; j < HAL_ROTORS; j++)
		a->thr[j] = t;
	bnd_thr_all(&a->bnd, t);
}

/* the frame's position as scalars */
static void frame_pos(const struct hal_sensor_frame *f, scalar_t pos[3])
{
	for (int i = 0; i < 3; i++)
		pos[i] = sc_from_float(f->pos_i_m[i]);
}

bool app_hovering(const struct app *a) { return !app_not_hovering(a, NULL, 0); }

/* Why the vehicle does not hover (false when it does), into why[cap] when why is given. */
bool app_not_hovering(const struct app *a, char *why, size_t cap)
{
	float dz = a->fr.pos_i_m[2] - sc_to_float(a->guid.z_target_m), vz = a->fr.vel_i_mps[2], tilt = tilt_deg(&a->fr);
	const char *w = NULL;
	if (a->mode == APP_TAKEOFF)
		w = "taking off";
	else if (a->mode == APP_HOLD && (!a->have_step || !a->link_ok))
		w = "no X-Plane frames";
	if (w || a->mode != APP_HOLD) {
		if (why)
			snprintf(why, cap, "%s%s", w ? w : "mode ", w ? "" : app_mode_name(a->mode));
		return true;
	}
	if (fabsf(dz) < HOVER_Z_TOL_M && fabsf(vz) < HOVER_VZ_MPS && tilt < HOVER_TILT_DEG)
		return false;
	if (why) {
		if (!(fabsf(dz) < HOVER_Z_TOL_M))
			snprintf(why, cap, "height %+.2f m off (%.2f)", (double)dz, (double)HOVER_Z_TOL_M);
		else if (!(fabsf(vz) < HOVER_VZ_MPS))
			snprintf(why, cap, "climbing %+.2f m/s (%.2f)", (double)vz, (double)HOVER_VZ_MPS);
		else
			snprintf(why, cap, "tilt %.1f deg (%.0f)", (double)tilt, (double)HOVER_TILT_DEG);
	}
	return true;
}

/* A status line (text of n characters and its NUL, n < APP_EVENT_TEXT): the platform's
 * report and log, and the outbox. */
static void status_out(struct app *a, enum app_severity severity, const char *text, size_t n)
{
	a->hal->report(a->hal->ctx, text);
	hal_log_event(a->hal, a->fr.t_s, (int)severity, text);
	struct app_event *e = outbox_put(&a->outbox);
	if (!e)
		return;
	e->kind = APP_EV_STATUS;
	e->severity = (uint8_t)severity;
	memcpy(e->text, text, n + 1u);
}

/* ---------------------------------------------------------------- what the step says
 *
 * In the step what is said is recorded (struct app_said, app.h) and said between frames, in
 * the order it was said. */

static void said_flush(struct app *a);

/* In the step (and not saying the ring): record, do not say. */
static bool said_defer(const struct app *a) { return a->said.in_step && !a->said.saying; }

/* The ring's next item; a full ring is said first, at once (an overflow, counted). */
static struct app_said_item *said_put(struct app *a)
{
	struct app_said *s = &a->said;
	if (s->n >= APP_SAID_LEN) {
		s->overflows++;
		said_flush(a);
	}
	struct app_said_item *it = &s->q[(s->head + s->n) % APP_SAID_LEN];
	s->n++;
	return it;
}

/* Between frames: what the last step said, first (before anything newer is said). */
static void said_out(struct app *a)
{
	if (!a->said.in_step)
		said_flush(a);
}

void app_status(struct app *a, enum app_severity severity, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	if (said_defer(a)) {
		struct app_said_item *it = said_put(a);
		it->kind = APP_SAID_LINE;
		line_vset(&it->line, (int)severity, fmt, ap);
		va_end(ap);
		return;
	}
	said_out(a);
	char text[APP_EVENT_TEXT];
	int n = vsnprintf(text, sizeof text, fmt, ap);
	va_end(ap);
	size_t len = n < 0 ? 0u : (size_t)n; /* what vsnprintf wrote, cut to the buffer */
	if (n < 0)
		text[0] = 0;
	if (len >= sizeof text)
		len = sizeof text - 1u;
	status_out(a, severity, text, len);
}

/* A status line kept as its format and values (line.h), said as app_status says it. */
static void status_line(struct app *a, const struct line *l)
{
	if (said_defer(a)) {
		struct app_said_item *it = said_put(a);
		it->kind = APP_SAID_LINE;
		it->line = *l;
		return;
	}
	said_out(a);
	char text[APP_EVENT_TEXT];
	line_format(l, text, sizeof text);
	status_out(a, (enum app_severity)l->sev, text, strlen(text));
}

void app_status2(struct app *a, enum app_severity severity, const char *s1, const char *s2)
{
	if (said_defer(a)) { /* "%s%s", without parsing the format */
		struct app_said_item *it = said_put(a);
		it->kind = APP_SAID_LINE;
		it->line.fmt = "%s%s";
		it->line.sev = (int)severity;
		it->line.kind[0] = 's';
		it->line.kind[1] = 's';
		it->line.kind[2] = 0;
		it->line.arg[0].s = s1;
		it->line.arg[1].s = s2;
		return;
	}
	said_out(a);
	char text[APP_EVENT_TEXT];
	size_t n = 0;
	for (const char *p = s1; *p && n + 1u < sizeof text; p++)
		text[n++] = *p;
	for (const char *p = s2; *p && n + 1u < sizeof text; p++)
		text[n++] = *p;
	text[n] = 0;
	status_out(a, severity, text, n);
}

/* A command's final answer (APP_EV_CMD_DONE for origin). */
static void post_done(struct app *a, uint8_t cmd, uint8_t result, uint8_t progress, app_origin origin)
{
	if (said_defer(a)) {
		struct app_said_item *it = said_put(a);
		it->kind = APP_SAID_DONE;
		it->cmd = cmd;
		it->result = result;
		it->progress = progress;
		it->origin = origin;
		return;
	}
	said_out(a);
	struct app_event *e = outbox_put(&a->outbox); /* in place */
	if (!e)
		return;
	e->kind = APP_EV_CMD_DONE;
	e->cmd = cmd;
	e->result = result;
	e->progress = progress;
	e->origin = origin;
}

static void exp_end(struct app *a, bool aborted);

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

/* The experiment ended (app_set_mode, leaving EXPERIMENT): an aborted one's lines said, the
 * run closed. In the step: recorded, done between frames. */
static void exp_end(struct app *a, bool aborted)
{
	if (said_defer(a)) {
		struct app_said_item *it = said_put(a);
		it->kind = APP_SAID_EXP_END;
		it->result = aborted ? 1u : 0u;
		return;
	}
	said_out(a);
	if (aborted)
		exp_flush(a);
	end_id_run(a);
}

/* What the step said, said in its order (between frames; in the step only when the ring is
 * full), then a status line for overflows not reported yet. */
static void said_flush(struct app *a)
{
	struct app_said *s = &a->said;
	if (s->saying)
		return;
	s->saying = true;
	while (s->n > 0) {
		const struct app_said_item *it = &s->q[s->head];
		switch (it->kind) {
		case APP_SAID_LINE: status_line(a, &it->line); break;
		case APP_SAID_EXP_END: exp_end(a, it->result != 0u); break;
		case APP_SAID_DONE: post_done(a, it->cmd, it->result, it->progress, it->origin); break;
		default: break;
		}
		s->head = (uint8_t)((s->head + 1u) % APP_SAID_LEN);
		s->n--;
	}
	s->saying = false;
	if (s->overflows != s->overflows_said) {
		s->overflows_said = s->overflows;
		app_status(a, APP_SEV_WARNING, "Step said over %d lines %d times: said in the step", APP_SAID_LEN,
			   (int)s->overflows);
	}
}

/* ---------------------------------------------------------------- the flight envelope's requests
 *
 * env_hover, env_kf, env_osc and env_limits learn and guard; what they ask for (parameters
 * to write, a status line, a landing) the app carries out here. */

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

static void set_param(struct app *a, int i, float v, bool announce)
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

/* Between frames: what the last step noted. */
static void env_publish(struct app *a)
{
	struct env_hover_pub hp;
	if (env_hover_publish(&a->env_hover, &a->p, &hp)) { /* a HOLD entry */
		set_param(a, PX_HOV_THR, hp.u, true);
		set_param(a, PX_HOV_THR_SD, hp.sd, true);
		set_param(a, PX_HOV_KF, hp.kf, true);
		set_param(a, PX_HOV_KF_SD, hp.kf_sd, true);
		app_status(a, APP_SEV_INFO, "Hover throttle %.4f+/-%.2g, k_f %.5g+/-%.2g N", (double)hp.u,
			   (double)hp.sd, (double)hp.kf, (double)hp.kf_sd);
		if (hp.alloc) /* the torque gain: env_hover_torque_scale */
			app_status(a, APP_SEV_INFO, "Hover k_f %.3g N is %.2g of VEH_KF %.3g: torques x%.2g",
				   (double)hp.kf, (double)(hp.kf / a->p.veh_kf), (double)a->p.veh_kf, (double)hp.tau_k);
	}
	struct env_kf_pub kp;
	if (env_kf_due(&a->env_kf) &&
	    env_kf_publish(&a->env_kf, &a->p, hal_wall_us(a->hal), a->fr.t_s, a->dt_frame, &kp)) {
		if (kp.fold > 0) /* env_kf.h: a fold too slow for the tracker's sd */
			app_status(a, APP_SEV_WARNING, "KFT paused: vibration folds to %.2f Hz (HOV_KF too)",
				   (double)kp.fold_hz);
		else if (kp.fold < 0)
			app_status(a, APP_SEV_INFO, "KFT resumed: the vibration folds to %.2f Hz", (double)kp.fold_hz);
		if (!kp.paused) {
			set_param(a, PX_KFT_EST, kp.k, kp.announce);
			set_param(a, PX_KFT_SD, kp.sd, kp.announce);
			set_param(a, PX_KFT_T, kp.t, kp.announce);
			set_param(a, PX_KFT_MEM, kp.mem, kp.announce);
			if (kp.announce) {
				post_value(a, "KFT", kp.k);
				post_value(a, "KFT_SD", kp.sd);
			}
			if (kp.clear_apply)
				set_param(a, PX_KFT_APPLY, 0.0f, true);
			if (kp.refresh)
				set_veh_kf(a, kp.kf, kp.why);
		}
	}
	struct env_osc_req oq;
	if (env_osc_judge(&a->env_osc, &a->p, &oq)) {
		if (oq.at_min || params_set(&a->p, PX_ATT_WN_RP, oq.nw) != PARAM_OK) {
			/* a loop the guard cannot settle: the vehicle cannot be flown, it lands */
			app_status(a, APP_SEV_ERROR, "Attitude oscillation %.0f deg/s: ATT_WN_RP at its minimum",
				   (double)oq.rms_dps);
			app_status(a, APP_SEV_ERROR, "Landing: the attitude loop cannot be settled");
			char w[8];
			app_cmd_land(a, APP_ORIGIN_NONE, w, sizeof w);
		} else {
			post_param(a, PX_ATT_WN_RP);
			a->params_dirty = true;
			a->save_pending = true;
			app_status(a, APP_SEV_WARNING, "Attitude oscillation %.0f deg/s: ATT_WN_RP %.2f -> %.2f",
				   (double)oq.rms_dps, (double)oq.wn, (double)oq.nw);
		}
	}
}

/* On every mode change. */
static void env_on_mode(struct app *a)
{
	env_limits_on_mode(&a->env_limits);
	a->torque_gain_due = true;
	if (a->mode == APP_TAKEOFF && env_hover_untaught(&a->env_hover)) {
		/* nothing learned yet: start from the current VEH_* */
		env_kf_init(&a->env_kf, &a->p);
		env_hover_init(&a->env_hover, &a->p);
	}
	if (a->mode == APP_HOLD)
		env_hover_on_hold(&a->env_hover, a->fr.t_s); /* published between frames */
}

/* Before experiment `id`: VEH_KF from the hover throttle (NAV_KF_SEED, env_hover.h). */
/* The experiment's source (ID_SOURCE): thrust rows (each rotor's measured thrust and torque,
 * X-Plane's rows 35 and 36), or the IMU (accelerometer and gyro, with the throttles sent and
 * the mass). Auto takes the rows when the frames carry them, else the IMU. A source the
 * frames do not deliver, or one this firmware does not build, is refused with the reason. */
static bool exp_source_pick(const struct app *a, int id, enum exp_source *src, char *why, size_t cap)
{
	const uint32_t rows = HAL_FRAME_THRUST | HAL_FRAME_TORQUE, imu = HAL_FRAME_ACCEL | HAL_FRAME_RATES;
	bool have_rows = (a->fr.valid & rows) == rows, have_imu = (a->fr.valid & imu) == imu;
	bool have_rpm = (a->fr.valid & HAL_FRAME_RPM) != 0, have_tq = (a->fr.valid & HAL_FRAME_TORQUE) != 0;
	float v = a->p.id_source;
	int want = isfinite(v) ? (int)(v + 0.5f) : 0;
	if (want == 0)
		want = have_rows             ? EXP_SRC_THRUST
		       : have_rpm && have_tq ? EXP_SRC_IMU_RPM_TQ
		       : have_rpm            ? EXP_SRC_IMU_RPM
					     : EXP_SRC_IMU;
	if (want < 1 || want > 4) {
		snprintf(why, cap,
			 "Experiment %d refused: ID_SOURCE %d unknown (0 auto, 1 thrust, 2 imu, 3 imu_rpm, "
			 "4 imu_rpm_torque)",
			 id, want);
		return false;
	}
	if ((want == EXP_SRC_IMU_RPM || want == EXP_SRC_IMU_RPM_TQ) && !have_rpm) {
		snprintf(why, cap, "Experiment %d refused: no rotor speeds (ID_SOURCE %s)", id,
			 want == EXP_SRC_IMU_RPM ? "imu_rpm" : "imu_rpm_torque");
		return false;
	}
	if (want == EXP_SRC_IMU_RPM_TQ && !have_tq) {
		snprintf(why, cap, "Experiment %d refused: no ESC torques (ID_SOURCE imu_rpm_torque)", id);
		return false;
	}
	if (want == EXP_SRC_THRUST && !have_rows) {
		snprintf(why, cap, "Experiment %d refused: no rotor thrust/torque rows", id);
		return false;
	}
	if (want >= EXP_SRC_IMU && !have_imu) {
		snprintf(why, cap, "Experiment %d refused: no accelerometer (ID_SOURCE imu)", id);
		return false;
	}
	*src = (enum exp_source)want;
	return true;
}

static void seed_kf(struct app *a, int id)
{
	float kf, old = a->p.veh_kf;
	if (!env_hover_seed_kf(&a->env_hover, &a->p, id, &kf) || params_set(&a->p, PX_VEH_KF, kf) != PARAM_OK)
		return;
	post_param(a, PX_VEH_KF);
	a->params_dirty = true;
	app_status(a, APP_SEV_INFO, "VEH_KF %.2f -> %.2f N (hover throttle)", (double)old, (double)kf);
}

void app_phase_timeout(struct app *a, const struct env_limits_req *r)
{
	status_line(a, &r->why);
	if (r->more.fmt)
		status_line(a, &r->more);
	if (r->cmd && r->origin != APP_ORIGIN_NONE)
		post_done(a, r->cmd, APP_FAILED, 0, r->origin);
	if (r->land) { /* the take-off or its hold entry ran out: land */
		char w[8];
		app_cmd_land(a, APP_ORIGIN_NONE, w, sizeof w); /* the take-off's origin has its answer */
	}
}

void app_set_mode(struct app *a, enum app_mode m)
{
	if (a->mode == m)
		return;
	if (a->mode == APP_EXPERIMENT)
		exp_end(a, a->exp.state == EXP_ABORTED);
	if (a->mode == APP_EXPERIMENT && a->exp_ack_pending) {
		/* the final answer to the experiment command: ACCEPTED when it
		 * finished, FAILED when it was aborted (the experiment sets final_result) */
		enum app_result r = a->exp.final_result == APP_ACCEPTED ? APP_ACCEPTED : APP_FAILED;
		post_done(a, APP_CMD_EXPERIMENT, (uint8_t)r, r == APP_ACCEPTED ? 100 : 0, a->exp_origin);
		a->exp_ack_pending = false;
	}
	a->mode = m;
	app_status2(a, APP_SEV_INFO, "Mode ", app_mode_name(m)); /* "Mode %s" without a format */
	env_on_mode(a);
}

/* ---------------------------------------------------------------- parameters -> modules */

/* Parameters -> controllers, mixer and throttle map. Not in the 90 Hz step: a parameter
 * change (PARAM_SET, a parameter load, identification results) sets params_dirty and
 * app_settle() runs this between frames (docs/architecture.md, "Between frames"). */
/* New rotor effectivenesses in flight (identified; not a rotor the guard found failed, whose
 * loss came too suddenly for the integral to take): the
 * torque the old ones left out, which the attitude integral had taken, goes back out of the
 * integral: rotor j's allocated thrust f_j was delivered as f_j s_new / s_old, and the mixer
 * now allocates for that (without it the integral's trim and the new allocation would both
 * correct it: a torque step as large as the trim). */
static void hand_back_trim(struct app *a, const struct mixer_params *mp)
{
	if (a->mode == APP_DISARMED || a->mode == APP_IDLE)
		return;
	scalar_t df[MIXER_N_ROTORS], w[MIXER_N_AXES];
	bool any = false;
	for (int j = 0; j < MIXER_N_ROTORS; j++) {
		scalar_t s0 = a->mix.p.scale[j], s1 = mp->scale[j];
		df[j] = SC_ZERO;
		if (s1 == s0 || !(s0 > SC_ZERO) || !(s1 > SC_ZERO) || !((mp->rotor_mask >> j) & 1u) ||
		    ((a->rf.failed >> j) & 1u))
			continue;
		df[j] = sc_mul(a->mix_out.f_n[j], sc_sub(sc_div(s1, s0), SC(1)));
		any = true;
	}
	if (!any)
		return;
	mixer_wrench(&a->mix, df, w);
	att_ctrl_shift_integral(&a->att, vec3_make(w[1], w[2], w[3]), a->ps.inertia_kgm2);
}

#define ATT_INT_WEAK_SHARE 0.75f
static void sync_params(struct app *a)
{
	const struct app_params *p = &a->p;
	a->torque_gain_due = true;
	struct att_ctrl_params ap = att_ctrl_params_default();
	ap.wn_rps = vec3_make(sc_from_float(p->att_wn_rp), sc_from_float(p->att_wn_rp), sc_from_float(p->att_wn_yaw));
	ap.zeta = vec3_make(sc_from_float(p->att_zeta), sc_from_float(p->att_zeta), sc_from_float(p->att_zeta));
	ap.ki_rps = vec3_make(sc_from_float(p->att_ki), sc_from_float(p->att_ki), sc_from_float(p->att_ki));
	/* the roll and pitch integral's reach: at least what rotors weaker than their MOT_SCALEj
	 * leave unbalanced before they are identified (three at 0.75 on a side: 0.75 of a
	 * rotor's hover thrust at the arm); beyond its reach the attitude error carries the
	 * torque, and the set point that error leaves behind is flown once the scales are
	 * identified */
	float tau_w = ATT_INT_WEAK_SHARE * p->veh_mass * p->veh_grav / (float)HAL_ROTORS * p->veh_arm_l;
	if (isfinite(tau_w) && tau_w > sc_to_float(ap.int_tau_max_nm.x)) {
		ap.int_tau_max_nm.x = sc_from_float(tau_w);
		ap.int_tau_max_nm.y = sc_from_float(tau_w);
	}
	att_ctrl_set_params(&a->att, &ap); /* not att_ctrl_init: that would drop the integral */

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
	pp.tilt_max_rad = sc_from_float(fminf(p->att_tilt_max, EXP_TILT_SP_DEG) * DEG_F);
	a->pos_exp = pp;

	struct alt_ctrl_params lp = alt_ctrl_params_default();
	lp.wn_rps = sc_from_float(p->alt_wn);
	lp.zeta = sc_from_float(p->alt_zeta);
	lp.ki_rps = sc_from_float(p->alt_ki);
	lp.g_mps2 = sc_from_float(p->veh_grav);
	lp.vz_max_up_mps = sc_from_float(fmaxf(sc_to_float(lp.vz_max_up_mps), p->nav_tko_vel));
	lp.vz_max_down_mps = sc_from_float(fmaxf(sc_to_float(lp.vz_max_down_mps), p->nav_land_vel));
	lp.f_max_n = sc_from_float((float)HAL_ROTORS * p->veh_kf * p->mot_thr_max);
	alt_ctrl_set_params(&a->alt, &lp); /* keeps the integral */

	a->ps.inertia_kgm2 = vec3_make(sc_from_float(p->veh_ixx), sc_from_float(p->veh_iyy), sc_from_float(p->veh_izz));
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
		if (!(scale[j] > 0.0f)) /* 0: a failed rotor, left out of the allocation */
			mp.rotor_mask &= (uint8_t) ~(1u << j);
	}
	mp.arm_l_m = sc_from_float(p->veh_arm_l);
	mp.k_f_n = sc_from_float(p->veh_kf);
	mp.k_tau_nm = sc_from_float(p->veh_ktau);
	mp.t_min = SC(0.0);
	mp.t_max = sc_from_float(p->mot_thr_max);
	mp.mode = p->mix_mode >= 0.5f ? MIXER_MODE_PRIORITY : MIXER_MODE_CLIP;
	hand_back_trim(a, &mp);
	mixer_set_params(&a->mix, &mp); /* recomputes only when something changed */
	mixer_warm_reset(&a->mix_warm); /* its face belongs to the mixer it was found on */

	struct thrmap_params tp = {sc_from_float(p->veh_kf), sc_from_float(p->mot_curve), {0}};
	for (int j = 0; j < THRMAP_ROTORS; j++)
		tp.scale[j] = sc_from_float(scale[j]);
	thrmap_init(&a->map, &tp);
	rotor_guard_sync(&a->rf, p);
	env_kf_model_sync(&a->env_kf, p);
	env_hover_model_sync(&a->env_hover, p);
	env_limits_sync(&a->env_limits, p);
}

void app_reset_control(struct app *a)
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
	env_kf_init(&a->env_kf, &a->p);
	env_hover_init(&a->env_hover, &a->p);
	a->torque_gain_due = true;
	a->exp.mix = &a->mix; /* the inertia phases take the body torque through the mixer's Gamma */
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
	said_out(a);
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
	said_out(a);
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
		app_reset_control(a);
		app_set_mode(a, APP_IDLE);
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
	app_set_thr_all(a, 0.0f);
	app_set_mode(a, APP_DISARMED);
	return APP_ACCEPTED;
}

enum app_result app_cmd_takeoff(struct app *a, float height_m, app_origin origin, char *why, size_t cap)
{
	said_out(a);
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
	if (!guid_takeoff(&a->guid, app_guid_mode(a->mode), sc_from_float(height_m), pos, frame_yaw(&a->fr)))
		return APP_ACCEPTED; /* a retry: nothing changes */
	if (a->mode == APP_IDLE)
		app_reset_control(a);
	app_status(a, APP_SEV_INFO, "Takeoff to %.2f m", (double)height_m);
	env_limits_on_command(&a->env_limits, APP_CMD_TAKEOFF, origin);
	a->mode = APP_HOLD; /* so that set_mode reports the change even from HOLD */
	app_set_mode(a, APP_TAKEOFF);
	return APP_ACCEPTED;
}

enum app_result app_cmd_land(struct app *a, app_origin origin, char *why, size_t cap)
{
	said_out(a); /* between frames; in the step (a failsafe) it records, as the step does */
	(void)why;
	(void)cap;
	switch (a->mode) {
	case APP_DISARMED:
	case APP_LAND: return APP_ACCEPTED;
	case APP_IDLE:
		app_set_thr_all(a, 0.0f);
		app_set_mode(a, APP_DISARMED);
		return APP_ACCEPTED;
	case APP_EXPERIMENT:
		exp_abort(&a->exp, "landing");
		/* fall through */
	case APP_TAKEOFF:
	case APP_HOLD:
		guid_land(&a->guid, sc_from_float(a->fr.pos_i_m[2]));
		env_limits_on_command(&a->env_limits, APP_CMD_LAND, origin);
		app_set_mode(a, APP_LAND);
		return APP_ACCEPTED;
	}
	return APP_FAILED;
}

static enum app_result exp_begin(struct app *a, int id, app_origin origin, char *why, size_t cap);

enum app_result app_cmd_experiment(struct app *a, float id_f, app_origin origin, char *why, size_t cap)
{
	said_out(a);
	if (!isfinite(id_f) || id_f != floorf(id_f) || id_f < 0.0f || id_f > 6.0f) {
		snprintf(why, cap, "Experiment %g unknown (1..6, 0 = stop)", (double)id_f);
		return APP_DENIED;
	}
	int id = (int)id_f;
	if (id == 0) {
		if (a->exp_wait.id) {
			app_status(a, APP_SEV_WARNING, "Experiment %d not started: stopped by command", a->exp_wait.id);
			post_done(a, APP_CMD_EXPERIMENT, APP_FAILED, 0, a->exp_wait.origin);
			a->exp_wait.id = 0;
		}
		if (a->mode == APP_EXPERIMENT) {
			exp_abort(&a->exp, "stopped by command");
			app_set_mode(a, APP_HOLD);
		}
		return APP_ACCEPTED;
	}
	if (a->mode == APP_EXPERIMENT) {
		if (a->exp.id == id)
			return APP_IN_PROGRESS; /* a retry: still running */
		snprintf(why, cap, "Experiment %d running", a->exp.id);
		return APP_BUSY;
	}
	if (a->exp_wait.id) {
		if (a->exp_wait.id == id)
			return APP_IN_PROGRESS; /* a retry: still waiting */
		snprintf(why, cap, "Experiment %d waits for the hover", a->exp_wait.id);
		return APP_BUSY;
	}
	char nh[48];
	if (app_not_hovering(a, nh, sizeof nh)) {
		if (a->mode != APP_HOLD && a->mode != APP_TAKEOFF) {
			snprintf(why, cap, "Experiment %d refused: not hovering, %s", id, nh);
			return APP_DENIED;
		}
		/* flying but not yet settled: wait for the hover (exp_wait_tick) */
		a->exp_wait.id = id;
		a->exp_wait.origin = origin;
		a->exp_wait.t0_s = a->fr.t_s;
		app_status(a, APP_SEV_INFO, "Experiment %d waits: %s", id, nh);
		return APP_IN_PROGRESS;
	}
	return exp_begin(a, id, origin, why, cap);
}

/* An experiment starts only after this long without a gap longer than FS_LINK_TO: the plant
 * holds the last throttles through a gap, and a sweep step (ID_SWP_THR: up to 3 g above the
 * weight for a few frames) held for half a second climbs metres. The first gap aborts an
 * experiment anyway; on a link that loses frames it would abort soon after the start. */
#define EXP_LINK_QUIET_S 10.0f

/* Experiment `id` on a hovering vehicle: refused while the attitude oscillates, while the
 * link has lost frames within EXP_LINK_QUIET_S, or when the source is not delivered; else
 * started, its final answer owed to `origin`. */
static enum app_result exp_begin(struct app *a, int id, app_origin origin, char *why, size_t cap)
{
	if (env_osc_oscillating(&a->env_osc)) { /* its excitation would take the tilt past the limit */
		snprintf(why, cap, "Experiment %d refused: attitude oscillating (%.0f deg/s rms)", id,
			 (double)env_osc_rms_dps(&a->env_osc));
		return APP_BUSY;
	}
	if (a->gap_n != 0u && a->n_prev >= a->gap_n) {
		float ago = (float)(a->n_prev - a->gap_n) * (a->dt_frame > 0.0f ? a->dt_frame : 1.0f / 90.0f);
		if (ago < EXP_LINK_QUIET_S) {
			/* within STATUSTEXT's 50 characters: the wait is docs/reliability.md's */
			snprintf(why, cap, "Experiment %d refused: frames lost %.1f s ago", id, (double)ago);
			return APP_BUSY;
		}
	}
	enum exp_source src;
	if (!exp_source_pick(a, id, &src, why, cap))
		return APP_DENIED;
	seed_kf(a, id);
	int r = exp_start(&a->exp, id, &a->p, src, why, cap);
	if (r == APP_ACCEPTED || r == APP_IN_PROGRESS) {
		a->id_run.run_id++;
		a->id_run.count = 0;
		a->id_run.done = false;
		app_set_mode(a, APP_EXPERIMENT);
		a->exp_ack_pending = true;
		a->exp_origin = origin;
		r = APP_IN_PROGRESS;
	}
	return r;
}

/* ---------------------------------------------------------------- identification results */

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
 * What changes the gains, mixer and throttle map runs here, at a frame boundary, never in
 * the step: docs/architecture.md, "Between frames". */
/* The last frame's work its step left (app.h, a->after), in the order the step had it: the
 * k_f tracker, the frame's record (which shows the tracker's estimate after the frame), the
 * rotor-failure judge. Before anything else between frames: whatever runs next sees the
 * frame done. */
static void log_frame(struct app *a, bool stepped, float dt);
static void after_frame(struct app *a)
{
	if (a->after.kf_due) {
		a->after.kf_due = false;
		env_kf_step(&a->env_kf, &a->after.kf_in, &a->p);
	}
	if (a->after.log_due) {
		a->after.log_due = false;
		log_frame(a, a->after.log_step, a->after.log_dt);
	}
	if (a->after.judge_due) {
		a->after.judge_due = false;
		rotor_guard_run(a); /* a failed rotor: its scale set, the vehicle told to land */
	}
}

/* The work between frames: its parts in their order, each run when its condition says it is
 * due. With run false, only whether any part is due: the step asks that before it settles,
 * since the all-clear case is the common one (app_tick settles every step before the next
 * frame). One list serves both, so a part cannot be due without the step seeing it. */
static bool settle_parts(struct app *a, bool run)
{
#define PART(due, work)                      \
	do {                                 \
		if (due) {                   \
			if (!run)            \
				return true; \
			work;                \
		}                            \
	} while (0)
	const struct app_said *s = &a->said;
	struct experiment *e = &a->exp;
	/* what the last step said, in its order, before anything newer */
	PART(s->n > 0u || s->overflows != s->overflows_said, said_out(a));
	PART(a->after.kf_due | a->after.log_due | a->after.judge_due, after_frame(a));
	/* what the last step noted: HOV_* of a HOLD entry, KFT_*, a VEH_KF refresh, a detune */
	PART(a->env_hover.pub_due | env_kf_due(&a->env_kf) | a->env_osc.due, env_publish(a));
	/* the torque demands' gain, from the hover learned so far */
	PART(a->torque_gain_due, (a->torque_gain_due = false, env_hover_torque_scale(&a->env_hover, &a->p)));
	/* a phase that ended in the last step: close it, start the next */
	PART(e->begin_pending | e->turn_pending, exp_turn(e, &a->p));
	PART(e->n_ids > 0, publish_ids(a));
	PART(e->n_results > 0, apply_results(a));
	PART(a->params_dirty, (a->params_dirty = false, sync_params(a)));
#undef PART
	return false;
}

void app_settle(struct app *a) { settle_parts(a, true); }

/* ---------------------------------------------------------------- per frame */

/* This frame's record: the log table filled (log.c) and handed to the platform. */
static void log_frame(struct app *a, bool stepped, float dt)
{
	struct log_src s = {
		.fr = &a->fr,
		.stepped = stepped,
		.dt = dt,
		.mode = (int8_t)a->mode,
		.armed = a->mode != APP_DISARMED,
		.link_ok = a->link_ok,
		.experiment = a->mode == APP_EXPERIMENT,
		.guid = &a->guid,
		.wrench_dem = a->wrench_dem,
		.mix_out = &a->mix_out,
		.excitation = a->exp_out.thr_delta,
		.thr = a->thr,
		.att_flags = a->att.flags,
		.alt_flags = a->alt.flags,
		.thr_clamped = a->thr_clamped,
		.exp = &a->exp,
		.p = &a->p,
		.kf = &a->env_kf,
		.bnd = &a->bnd,
	};
	log_fill(&a->log, &s);
	hal_log_frame(a->hal, &a->log);
}

static void link_back(struct app *a, float gap_s)
{
	a->link_ok = true;
	if (!a->link_ever) {
		a->link_ever = true;
		app_status2(a, APP_SEV_INFO, "X-Plane link up", "");
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
	app_set_mode(a, APP_HOLD);
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
		app_status(a, APP_SEV_WARNING, "X-Plane frames missing: %d gaps, longest %.2f s",
			   (int)(a->gaps_unsaid + 1u), (double)fmaxf(gap_s, a->gap_max_unsaid_s));
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
/* (float)x, the same value: a count that fits in 32 bits goes through the 32-bit conversion
 * (one instruction with an FPU; the 64-bit one is a library call) */
static inline float u64_float(uint64_t x) { return x <= UINT32_MAX ? (float)(uint32_t)x : (float)x; }

static float step_gap(struct app *a, const struct hal_sensor_frame *f, uint64_t k)
{
	if (!a->have_step) {
		a->per_n = f->frame_n;
		a->per_us = f->t_us;
		return FIRST_DT_S;
	}
	uint64_t span = f->frame_n - a->per_n;
	if (!(a->dt_frame > 0.0f) || span >= PERIOD_FRAMES) {
		float fspan = u64_float(span);
		float p = u64_float(f->t_us - a->per_us) * 1e-6f / fspan, d = p - a->dt_frame;
		if (!(a->dt_frame > 0.0f) || fabsf(d) > 0.25f * a->dt_frame)
			a->dt_frame = p;
		else if (fabsf(d) * fspan > 2e-6f)
			a->dt_frame += 0.5f * d;
		a->per_n = f->frame_n;
		a->per_us = f->t_us;
	}
	return u64_float(k) * a->dt_frame;
}

/* *d = *s field by field: the library's memcpy of the whole frame costs more on a core that
 * copies a word per load and store anyway. Every field of struct hal_sensor_frame is here
 * (hal.h says so at the struct; the assertion catches a field added beyond the padding). */
#define FRAME_FIELDS_SIZE                                                   \
	(2 * sizeof(uint64_t) + 3 * sizeof(double) + 2 * sizeof(uint32_t) + \
	 (4 + 3 * 4 + 4 * HAL_ROTORS + 1) * sizeof(float))
_Static_assert(sizeof(struct hal_sensor_frame) == FRAME_FIELDS_SIZE ||
		       sizeof(struct hal_sensor_frame) == FRAME_FIELDS_SIZE + 4u, /* a double's alignment */
	       "frame_copy copies every field of struct hal_sensor_frame");
static void frame_copy(struct hal_sensor_frame *restrict d, const struct hal_sensor_frame *restrict s)
{
	d->t_us = s->t_us;
	d->frame_n = s->frame_n;
	d->t_s = s->t_s;
	d->seq = s->seq;
	d->valid = s->valid;
	d->lat_deg = s->lat_deg;
	d->lon_deg = s->lon_deg;
	d->alt_msl_m = s->alt_msl_m;
	SC_HOT_UNROLL
	for (int i = 0; i < 4; i++)
		d->q_ib[i] = s->q_ib[i];
	SC_HOT_UNROLL
	for (int i = 0; i < 3; i++) {
		d->rate_b_rps[i] = s->rate_b_rps[i];
		d->pos_i_m[i] = s->pos_i_m[i];
		d->vel_i_mps[i] = s->vel_i_mps[i];
		d->accel_b_g[i] = s->accel_b_g[i];
	}
	SC_HOT_UNROLL
	for (int j = 0; j < HAL_ROTORS; j++) {
		d->rotor_thrust_n[j] = s->rotor_thrust_n[j];
		d->rotor_torque_nm[j] = s->rotor_torque_nm[j];
		d->thr_cmd_echo[j] = s->thr_cmd_echo[j];
		d->rotor_speed_rps[j] = s->rotor_speed_rps[j];
	}
}

void app_on_frame(struct app *a, const struct hal_sensor_frame *f)
{
	if (settle_parts(a, false)) /* normally done by app_tick already (nothing left here) */
		app_settle(a);
	a->said.in_step = true; /* what the step says is said between frames (struct app_said) */
	uint64_t now = hal_wall_us(a->hal);
	frame_copy(&a->fr, f);
	if (origin_correct(&a->orig, &a->fr))
		app_status(a, APP_SEV_INFO, "Plant moved its local origin (%.0f m): position re-referenced",
			   (double)sqrtf(a->orig.last_step[0] * a->orig.last_step[0] +
					 a->orig.last_step[1] * a->orig.last_step[1] +
					 a->orig.last_step[2] * a->orig.last_step[2]));
	a->have_frame = true;
	if (!a->link_ok)
		link_back(a, a->link_ever ? u64_float(now - a->link_lost_at_us) * 1e-6f : 0.0f);
	a->wall_last_frame_us = now;

	bool complete = (f->valid & HAL_FRAME_NEEDED) == HAL_FRAME_NEEDED;
	float dt = 0.0f;
	bool stepped = false;
	if (complete) {
		/* frames since the last step, as the platform counts them (lost ones included; a
		 * frame without a newer count, a duplicate or an older one, brings none) */
		uint64_t k = !a->have_step ? 1u : f->frame_n > a->n_prev ? f->frame_n - a->n_prev : 0u;
		float gap = k > 0u ? step_gap(a, f, k) : 0.0f;
		if (app_f_lt(0.0f, gap)) { /* the frame's comparisons: fcmp.h */
			bool missing = a->have_step && app_f_lt(a->p.fs_link_to, gap);
			if (missing) {
				/* frames missing in plant time (lockstep bursts, reload) */
				say_gap(a, gap, now);
				a->gap_n = f->frame_n;
				abort_experiment(a, "X-Plane frames missing");
				if (gap > a->p.fs_land_after && app_flying(a) && a->mode != APP_LAND) {
					char why[8];
					app_cmd_land(a, APP_ORIGIN_NONE, why, sizeof why);
				}
			}
			dt = app_f_lt(MAX_DT_S, gap) ? MAX_DT_S : gap;
			a->n_prev = f->frame_n;
			a->have_step = true;
			rotor_guard_note(a, dt); /* judged at the frame boundary (after_frame) */
			/* After frames missing the controllers were out of the loop (their last
			 * command held): they take one frame period, not the gap, so that their
			 * integrators do not wind up over time they could not act in. */
			app_step(a, missing && a->dt_frame > 0.0f ? a->dt_frame : dt);
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
	/* the frame's record: filled and handed to the platform at the frame boundary */
	a->after.log_due = true;
	a->after.log_step = stepped;
	a->after.log_dt = dt;
	a->said.in_step = false;
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
	said_out(a);
	return outbox_pop(&a->outbox, e);
}

/* Between frames: an experiment waiting for the hover starts once the vehicle hovers (and
 * its attitude no longer oscillates); it fails, saying why, when the vehicle leaves TAKEOFF
 * and HOLD, when it cannot start, or after EXP_WAIT_S. */
static void exp_wait_tick(struct app *a)
{
	int id = a->exp_wait.id;
	if (!id)
		return;
	char nh[48], why[96] = "";
	bool flying = a->mode == APP_HOLD || a->mode == APP_TAKEOFF;
	bool hover = !app_not_hovering(a, nh, sizeof nh);
	if (hover) {
		a->exp_wait.id = 0;
		enum app_result r = exp_begin(a, id, a->exp_wait.origin, why, sizeof why);
		if (r == APP_IN_PROGRESS || r == APP_ACCEPTED)
			return;
		if (r != APP_BUSY) { /* cannot start at all: said, FAILED */
			app_status(a, APP_SEV_ERROR, "%s", why);
			post_done(a, APP_CMD_EXPERIMENT, APP_FAILED, 0, a->exp_wait.origin);
			return;
		}
		/* oscillating (the guard lowers the gain) or frames lost lately: wait on, saying why */
		a->exp_wait.id = id;
		const char *cause = strstr(why, "refused: ");
		snprintf(nh, sizeof nh, "%.40s", cause ? cause + strlen("refused: ") : why);
	}
	bool late = a->fr.t_s - a->exp_wait.t0_s > EXP_WAIT_S;
	if (flying && !late)
		return;
	if (late)
		app_status(a, APP_SEV_ERROR, "Experiment %d not started: %.0f s, %s", id, EXP_WAIT_S, nh);
	else
		app_status(a, APP_SEV_ERROR, "Experiment %d not started: %s", id, nh);
	post_done(a, APP_CMD_EXPERIMENT, APP_FAILED, 0, a->exp_wait.origin);
	a->exp_wait.id = 0;
}

void app_tick(struct app *a)
{
	app_settle(a);
	exp_wait_tick(a);
	mixer_refresh(&a->mix, &a->mix_warm); /* the last step's saturated demand, exactly */
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
	exp_pump(&a->exp); /* the experiment's next status line, formatted here */
	if (a->exp.msg[0]) {
		app_status(a, a->exp.msg_severity, "%s", a->exp.msg);
		a->exp.msg[0] = 0;
	}
}
