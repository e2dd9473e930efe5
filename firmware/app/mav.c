/* mav.c - MAVLink 2 endpoint: telemetry table, parameters, commands (see mav.h). */
#include "mav.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "app.h"
#include "mav_ftp.h"
#include "mav_lib.h"
#include "mav_telem.h"

#define CHAN MAVLINK_COMM_0
#define PARAM_PACE_US 2000u /* list streaming: one PARAM_VALUE per 2 ms */
#define PARAM_PER_TICK 4
#define TEXT_BURST 50.0f /* STATUSTEXT: burst of 50, then 20 per second */
#define TEXT_RATE 20.0f
#define FW_VERSION 0x00050000u /* 0.5.0 */

/* The channel's status and receive buffer (mav_lib.h): one channel, whatever its number. */
mavlink_status_t *mavlink_get_channel_status(uint8_t chan)
{
	static mavlink_status_t status;
	(void)chan;
	return &status;
}

mavlink_message_t *mavlink_get_channel_buffer(uint8_t chan)
{
	static mavlink_message_t rx;
	(void)chan;
	return &rx;
}

/* With signing on, only RADIO_STATUS may arrive unsigned (common practice). */
static bool accept_unsigned(const mavlink_status_t *status, uint32_t msgid)
{
	(void)status;
	return msgid == MAVLINK_MSG_ID_RADIO_STATUS;
}

static void signing_setup(struct mav *m, const struct hal *hal)
{
	uint8_t key[32];
	mavlink_status_t *st = mavlink_get_channel_status(CHAN);
	if (!hal_signing_key(hal, key)) {
		st->signing = NULL;
		st->signing_streams = NULL;
		return;
	}
	mavlink_signing_t *sg = &m->signing_state;
	memset(sg, 0, sizeof *sg);
	memset(&m->signing_streams, 0, sizeof m->signing_streams);
	memcpy(sg->secret_key, key, sizeof key);
	memset(key, 0, sizeof key);
	sg->link_id = (uint8_t)CHAN;
	sg->flags = MAVLINK_SIGNING_FLAG_SIGN_OUTGOING;
	/* 10 us units since 2015-01-01 00:00:00 UTC */
	uint64_t us = hal_unix_us(hal);
	const uint64_t epoch2015_us = 1420070400ull * 1000000ull;
	sg->timestamp = us > epoch2015_us ? (us - epoch2015_us) / 10u : 1u;
	sg->accept_unsigned_callback = accept_unsigned;
	st->signing = sg;
	st->signing_streams = &m->signing_streams;
	m->signing = true;
}

static void send_msg(const struct mav *m, const mavlink_message_t *msg)
{
	uint8_t buf[MAVLINK_MAX_PACKET_LEN];
	uint16_t n = mavlink_msg_to_send_buffer(buf, msg);
	hal_ground_send(m->hal, buf, n);
}

static uint32_t boot_ms(const struct mav *m) { return (uint32_t)((hal_wall_us(m->hal) - m->boot_us) / 1000u); }

static void send_named_float(const struct mav *m, const char *name, float value);

/* The sender handed to the telemetry and FTP modules (their context is the endpoint). */
static void send_cb(const void *ctx, const mavlink_message_t *msg) { send_msg(ctx, msg); }

static struct mav_telem_in telem_in(const struct mav *m, const struct app_view *v)
{
	float thr = 0.0f;
	for (int j = 0; j < HAL_ROTORS; j++)
		thr += v->thr[j] / (float)HAL_ROTORS;
	return (struct mav_telem_in){
		boot_ms(m), v->fr,      v->frames_ok, v->armed, v->frames_ok,   (uint32_t)v->mode, thr,
		MAV_SYSID,  MAV_COMPID, CHAN,         m,        v->rotor_failed};
}

static struct mav_ftp_link ftp_link(const struct mav *m, const mavlink_message_t *req)
{
	return (struct mav_ftp_link){MAV_SYSID, MAV_COMPID, CHAN, req->sysid, req->compid, boot_ms(m), m};
}

/* ---------------------------------------------------------------- telemetry table
 * The pack functions read the app's view: telemetry never changes the app. */

static void pack_heartbeat(const struct mav *m, const struct app_view *v, mavlink_message_t *msg)
{
	(void)m;
	uint8_t base = mav_telem_base_mode(v->armed);
	uint8_t status = MAV_STATE_STANDBY;
	if (v->flying)
		status = v->link_ok ? MAV_STATE_ACTIVE : MAV_STATE_CRITICAL;
	mavlink_msg_heartbeat_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, msg, MAV_TYPE_OCTOROTOR, MAV_AUTOPILOT_GENERIC,
					base, (uint32_t)v->mode, status);
}

/* Telemetry leaves in MAVLink's NED / forward-right-down conventions. */
static void pack_attitude_q(const struct mav *m, const struct app_view *v, mavlink_message_t *msg)
{
	const struct hal_sensor_frame *f = v->fr;
	const float zero[4] = {0, 0, 0, 0};
	mavlink_msg_attitude_quaternion_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, msg, boot_ms(m), f->q_ib[0], f->q_ib[1],
						  -f->q_ib[2], -f->q_ib[3], f->rate_b_rps[0], -f->rate_b_rps[1],
						  -f->rate_b_rps[2], zero);
}

static void pack_actuator(const struct mav *m, const struct app_view *v, mavlink_message_t *msg)
{
	float act[32] = {0};
	for (int j = 0; j < HAL_ROTORS; j++)
		act[j] = v->thr[j];
	mavlink_msg_actuator_output_status_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, msg, (uint64_t)boot_ms(m) * 1000u,
						     0xFFu, act);
}

static uint16_t pwm(float t)
{
	t = t < 0.0f ? 0.0f : (t > 1.0f ? 1.0f : t);
	return (uint16_t)(1000.0f + 1000.0f * t + 0.5f);
}

static void pack_servo(const struct mav *m, const struct app_view *v, mavlink_message_t *msg)
{
	const float *t = v->thr;
	mavlink_msg_servo_output_raw_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, msg, boot_ms(m) * 1000u, 0, pwm(t[0]),
					       pwm(t[1]), pwm(t[2]), pwm(t[3]), pwm(t[4]), pwm(t[5]), pwm(t[6]),
					       pwm(t[7]), 0, 0, 0, 0, 0, 0, 0, 0);
}

static void pack_sys_status(const struct mav *m, const struct app_view *v, mavlink_message_t *msg)
{
	struct hal_plant_stats ls;
	hal_plant_stats(m->hal, &ls);
	uint16_t drops = (uint16_t)(ls.dropped > 65535u ? 65535u : ls.dropped);
	uint32_t present, enabled, health;
	struct mav_telem_in in = telem_in(m, v);
	mav_telem_sensors(&in, &present, &enabled, &health);
	mavlink_msg_sys_status_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, msg, present, enabled, health, 0, UINT16_MAX, -1,
					 -1, 0, (uint16_t)(m->rx_dropped > 65535u ? 65535u : m->rx_dropped), drops,
					 (uint16_t)(ls.foreign > 65535u ? 65535u : ls.foreign),
					 (uint16_t)(m->text_dropped > 65535u ? 65535u : m->text_dropped),
					 (uint16_t)(m->rx_unsigned > 65535u ? 65535u : m->rx_unsigned), 0, 0, 0);
}

/* NAMED_VALUE_FLOAT of the live estimates: packs nothing itself (several
 * messages), sends them directly; returns false so the table sends nothing. */
static void pack_estimates(const struct mav *m, const struct app_view *v, mavlink_message_t *msg)
{
	(void)msg;
	if (v->mode != APP_EXPERIMENT)
		return;
	static const char *const with_sd[] = {"KF", "KTAU", "IXX", "IYY", "IZZ"};
	for (int i = 0; i < v->n_est && i < EXP_MAX_EST; i++) {
		if (!(v->est_live & (1u << i)))
			continue;
		send_named_float(m, v->est_name[i], v->est[i]);
		for (size_t k = 0; k < sizeof with_sd / sizeof with_sd[0]; k++)
			if (!strcmp(v->est_name[i], with_sd[k])) {
				char name[16];
				snprintf(name, sizeof name, "%s_SD", with_sd[k]);
				send_named_float(m, name, v->est_sd[i]);
			}
	}
}

struct mav_stream {
	uint32_t msgid;
	uint32_t default_interval_us;
	void (*pack)(const struct mav *m, const struct app_view *v, mavlink_message_t *msg);
	bool direct; /* pack sends itself (zero or several messages) */
};

static const struct mav_stream streams[MAV_N_STREAMS] = {
	{MAVLINK_MSG_ID_HEARTBEAT, 1000000u, pack_heartbeat, false},
	{MAVLINK_MSG_ID_SYS_STATUS, 1000000u, pack_sys_status, false},
	{MAVLINK_MSG_ID_ATTITUDE_QUATERNION, 100000u, pack_attitude_q, false},
	{MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS, 200000u, pack_actuator, false},
	{MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, 200000u, pack_servo, false},
	{MAVLINK_MSG_ID_NAMED_VALUE_FLOAT, 500000u, pack_estimates, true},
};

static int stream_index(uint32_t msgid)
{
	for (int i = 0; i < MAV_N_STREAMS; i++)
		if (streams[i].msgid == msgid)
			return i;
	return -1;
}

static void send_stream(const struct mav *m, const struct app_view *v, int i)
{
	mavlink_message_t msg;
	streams[i].pack(m, v, &msg);
	if (!streams[i].direct)
		send_msg(m, &msg);
}

void mav_init(struct mav *m, struct app *a, const struct hal *hal, uint64_t now_us)
{
	memset(m, 0, sizeof *m);
	m->app = a;
	m->hal = hal;
	for (int i = 0; i < MAV_N_STREAMS; i++)
		m->interval_us[i] = streams[i].default_interval_us;
	m->param_next = -1;
	m->boot_us = now_us;
	m->text_tokens = TEXT_BURST;
	m->text_last_us = now_us;
	mav_telem_init(&m->telem);
	(void)mav_ftp_init(&m->ftp); /* without metadata, FTP NAKs everything and 395/397 are UNSUPPORTED */
	signing_setup(m, hal);
}

/* ---------------------------------------------------------------- outgoing helpers */

/* STATUSTEXT carries 50 characters. A longer line goes out as chunks sharing a nonzero id
 * (MAVLink 2's id and chunk_seq): 50 characters each, then a shorter, NUL-padded one that ends
 * the line (empty when the length is a multiple of 50). QGroundControl, MAVProxy and the
 * project's tools join the chunks; a receiver that does not shows them in order. A line of at
 * most 50 characters is one message with id 0. The rate limit admits a line whole or not at all. */
static void send_statustext(struct mav *m, int severity, const char *text)
{
	enum { W = MAVLINK_MSG_STATUSTEXT_FIELD_TEXT_LEN };
	size_t n = strlen(text);
	unsigned chunks = n <= W ? 1u : (unsigned)(n / W) + 1u;
	uint64_t now = hal_wall_us(m->hal);
	m->text_tokens += (float)(now - m->text_last_us) * 1e-6f * TEXT_RATE;
	if (m->text_tokens > TEXT_BURST)
		m->text_tokens = TEXT_BURST;
	m->text_last_us = now;
	if (m->text_tokens < (float)chunks) {
		m->text_dropped++;
		return;
	}
	m->text_tokens -= (float)chunks;
	uint16_t id = 0;
	if (chunks > 1u) {
		m->text_id = (uint16_t)(m->text_id == UINT16_MAX ? 1u : m->text_id + 1u);
		id = m->text_id;
	}
	uint8_t sev = (uint8_t)(severity < 0 ? 0 : (severity > 7 ? 7 : severity));
	for (unsigned c = 0; c < chunks; c++) {
		char buf[W]; /* zero-filled, full size */
		memset(buf, 0, sizeof buf);
		size_t at = (size_t)c * W, k = n - at < W ? n - at : W;
		memcpy(buf, text + at, k);
		mavlink_message_t msg;
		mavlink_msg_statustext_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &msg, sev, buf, id, (uint8_t)c);
		send_msg(m, &msg);
	}
}

static void send_named_float(const struct mav *m, const char *name, float value)
{
	char buf[MAVLINK_MSG_NAMED_VALUE_FLOAT_FIELD_NAME_LEN];
	memset(buf, 0, sizeof buf);
	size_t n = strlen(name);
	memcpy(buf, name, n < sizeof buf ? n : sizeof buf);
	mavlink_message_t msg;
	mavlink_msg_named_value_float_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &msg, boot_ms(m), buf, value);
	send_msg(m, &msg);
}

/* ---------------------------------------------------------------- identification results */

/* The app's codes are the dialect's (id_result.h): checked here, where both are seen. */
#define SAME_CODE(app, dialect) _Static_assert((int)(app) == (int)(dialect), #app " is " #dialect)
SAME_CODE(APP_ID_KF, OCTO_ID_PARAM_KF);
SAME_CODE(APP_ID_KTAU, OCTO_ID_PARAM_KTAU);
SAME_CODE(APP_ID_IXX, OCTO_ID_PARAM_IXX);
SAME_CODE(APP_ID_IYY, OCTO_ID_PARAM_IYY);
SAME_CODE(APP_ID_IZZ, OCTO_ID_PARAM_IZZ);
SAME_CODE(APP_ID_MOT_TAU, OCTO_ID_PARAM_MOT_TAU);
SAME_CODE(APP_ID_DELAY_FR, OCTO_ID_PARAM_DELAY_FR);
SAME_CODE(APP_ID_MOT_CURVE, OCTO_ID_PARAM_MOT_CURVE);
SAME_CODE(APP_ID_MOT_SCALE, OCTO_ID_PARAM_MOT_SCALE);
SAME_CODE(APP_ID_KF_PLAIN, OCTO_ID_PARAM_KF_PLAIN);
SAME_CODE(APP_ID_KTAU_PLAIN, OCTO_ID_PARAM_KTAU_PLAIN);
SAME_CODE(APP_ID_KTAU_OVER_IZZ, OCTO_ID_PARAM_KTAU_OVER_IZZ);
SAME_CODE(APP_ID_VAL_NE_BEFORE, OCTO_ID_PARAM_VAL_NE_BEFORE);
SAME_CODE(APP_ID_VAL_NE_AFTER, OCTO_ID_PARAM_VAL_NE_AFTER);
SAME_CODE(APP_ID_OK, OCTO_ID_REASON_OK);
SAME_CODE(APP_ID_NOT_FINITE, OCTO_ID_REASON_NOT_FINITE);
SAME_CODE(APP_ID_OUT_OF_RANGE, OCTO_ID_REASON_OUT_OF_RANGE);
SAME_CODE(APP_ID_UNCERTAIN, OCTO_ID_REASON_UNCERTAIN);
SAME_CODE(APP_ID_PARTNER_REJECTED, OCTO_ID_REASON_PARTNER_REJECTED);
SAME_CODE(APP_ID_LAG_OFF, OCTO_ID_REASON_LAG_OFF);
SAME_CODE(APP_ID_NO_DATA, OCTO_ID_REASON_NO_DATA);
SAME_CODE(APP_ID_NOISE_UNKNOWN, OCTO_ID_REASON_NOISE_UNKNOWN);
SAME_CODE(APP_ID_LAG_RANGE, OCTO_ID_REASON_LAG_RANGE);
SAME_CODE(APP_ID_DELAY_RANGE, OCTO_ID_REASON_DELAY_RANGE);
SAME_CODE(APP_ID_DELAY_AMBIGUOUS, OCTO_ID_REASON_DELAY_AMBIGUOUS);
SAME_CODE(APP_ID_CURVE, OCTO_ID_REASON_CURVE);
SAME_CODE(APP_ID_ROTOR, OCTO_ID_REASON_ROTOR);
SAME_CODE(APP_ID_MODEL, OCTO_ID_REASON_MODEL);
SAME_CODE(APP_ID_DELAY_GIVEN, OCTO_ID_REASON_DELAY_GIVEN);
SAME_CODE(APP_ID_LEVEL, OCTO_ID_REASON_LEVEL);
SAME_CODE(APP_ID_COLOURED, OCTO_ID_REASON_COLOURED);
SAME_CODE(APP_ID_LAG_REACH, OCTO_ID_REASON_LAG_REACH);
SAME_CODE(APP_ID_NOT_IDENTIFIABLE, OCTO_ID_REASON_NOT_IDENTIFIABLE);
SAME_CODE(APP_ID_AUXILIARY, OCTO_ID_REASON_AUXILIARY);
SAME_CODE(APP_ID_ABORTED, OCTO_ID_REASON_ABORTED);
SAME_CODE(APP_ID_SOURCE_UNKNOWN, OCTO_ID_SOURCE_UNKNOWN);
SAME_CODE(APP_ID_SOURCE_THRUST, OCTO_ID_SOURCE_THRUST);
SAME_CODE(APP_ID_SOURCE_IMU, OCTO_ID_SOURCE_IMU);
SAME_CODE(APP_ID_SOURCE_IMU_RPM, OCTO_ID_SOURCE_IMU_RPM);
SAME_CODE(APP_ID_SOURCE_IMU_RPM_TQ, OCTO_ID_SOURCE_IMU_RPM_TORQUE);
#undef SAME_CODE

static void send_id_result(const struct mav *m, const struct app_id_result *r)
{
	mavlink_message_t msg;
	mavlink_msg_octo_id_result_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &msg, boot_ms(m), r->run_id, r->index,
					     r->count, r->run_done, r->experiment, r->param, r->rotor, r->value, r->sd,
					     r->accepted, r->reason, r->source);
	send_msg(m, &msg);
}

/* MAV_CMD_REQUEST_MESSAGE for OCTO_ID_RESULT: param2 the index within the last run, or -1
 * for all of them. FAILED when there is no such result (no run yet, an index past it). */
static uint8_t id_results_request(const struct app_view *v, float index)
{
	const struct app_id_run *run = v->id_run;
	if (index == -1.0f)
		return run->count > 0 ? MAV_RESULT_ACCEPTED : MAV_RESULT_FAILED;
	if (!(index >= 0.0f && index == floorf(index)))
		return MAV_RESULT_DENIED;
	return index < (float)run->count ? MAV_RESULT_ACCEPTED : MAV_RESULT_FAILED;
}

/* The requested results, as they stand now: count the run's so far, run_done on the last
 * of a run that ended. */
static void send_id_results(const struct mav *m, const struct app_view *v, float index)
{
	const struct app_id_run *run = v->id_run;
	for (int i = 0; i < run->count; i++) {
		if (index != -1.0f && index != (float)i)
			continue;
		struct app_id_result r = run->r[i];
		r.count = run->count;
		r.run_done = run->done && i == run->count - 1 ? 1u : 0u;
		send_id_result(m, &r);
	}
}

static void send_param_value(const struct mav *m, size_t index)
{
	if (index >= param_count)
		return;
	char id[MAVLINK_MSG_PARAM_VALUE_FIELD_PARAM_ID_LEN]; /* 16, no NUL when full */
	memset(id, 0, sizeof id);
	size_t n = strlen(param_defs[index].name);
	memcpy(id, param_defs[index].name, n < sizeof id ? n : sizeof id);
	mavlink_message_t msg;
	mavlink_msg_param_value_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &msg, id, params_get(app_params(m->app), index),
					  MAV_PARAM_TYPE_REAL32, (uint16_t)param_count, (uint16_t)index);
	send_msg(m, &msg);
}

static void send_command_ack(const struct mav *m, uint16_t cmd, uint8_t result, uint8_t progress, uint8_t sysid,
			     uint8_t compid)
{
	mavlink_message_t msg;
	mavlink_msg_command_ack_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &msg, cmd, result, progress, 0, sysid, compid);
	send_msg(m, &msg);
}

static void drain(struct mav *m);

/* Every reply first drains the outbox: status lines the request caused go out before its answer. */
static void send_ack(struct mav *m, uint16_t cmd, uint8_t result, const mavlink_message_t *req)
{
	drain(m);
	send_command_ack(m, cmd, result, 0, req->sysid, req->compid);
}

static void send_autopilot_version(const struct mav *m)
{
	uint8_t custom[8] = {0}, uid2[18] = {0};
	memcpy(custom, "octofw05", 8);
	mavlink_message_t msg;
	mavlink_msg_autopilot_version_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &msg,
						MAV_PROTOCOL_CAPABILITY_MAVLINK2 |
							MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE |
							MAV_PROTOCOL_CAPABILITY_COMMAND_INT,
						FW_VERSION, 0, 0, 0, custom, custom, custom, 0, 0, 1, uid2);
	send_msg(m, &msg);
}

/* ---------------------------------------------------------------- parameters */

static bool for_us(uint8_t tsys, uint8_t tcomp)
{
	return (tsys == 0 || tsys == MAV_SYSID) && (tcomp == 0 || tcomp == MAV_COMPID);
}

static void unknown_param(struct mav *m, const char *id, int index)
{
	char name[PARAM_ID_LEN + 1] = {0};
	size_t n = 0;
	while (n < PARAM_ID_LEN && id[n])
		n++;
	memcpy(name, id, n);
	for (char *c = name; *c; c++)
		if (*c < 32 || *c > 126)
			*c = '?';
	if (name[0])
		app_status(m->app, APP_SEV_WARNING, "Unknown parameter %s", name);
	else
		app_status(m->app, APP_SEV_WARNING, "Unknown parameter index %d", index);
}

static void handle_param_set(struct mav *m, const mavlink_message_t *msg)
{
	mavlink_param_set_t ps;
	mavlink_msg_param_set_decode(msg, &ps);
	if (!for_us(ps.target_system, ps.target_component))
		return;
	int idx = params_find(ps.param_id, sizeof ps.param_id);
	if (idx < 0) {
		unknown_param(m, ps.param_id, -1);
		return;
	}
	const char *why = app_param_write(m->app, (size_t)idx, ps.param_value);
	if (why)
		app_status(m->app, APP_SEV_WARNING, "%s: %g refused (%s)", param_defs[idx].name, (double)ps.param_value,
			   why);
	drain(m);
	send_param_value(m, (size_t)idx); /* always: the current value */
}

static void handle_param_read(struct mav *m, const mavlink_message_t *msg)
{
	mavlink_param_request_read_t pr;
	mavlink_msg_param_request_read_decode(msg, &pr);
	if (!for_us(pr.target_system, pr.target_component))
		return;
	int idx;
	if (pr.param_index < 0)
		idx = params_find(pr.param_id, sizeof pr.param_id);
	else
		idx = (size_t)pr.param_index < param_count ? pr.param_index : -1;
	if (idx < 0) {
		unknown_param(m, pr.param_index < 0 ? pr.param_id : "", pr.param_index);
		return;
	}
	send_param_value(m, (size_t)idx);
}

/* ---------------------------------------------------------------- commands */

static uint8_t mav_result(enum app_result r)
{
	switch (r) {
	case APP_ACCEPTED: return MAV_RESULT_ACCEPTED;
	case APP_IN_PROGRESS: return MAV_RESULT_IN_PROGRESS;
	case APP_BUSY: return MAV_RESULT_TEMPORARILY_REJECTED;
	case APP_DENIED: return MAV_RESULT_DENIED;
	case APP_FAILED: return MAV_RESULT_FAILED;
	case APP_UNSUPPORTED: break;
	}
	return MAV_RESULT_UNSUPPORTED;
}

/* The sender of a command, as the app keeps it (opaque to it). */
static app_origin origin_of(const mavlink_message_t *req) { return (app_origin)req->sysid << 8 | req->compid; }

/* MAV_CMD_USER_1: long-running, IN_PROGRESS (with progress) now and on retries, the final
 * ACCEPTED / FAILED when the experiment ends (the app's APP_EV_CMD_DONE). Returns true when
 * it answered itself. */
static bool cmd_experiment(struct mav *m, const mavlink_message_t *req, uint16_t cmd, float id, uint8_t *r, char *why,
			   size_t cap)
{
	*r = mav_result(app_cmd_experiment(m->app, id, origin_of(req), why, cap));
	if (*r != MAV_RESULT_IN_PROGRESS)
		return false;
	/* progress in percent, rounded up (a started experiment shows >= 1), at most 99 until
	 * the final ACK */
	float pr = ceilf(app_view(m->app).exp_progress * 100.0f);
	drain(m);
	send_command_ack(m, cmd, *r, (uint8_t)(pr < 0.0f ? 0.0f : (pr > 99.0f ? 99.0f : pr)), req->sysid, req->compid);
	if (why[0])
		app_status(m->app, APP_SEV_INFO, "%s", why);
	return true;
}

/* MAV_CMD_PREFLIGHT_STORAGE: param1 0 loads the parameter file, 1 saves it. */
static uint8_t cmd_storage(struct mav *m, float what, char *why, size_t cap)
{
	uint8_t r;
	if (what == 0.0f) {
		if (app_view(m->app).mode == APP_EXPERIMENT) {
			snprintf(why, cap, "Parameter load refused: experiment running");
			return MAV_RESULT_TEMPORARILY_REJECTED;
		}
		r = mav_result(app_params_load(m->app, why, cap));
		if (r == MAV_RESULT_ACCEPTED) {
			app_status(m->app, APP_SEV_INFO, "Parameters loaded");
			m->param_next = 0; /* the ground station's copy is stale */
		}
		return r;
	}
	if (what == 1.0f) {
		r = mav_result(app_params_save(m->app, why, cap));
		if (r == MAV_RESULT_ACCEPTED)
			app_status(m->app, APP_SEV_INFO, "Parameters saved");
		return r;
	}
	snprintf(why, cap, "Storage: param1 must be 0 (read) or 1 (write)");
	return MAV_RESULT_DENIED;
}

/* MAV_CMD_REQUEST_MESSAGE (and REQUEST_AUTOPILOT_CAPABILITIES, as a request for
 * AUTOPILOT_VERSION): acknowledged, then the message sent. Returns false when no module
 * has message `id` (UNSUPPORTED). */
static bool cmd_request_message(struct mav *m, const mavlink_message_t *req, uint16_t cmd, float id, float param2)
{
	if (id == (float)MAVLINK_MSG_ID_AUTOPILOT_VERSION) {
		send_ack(m, cmd, MAV_RESULT_ACCEPTED, req);
		send_autopilot_version(m);
		return true;
	}
	if (!(id >= 0.0f && id < 65536.0f))
		return false;
	uint32_t msgid = (uint32_t)id;
	struct app_view v = app_view(m->app);
	int s = stream_index(msgid);
	if (s >= 0) {
		/* the live estimates exist only while an experiment runs */
		bool now = !streams[s].direct || v.mode == APP_EXPERIMENT;
		send_ack(m, cmd, now ? MAV_RESULT_ACCEPTED : MAV_RESULT_TEMPORARILY_REJECTED, req);
		if (now)
			send_stream(m, &v, s);
		return true;
	}
	if (msgid == MAVLINK_MSG_ID_OCTO_ID_RESULT) {
		uint8_t r = id_results_request(&v, param2);
		send_ack(m, cmd, r, req);
		if (r == MAV_RESULT_ACCEPTED)
			send_id_results(m, &v, param2);
		return true;
	}
	if (mav_ftp_is_metadata_msg(&m->ftp, msgid)) {
		send_ack(m, cmd, MAV_RESULT_ACCEPTED, req);
		struct mav_ftp_link l = ftp_link(m, req);
		mav_ftp_send_metadata_msg(&m->ftp, &l, msgid, send_cb);
		return true;
	}
	int tr = mav_telem_request_result(&m->telem, msgid, param2);
	if (tr < 0)
		return false;
	send_ack(m, cmd, (uint8_t)tr, req);
	if (tr == MAV_RESULT_ACCEPTED) {
		struct mav_telem_in in = telem_in(m, &v);
		mav_telem_request_send(&m->telem, &in, msgid, param2, send_cb);
	}
	return true;
}

/* MAV_CMD_GET_MESSAGE_INTERVAL: ACK, then MESSAGE_INTERVAL with the interval in us,
 * -1 disabled, 0 not available. */
static void cmd_get_interval(struct mav *m, const mavlink_message_t *req, uint16_t cmd, float msgid)
{
	int32_t us = 0;
	bool valid = msgid >= 0.0f && msgid < 65536.0f;
	uint16_t id = valid ? (uint16_t)msgid : 0;
	int s = valid ? stream_index(id) : -1;
	if (s >= 0)
		us = m->interval_us[s] < 0 ? -1 : (int32_t)m->interval_us[s];
	else if (!mav_telem_get_interval(&m->telem, id, &us))
		us = 0;
	send_ack(m, cmd, MAV_RESULT_ACCEPTED, req);
	mavlink_message_t out;
	mavlink_msg_message_interval_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &out, id, us);
	send_msg(m, &out);
}

/* MAV_CMD_SET_MESSAGE_INTERVAL: this module's streams, or the telemetry module's. */
static uint8_t cmd_set_interval(struct mav *m, float msgid, float interval_us)
{
	int s = msgid >= 0.0f && msgid < 65536.0f ? stream_index((uint32_t)msgid) : -1;
	int t = s < 0 && msgid >= 0.0f && msgid < 65536.0f
			? mav_telem_set_interval(&m->telem, (uint32_t)msgid, interval_us)
			: -1;
	if (t >= 0)
		return (uint8_t)t;
	if (s < 0)
		return MAV_RESULT_UNSUPPORTED;
	return mav_interval_of_request(interval_us, streams[s].default_interval_us, &m->interval_us[s])
		       ? MAV_RESULT_ACCEPTED
		       : MAV_RESULT_DENIED;
}

static void handle_command(struct mav *m, const mavlink_message_t *req, uint16_t cmd, const float prm[7])
{
	struct app *a = m->app;
	char why[64] = {0};
	uint8_t r = MAV_RESULT_UNSUPPORTED;
	switch (cmd) {
	case MAV_CMD_COMPONENT_ARM_DISARM:
		if (prm[0] == 1.0f || prm[0] == 0.0f)
			r = mav_result(app_cmd_arm(a, prm[0] == 1.0f, prm[1] == 21196.0f, why, sizeof why));
		else {
			r = MAV_RESULT_DENIED;
			snprintf(why, sizeof why, "Arm/disarm: param1 must be 0 or 1");
		}
		break;
	case MAV_CMD_NAV_TAKEOFF: r = mav_result(app_cmd_takeoff(a, prm[6], origin_of(req), why, sizeof why)); break;
	case MAV_CMD_NAV_LAND: r = mav_result(app_cmd_land(a, origin_of(req), why, sizeof why)); break;
	case MAV_CMD_USER_1:
		if (cmd_experiment(m, req, cmd, prm[0], &r, why, sizeof why))
			return;
		break;
	case MAV_CMD_PREFLIGHT_STORAGE: r = cmd_storage(m, prm[0], why, sizeof why); break;
	case MAV_CMD_REQUEST_MESSAGE:
	case MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
		if (cmd_request_message(
			    m, req, cmd,
			    cmd == MAV_CMD_REQUEST_MESSAGE ? prm[0] : (float)MAVLINK_MSG_ID_AUTOPILOT_VERSION, prm[1]))
			return;
		r = MAV_RESULT_UNSUPPORTED;
		break;
	case MAV_CMD_GET_HOME_POSITION: {
		int tr = mav_telem_request_result(&m->telem, MAVLINK_MSG_ID_HOME_POSITION, 0.0f);
		send_ack(m, cmd, (uint8_t)tr, req);
		if (tr == MAV_RESULT_ACCEPTED) {
			struct app_view v = app_view(a);
			struct mav_telem_in in = telem_in(m, &v);
			mav_telem_request_send(&m->telem, &in, MAVLINK_MSG_ID_HOME_POSITION, 0.0f, send_cb);
		}
		return;
	}
	case MAV_CMD_GET_MESSAGE_INTERVAL: cmd_get_interval(m, req, cmd, prm[0]); return;
	case MAV_CMD_SET_MESSAGE_INTERVAL: r = cmd_set_interval(m, prm[0], prm[1]); break;
	default: r = MAV_RESULT_UNSUPPORTED; break;
	}
	send_ack(m, cmd, r, req);
	if (why[0])
		app_status(a, r == MAV_RESULT_ACCEPTED ? APP_SEV_INFO : APP_SEV_WARNING, "%s", why);
}

static void handle_ftp(struct mav *m, const mavlink_message_t *msg)
{
	mavlink_file_transfer_protocol_t ftp;
	mavlink_msg_file_transfer_protocol_decode(msg, &ftp);
	if (!for_us(ftp.target_system, ftp.target_component))
		return;
	struct mav_ftp_link l = ftp_link(m, msg);
	mav_ftp_handle(&m->ftp, &l, ftp.payload, send_cb);
}

static void handle(struct mav *m, const mavlink_message_t *msg)
{
	m->rx_msgs++;
	if (msg->sysid == MAV_SYSID && msg->compid == MAV_COMPID)
		return; /* our own echo */
	switch (msg->msgid) {
	case MAVLINK_MSG_ID_HEARTBEAT:
		m->gcs_sysid = msg->sysid;
		m->gcs_compid = msg->compid;
		break;
	case MAVLINK_MSG_ID_PARAM_REQUEST_LIST: {
		mavlink_param_request_list_t pl;
		mavlink_msg_param_request_list_decode(msg, &pl);
		if (for_us(pl.target_system, pl.target_component))
			m->param_next = 0; /* (re)start the paced stream */
		break;
	}
	case MAVLINK_MSG_ID_PARAM_REQUEST_READ: handle_param_read(m, msg); break;
	case MAVLINK_MSG_ID_PARAM_SET: handle_param_set(m, msg); break;
	case MAVLINK_MSG_ID_COMMAND_LONG: {
		mavlink_command_long_t c;
		mavlink_msg_command_long_decode(msg, &c);
		if (!for_us(c.target_system, c.target_component))
			break;
		const float prm[7] = {c.param1, c.param2, c.param3, c.param4, c.param5, c.param6, c.param7};
		handle_command(m, msg, c.command, prm);
		break;
	}
	case MAVLINK_MSG_ID_COMMAND_INT: {
		mavlink_command_int_t c;
		mavlink_msg_command_int_decode(msg, &c);
		if (!for_us(c.target_system, c.target_component))
			break;
		const float prm[7] = {c.param1, c.param2, c.param3, c.param4, (float)c.x, (float)c.y, c.z};
		handle_command(m, msg, c.command, prm);
		break;
	}
	case MAVLINK_MSG_ID_MISSION_REQUEST_LIST: {
		mavlink_mission_request_list_t r;
		mavlink_msg_mission_request_list_decode(msg, &r);
		if (!for_us(r.target_system, r.target_component))
			break;
		mavlink_message_t out;
		mavlink_msg_mission_count_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &out, msg->sysid, msg->compid, 0,
						    r.mission_type);
		send_msg(m, &out);
		break;
	}
	case MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL: handle_ftp(m, msg); break;
	case MAVLINK_MSG_ID_SET_GPS_GLOBAL_ORIGIN: {
		mavlink_set_gps_global_origin_t o;
		mavlink_msg_set_gps_global_origin_decode(msg, &o);
		struct app_view v = app_view(m->app);
		struct mav_telem_in in = telem_in(m, &v);
		if ((o.target_system == 0 || o.target_system == MAV_SYSID) &&
		    !mav_telem_set_origin(&m->telem, &in, o.latitude, o.longitude, o.altitude, send_cb))
			app_status(m->app, APP_SEV_WARNING, "Local origin kept: %s",
				   in.armed ? "armed" : "no position yet");
		break;
	}
	default: break;
	}
}

/* The app's events, translated: STATUSTEXT, PARAM_VALUE, the final COMMAND_ACK,
 * NAMED_VALUE_FLOAT, OCTO_ID_RESULT. */
static void drain(struct mav *m)
{
	struct app_event e;
	while (app_next_event(m->app, &e)) {
		switch (e.kind) {
		case APP_EV_STATUS: send_statustext(m, e.severity, e.text); break;
		case APP_EV_PARAM: send_param_value(m, e.param_index); break;
		case APP_EV_CMD_DONE:
			if (e.cmd == APP_CMD_EXPERIMENT || e.cmd == APP_CMD_TAKEOFF || e.cmd == APP_CMD_LAND)
				send_command_ack(
					m,
					e.cmd == APP_CMD_EXPERIMENT
						? MAV_CMD_USER_1
						: (e.cmd == APP_CMD_TAKEOFF ? MAV_CMD_NAV_TAKEOFF : MAV_CMD_NAV_LAND),
					mav_result((enum app_result)e.result), e.progress, (uint8_t)(e.origin >> 8),
					(uint8_t)e.origin);
			break;
		case APP_EV_VALUE: send_named_float(m, e.text, e.value); break;
		case APP_EV_ID_RESULT: send_id_result(m, &e.id); break;
		default: break;
		}
	}
}

size_t mav_receive(struct mav *m, const uint8_t *buf, size_t len)
{
	app_settle(m->app); /* commands see the results of the last step applied */
	mavlink_message_t msg;
	mavlink_status_t st;
	size_t accepted = 0;
	/* One datagram holds whole packets: a truncated packet at the end of the
	 * previous one must not swallow the start of this one. */
	mavlink_status_t *ch = mavlink_get_channel_status(CHAN);
	ch->parse_state = MAVLINK_PARSE_STATE_IDLE;
	ch->msg_received = MAVLINK_FRAMING_INCOMPLETE;
	for (size_t i = 0; i < len; i++) {
		/* mavlink_frame_char, not mavlink_parse_char: the latter hides why a
		 * frame failed, and rejections by signing are counted apart */
		uint8_t r = mavlink_frame_char(CHAN, buf[i], &msg, &st);
		if (r == MAVLINK_FRAMING_OK) {
			accepted++;
			handle(m, &msg);
		} else if (r == MAVLINK_FRAMING_BAD_CRC || r == MAVLINK_FRAMING_BAD_SIGNATURE) {
			if (r == MAVLINK_FRAMING_BAD_CRC)
				m->rx_dropped++;
			else
				m->rx_unsigned++;
			/* restart the parser as mavlink_parse_char does */
			mavlink_status_t *status = mavlink_get_channel_status(CHAN);
			mavlink_message_t *rx = mavlink_get_channel_buffer(CHAN);
			status->msg_received = MAVLINK_FRAMING_INCOMPLETE;
			status->parse_state = MAVLINK_PARSE_STATE_IDLE;
			if (buf[i] == MAVLINK_STX) {
				status->parse_state = MAVLINK_PARSE_STATE_GOT_STX;
				rx->len = 0;
				mavlink_start_checksum(rx);
			}
		}
	}
	drain(m);
	return accepted;
}

void mav_tick(struct mav *m, uint64_t now_us)
{
	drain(m);
	struct app_view v = app_view(m->app);
	struct mav_telem_in in = telem_in(m, &v);
	mav_telem_tick(&m->telem, &in, now_us, send_cb);
	for (int i = 0; i < MAV_N_STREAMS; i++) {
		if (m->interval_us[i] < 0)
			continue;
		if (m->last_us[i] && now_us - m->last_us[i] < (uint64_t)m->interval_us[i])
			continue;
		m->last_us[i] = now_us;
		send_stream(m, &v, i);
	}
	for (int k = 0; k < PARAM_PER_TICK && m->param_next >= 0; k++) {
		if (m->param_last_us && now_us - m->param_last_us < PARAM_PACE_US)
			break;
		send_param_value(m, (size_t)m->param_next);
		m->param_last_us = now_us;
		if (++m->param_next >= (long)param_count)
			m->param_next = -1;
	}
}
