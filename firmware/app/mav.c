/* mav.c - MAVLink 2 endpoint: telemetry table, parameters, commands (see mav.h). */
#include "mav.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include <octo/mavlink.h>

#include "app.h"
#include "mav_ftp.h"
#include "mav_telem.h"

#define CHAN MAVLINK_COMM_0
#define PARAM_PACE_US 2000u        /* list streaming: one PARAM_VALUE per 2 ms */
#define PARAM_PER_TICK 4
#define TEXT_BURST 50.0f           /* STATUSTEXT: burst of 50, then 20 per second */
#define TEXT_RATE 20.0f
#define FW_VERSION 0x00050000u     /* 0.5.0 */

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

static void send_msg(const struct app *a, const mavlink_message_t *msg)
{
	uint8_t buf[MAVLINK_MAX_PACKET_LEN];
	uint16_t n = mavlink_msg_to_send_buffer(buf, msg);
	hal_ground_send(a->hal, buf, n);
}

static uint32_t boot_ms(const struct app *a)
{
	return (uint32_t)((hal_wall_us(a->hal) - a->mav.boot_us) / 1000u);
}

static void send_named_float(const struct app *a, const char *name, float value);

/* The sender handed to the telemetry and FTP modules (their context is the app). */
static void send_cb(const void *ctx, const mavlink_message_t *msg)
{
	send_msg(ctx, msg);
}

static struct mav_telem_in telem_in(const struct app *a)
{
	float thr = 0.0f;
	for (int j = 0; j < HAL_ROTORS; j++)
		thr += a->thr[j] / (float)HAL_ROTORS;
	return (struct mav_telem_in){boot_ms(a), &a->fr, a->have_step && a->link_ok, a->mode != APP_DISARMED,
				     a->have_step && a->link_ok, (uint32_t)a->mode, thr, MAV_SYSID, MAV_COMPID, CHAN,
				     a};
}

static struct mav_ftp_link ftp_link(const struct app *a, const mavlink_message_t *req)
{
	return (struct mav_ftp_link){MAV_SYSID, MAV_COMPID, CHAN, req->sysid, req->compid, boot_ms(a), a};
}

/* ---------------------------------------------------------------- telemetry table
 * The pack functions read the app through a const view: telemetry never changes it. */

static void pack_heartbeat(const struct app *a, mavlink_message_t *msg)
{
	uint8_t base = mav_telem_base_mode(a->mode != APP_DISARMED);
	uint8_t status = MAV_STATE_STANDBY;
	if (app_flying(a))
		status = a->link_ok ? MAV_STATE_ACTIVE : MAV_STATE_CRITICAL;
	mavlink_msg_heartbeat_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, msg, MAV_TYPE_OCTOROTOR,
					MAV_AUTOPILOT_GENERIC, base, (uint32_t)a->mode, status);
}

/* Telemetry leaves in MAVLink's NED / forward-right-down conventions. */
static void pack_attitude_q(const struct app *a, mavlink_message_t *msg)
{
	const struct hal_sensor_frame *f = &a->fr;
	const float zero[4] = {0, 0, 0, 0};
	mavlink_msg_attitude_quaternion_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, msg, boot_ms(a),
						  f->q_ib[0], f->q_ib[1], -f->q_ib[2], -f->q_ib[3],
						  f->rate_b_rps[0], -f->rate_b_rps[1],
						  -f->rate_b_rps[2], zero);
}

static void pack_actuator(const struct app *a, mavlink_message_t *msg)
{
	float act[32] = {0};
	for (int j = 0; j < HAL_ROTORS; j++)
		act[j] = a->thr[j];
	mavlink_msg_actuator_output_status_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, msg,
						     (uint64_t)boot_ms(a) * 1000u, 0xFFu, act);
}

static uint16_t pwm(float t)
{
	t = t < 0.0f ? 0.0f : (t > 1.0f ? 1.0f : t);
	return (uint16_t)(1000.0f + 1000.0f * t + 0.5f);
}

static void pack_servo(const struct app *a, mavlink_message_t *msg)
{
	const float *t = a->thr;
	mavlink_msg_servo_output_raw_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, msg, boot_ms(a) * 1000u, 0,
					       pwm(t[0]), pwm(t[1]), pwm(t[2]), pwm(t[3]), pwm(t[4]),
					       pwm(t[5]), pwm(t[6]), pwm(t[7]), 0, 0, 0, 0, 0, 0, 0, 0);
}

static void pack_sys_status(const struct app *a, mavlink_message_t *msg)
{
	struct hal_plant_stats ls;
	hal_plant_stats(a->hal, &ls);
	uint16_t drops = (uint16_t)(ls.dropped > 65535u ? 65535u : ls.dropped);
	uint32_t present, enabled, health;
	struct mav_telem_in in = telem_in(a);
	mav_telem_sensors(&in, &present, &enabled, &health);
	mavlink_msg_sys_status_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, msg, present, enabled, health, 0, UINT16_MAX,
					 -1, -1, 0,
					 (uint16_t)(a->mav.rx_dropped > 65535u ? 65535u : a->mav.rx_dropped),
					 drops, (uint16_t)(ls.foreign > 65535u ? 65535u : ls.foreign),
					 (uint16_t)(a->mav.text_dropped > 65535u ? 65535u : a->mav.text_dropped),
					 (uint16_t)(a->mav.rx_unsigned > 65535u ? 65535u : a->mav.rx_unsigned), 0, 0, 0);
}

/* NAMED_VALUE_FLOAT of the live estimates: packs nothing itself (several
 * messages), sends them directly; returns false so the table sends nothing. */
static void pack_estimates(const struct app *a, mavlink_message_t *msg)
{
	(void)msg;
	if (a->mode != APP_EXPERIMENT)
		return;
	static const char *const with_sd[] = {"KF", "KTAU", "IXX", "IYY", "IZZ"};
	for (int i = 0; i < a->exp.n_est && i < EXP_MAX_EST; i++) {
		if (!(a->exp.est_live & (1u << i)))
			continue;
		send_named_float(a, a->exp.est_name[i], a->exp.est[i]);
		for (size_t k = 0; k < sizeof with_sd / sizeof with_sd[0]; k++)
			if (!strcmp(a->exp.est_name[i], with_sd[k])) {
				char name[16];
				snprintf(name, sizeof name, "%s_SD", with_sd[k]);
				send_named_float(a, name, a->exp.est_sd[i]);
			}
	}
}

struct mav_stream {
	uint32_t msgid;
	uint32_t default_interval_us;
	void (*pack)(const struct app *a, mavlink_message_t *msg); /* reads a const view of the app */
	bool direct;   /* pack sends itself (zero or several messages) */
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

static void send_stream(struct app *a, int i)
{
	mavlink_message_t msg;
	streams[i].pack(a, &msg);
	if (!streams[i].direct)
		send_msg(a, &msg);
}

void mav_init(struct mav *m, const struct hal *hal, uint64_t now_us)
{
	memset(m, 0, sizeof *m);
	for (int i = 0; i < MAV_N_STREAMS; i++)
		m->interval_us[i] = streams[i].default_interval_us;
	m->param_next = -1;
	m->boot_us = now_us;
	m->text_tokens = TEXT_BURST;
	m->text_last_us = now_us;
	mav_telem_init(&m->telem);
	(void)mav_ftp_init(&m->ftp);   /* without metadata, FTP NAKs everything and 395/397 are UNSUPPORTED */
	signing_setup(m, hal);
}

/* ---------------------------------------------------------------- outgoing helpers */

/* STATUSTEXT carries 50 characters. A longer line goes out as chunks sharing a nonzero id
 * (MAVLink 2's id and chunk_seq): 50 characters each, then a shorter, NUL-padded one that ends
 * the line (empty when the length is a multiple of 50). QGroundControl, MAVProxy and the
 * project's tools join the chunks; a receiver that does not shows them in order. A line of at
 * most 50 characters is one message with id 0. The rate limit admits a line whole or not at all. */
static void send_statustext(struct app *a, int severity, const char *text)
{
	enum { W = MAVLINK_MSG_STATUSTEXT_FIELD_TEXT_LEN };
	struct mav *m = &a->mav;
	size_t n = strlen(text);
	unsigned chunks = n <= W ? 1u : (unsigned)(n / W) + 1u;
	uint64_t now = hal_wall_us(a->hal);
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
		char buf[W];   /* zero-filled, full size */
		memset(buf, 0, sizeof buf);
		size_t at = (size_t)c * W, k = n - at < W ? n - at : W;
		memcpy(buf, text + at, k);
		mavlink_message_t msg;
		mavlink_msg_statustext_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &msg, sev, buf, id, (uint8_t)c);
		send_msg(a, &msg);
	}
}

static void send_named_float(const struct app *a, const char *name, float value)
{
	char buf[MAVLINK_MSG_NAMED_VALUE_FLOAT_FIELD_NAME_LEN];
	memset(buf, 0, sizeof buf);
	size_t n = strlen(name);
	memcpy(buf, name, n < sizeof buf ? n : sizeof buf);
	mavlink_message_t msg;
	mavlink_msg_named_value_float_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &msg, boot_ms(a), buf, value);
	send_msg(a, &msg);
}

static void send_param_value(struct app *a, size_t index)
{
	if (index >= param_count)
		return;
	char id[MAVLINK_MSG_PARAM_VALUE_FIELD_PARAM_ID_LEN];   /* 16, no NUL when full */
	memset(id, 0, sizeof id);
	size_t n = strlen(param_defs[index].name);
	memcpy(id, param_defs[index].name, n < sizeof id ? n : sizeof id);
	mavlink_message_t msg;
	mavlink_msg_param_value_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &msg, id, params_get(&a->p, index),
					  MAV_PARAM_TYPE_REAL32, (uint16_t)param_count, (uint16_t)index);
	send_msg(a, &msg);
}

static void send_command_ack(struct app *a, uint16_t cmd, uint8_t result, uint8_t progress, uint8_t sysid,
			     uint8_t compid)
{
	(void)a;
	mavlink_message_t msg;
	mavlink_msg_command_ack_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &msg, cmd, result, progress, 0, sysid,
					  compid);
	send_msg(a, &msg);
}

static void drain(struct app *a);

/* Every reply first drains the outbox: status lines the request caused go out before its answer. */
static void send_ack(struct app *a, uint16_t cmd, uint8_t result, const mavlink_message_t *req)
{
	drain(a);
	send_command_ack(a, cmd, result, 0, req->sysid, req->compid);
}

static void send_autopilot_version(struct app *a)
{
	uint8_t custom[8] = {0}, uid2[18] = {0};
	memcpy(custom, "octofw05", 8);
	mavlink_message_t msg;
	mavlink_msg_autopilot_version_pack_chan(
		MAV_SYSID, MAV_COMPID, CHAN, &msg,
		MAV_PROTOCOL_CAPABILITY_MAVLINK2 | MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE |
			MAV_PROTOCOL_CAPABILITY_COMMAND_INT,
		FW_VERSION, 0, 0, 0, custom, custom, custom, 0, 0, 1, uid2);
	send_msg(a, &msg);
}

/* ---------------------------------------------------------------- parameters */

static bool for_us(uint8_t tsys, uint8_t tcomp)
{
	return (tsys == 0 || tsys == MAV_SYSID) && (tcomp == 0 || tcomp == MAV_COMPID);
}

static void unknown_param(struct app *a, const char *id, int index)
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
		app_status(a, APP_SEV_WARNING, "Unknown parameter %s", name);
	else
		app_status(a, APP_SEV_WARNING, "Unknown parameter index %d", index);
}

static void handle_param_set(struct app *a, const mavlink_message_t *msg)
{
	mavlink_param_set_t ps;
	mavlink_msg_param_set_decode(msg, &ps);
	if (!for_us(ps.target_system, ps.target_component))
		return;
	int idx = params_find(ps.param_id, sizeof ps.param_id);
	if (idx < 0) {
		unknown_param(a, ps.param_id, -1);
		return;
	}
	const char *why = app_param_write(a, (size_t)idx, ps.param_value);
	if (why)
		app_status(a, APP_SEV_WARNING, "%s: %g refused (%s)", param_defs[idx].name,
			   (double)ps.param_value, why);
	drain(a);
	send_param_value(a, (size_t)idx);   /* always: the current value */
}

static void handle_param_read(struct app *a, const mavlink_message_t *msg)
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
		unknown_param(a, pr.param_index < 0 ? pr.param_id : "", pr.param_index);
		return;
	}
	send_param_value(a, (size_t)idx);
}

/* ---------------------------------------------------------------- commands */

static uint8_t mav_result(enum app_result r)
{
	switch (r) {
	case APP_ACCEPTED:
		return MAV_RESULT_ACCEPTED;
	case APP_IN_PROGRESS:
		return MAV_RESULT_IN_PROGRESS;
	case APP_BUSY:
		return MAV_RESULT_TEMPORARILY_REJECTED;
	case APP_DENIED:
		return MAV_RESULT_DENIED;
	case APP_FAILED:
		return MAV_RESULT_FAILED;
	case APP_UNSUPPORTED:
		break;
	}
	return MAV_RESULT_UNSUPPORTED;
}

/* The sender of a command, as the app keeps it (opaque to it). */
static app_origin origin_of(const mavlink_message_t *req)
{
	return (app_origin)req->sysid << 8 | req->compid;
}

static void handle_command(struct app *a, const mavlink_message_t *req, uint16_t cmd,
			   const float prm[7])
{
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
	case MAV_CMD_NAV_TAKEOFF:
		r = mav_result(app_cmd_takeoff(a, prm[6], origin_of(req), why, sizeof why));
		break;
	case MAV_CMD_NAV_LAND:
		r = mav_result(app_cmd_land(a, origin_of(req), why, sizeof why));
		break;
	case MAV_CMD_USER_1:
		/* long-running: IN_PROGRESS (with progress) now and on retries, the
		 * final ACCEPTED / FAILED when the experiment ends (app.c) */
		r = mav_result(app_cmd_experiment(a, prm[0], origin_of(req), why, sizeof why));
		if (r == MAV_RESULT_IN_PROGRESS) {
			/* progress in percent, rounded up (a started experiment shows >= 1),
			 * at most 99 until the final ACK */
			float pr = ceilf(a->exp.progress * 100.0f);
			drain(a);
			send_command_ack(a, cmd, r, (uint8_t)(pr < 0.0f ? 0.0f : (pr > 99.0f ? 99.0f : pr)),
					req->sysid, req->compid);
			if (why[0])
				app_status(a, APP_SEV_INFO, "%s", why);
			return;
		}
		break;
	case MAV_CMD_PREFLIGHT_STORAGE:
		if (prm[0] == 0.0f) {
			if (a->mode == APP_EXPERIMENT) {
				r = MAV_RESULT_TEMPORARILY_REJECTED;
				snprintf(why, sizeof why, "Parameter load refused: experiment running");
			} else {
				r = mav_result(app_params_load(a, why, sizeof why));
				if (r == MAV_RESULT_ACCEPTED) {
					app_status(a, APP_SEV_INFO, "Parameters loaded");
					a->mav.param_next = 0;   /* the ground station's copy is stale */
				}
			}
		} else if (prm[0] == 1.0f) {
			r = mav_result(app_params_save(a, why, sizeof why));
			if (r == MAV_RESULT_ACCEPTED)
				app_status(a, APP_SEV_INFO, "Parameters saved");
		} else {
			r = MAV_RESULT_DENIED;
			snprintf(why, sizeof why, "Storage: param1 must be 0 (read) or 1 (write)");
		}
		break;
	case MAV_CMD_REQUEST_MESSAGE:
	case MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: {
		float id = cmd == MAV_CMD_REQUEST_MESSAGE ? prm[0] : (float)MAVLINK_MSG_ID_AUTOPILOT_VERSION;
		if (id == (float)MAVLINK_MSG_ID_AUTOPILOT_VERSION) {
			r = MAV_RESULT_ACCEPTED;
			send_ack(a, cmd, r, req);
			send_autopilot_version(a);
			return;
		}
		int s = id >= 0.0f && id < 65536.0f ? stream_index((uint32_t)id) : -1;
		if (s >= 0) {
			/* the live estimates exist only while an experiment runs */
			bool now = !streams[s].direct || a->mode == APP_EXPERIMENT;
			send_ack(a, cmd, now ? MAV_RESULT_ACCEPTED : MAV_RESULT_TEMPORARILY_REJECTED, req);
			if (now)
				send_stream(a, s);
			return;
		}
		if (id >= 0.0f && id < 65536.0f && mav_ftp_is_metadata_msg(&a->mav.ftp, (uint32_t)id)) {
			send_ack(a, cmd, MAV_RESULT_ACCEPTED, req);
			struct mav_ftp_link l = ftp_link(a, req);
			mav_ftp_send_metadata_msg(&a->mav.ftp, &l, (uint32_t)id, send_cb);
			return;
		}
		int tr = id >= 0.0f && id < 65536.0f ? mav_telem_request_result(&a->mav.telem, (uint32_t)id, prm[1]) : -1;
		if (tr >= 0) {
			send_ack(a, cmd, (uint8_t)tr, req);
			if (tr == MAV_RESULT_ACCEPTED) {
				struct mav_telem_in in = telem_in(a);
				mav_telem_request_send(&a->mav.telem, &in, (uint32_t)id, prm[1], send_cb);
			}
			return;
		}
		r = MAV_RESULT_UNSUPPORTED;
		break;
	}
	case MAV_CMD_GET_HOME_POSITION: {
		int tr = mav_telem_request_result(&a->mav.telem, MAVLINK_MSG_ID_HOME_POSITION, 0.0f);
		send_ack(a, cmd, (uint8_t)tr, req);
		if (tr == MAV_RESULT_ACCEPTED) {
			struct mav_telem_in in = telem_in(a);
			mav_telem_request_send(&a->mav.telem, &in, MAVLINK_MSG_ID_HOME_POSITION, 0.0f, send_cb);
		}
		return;
	}
	case MAV_CMD_GET_MESSAGE_INTERVAL: {
		/* ACK, then MESSAGE_INTERVAL: the interval in us, -1 disabled, 0 not available */
		int32_t us = 0;
		uint16_t id = prm[0] >= 0.0f && prm[0] < 65536.0f ? (uint16_t)prm[0] : 0;
		int s = prm[0] >= 0.0f && prm[0] < 65536.0f ? stream_index(id) : -1;
		if (s >= 0)
			us = a->mav.interval_us[s] < 0 ? -1 : (int32_t)a->mav.interval_us[s];
		else if (!mav_telem_get_interval(&a->mav.telem, id, &us))
			us = 0;
		send_ack(a, cmd, MAV_RESULT_ACCEPTED, req);
		mavlink_message_t out;
		mavlink_msg_message_interval_pack_chan(MAV_SYSID, MAV_COMPID, CHAN, &out, id, us);
		send_msg(a, &out);
		return;
	}
	case MAV_CMD_SET_MESSAGE_INTERVAL: {
		int s = prm[0] >= 0.0f && prm[0] < 65536.0f ? stream_index((uint32_t)prm[0]) : -1;
		int t = s < 0 && prm[0] >= 0.0f && prm[0] < 65536.0f
				? mav_telem_set_interval(&a->mav.telem, (uint32_t)prm[0], prm[1]) : -1;
		if (t >= 0) {
			r = (uint8_t)t;
		} else if (s < 0) {
			r = MAV_RESULT_UNSUPPORTED;
		} else if (!isfinite(prm[1])) {
			r = MAV_RESULT_DENIED;
		} else {
			if (prm[1] < 0.0f)
				a->mav.interval_us[s] = -1;
			else if (prm[1] == 0.0f)
				a->mav.interval_us[s] = streams[s].default_interval_us;
			else   /* 10 ms .. 1000 s: a huge float must not reach the integer cast */
				a->mav.interval_us[s] = prm[1] < 10000.0f ? 10000
							: (prm[1] > 1.0e9f ? 1000000000 : (int64_t)prm[1]);
			r = MAV_RESULT_ACCEPTED;
		}
		break;
	}
	default:
		r = MAV_RESULT_UNSUPPORTED;
		break;
	}
	send_ack(a, cmd, r, req);
	if (why[0])
		app_status(a, r == MAV_RESULT_ACCEPTED ? APP_SEV_INFO : APP_SEV_WARNING, "%s", why);
}

static void handle_ftp(struct app *a, const mavlink_message_t *msg)
{
	mavlink_file_transfer_protocol_t ftp;
	mavlink_msg_file_transfer_protocol_decode(msg, &ftp);
	if (!for_us(ftp.target_system, ftp.target_component))
		return;
	struct mav_ftp_link l = ftp_link(a, msg);
	mav_ftp_handle(&a->mav.ftp, &l, ftp.payload, send_cb);
}

static void handle(struct app *a, const mavlink_message_t *msg)
{
	struct mav *m = &a->mav;
	m->rx_msgs++;
	if (msg->sysid == MAV_SYSID && msg->compid == MAV_COMPID)
		return;   /* our own echo */
	switch (msg->msgid) {
	case MAVLINK_MSG_ID_HEARTBEAT:
		m->gcs_sysid = msg->sysid;
		m->gcs_compid = msg->compid;
		break;
	case MAVLINK_MSG_ID_PARAM_REQUEST_LIST: {
		mavlink_param_request_list_t pl;
		mavlink_msg_param_request_list_decode(msg, &pl);
		if (for_us(pl.target_system, pl.target_component))
			m->param_next = 0;   /* (re)start the paced stream */
		break;
	}
	case MAVLINK_MSG_ID_PARAM_REQUEST_READ:
		handle_param_read(a, msg);
		break;
	case MAVLINK_MSG_ID_PARAM_SET:
		handle_param_set(a, msg);
		break;
	case MAVLINK_MSG_ID_COMMAND_LONG: {
		mavlink_command_long_t c;
		mavlink_msg_command_long_decode(msg, &c);
		if (!for_us(c.target_system, c.target_component))
			break;
		const float prm[7] = {c.param1, c.param2, c.param3, c.param4, c.param5, c.param6, c.param7};
		handle_command(a, msg, c.command, prm);
		break;
	}
	case MAVLINK_MSG_ID_COMMAND_INT: {
		mavlink_command_int_t c;
		mavlink_msg_command_int_decode(msg, &c);
		if (!for_us(c.target_system, c.target_component))
			break;
		const float prm[7] = {c.param1, c.param2, c.param3, c.param4, (float)c.x, (float)c.y, c.z};
		handle_command(a, msg, c.command, prm);
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
		send_msg(a, &out);
		break;
	}
	case MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL:
		handle_ftp(a, msg);
		break;
	case MAVLINK_MSG_ID_SET_GPS_GLOBAL_ORIGIN: {
		mavlink_set_gps_global_origin_t o;
		mavlink_msg_set_gps_global_origin_decode(msg, &o);
		struct mav_telem_in in = telem_in(a);
		if ((o.target_system == 0 || o.target_system == MAV_SYSID) &&
		    !mav_telem_set_origin(&m->telem, &in, o.latitude, o.longitude, o.altitude, send_cb))
			app_status(a, APP_SEV_WARNING, "Local origin kept: %s",
				   in.armed ? "armed" : "no position yet");
		break;
	}
	default:
		break;
	}
}

/* The app's events, translated: STATUSTEXT, PARAM_VALUE, the final COMMAND_ACK. */
static void drain(struct app *a)
{
	struct app_event e;
	while (outbox_pop(&a->outbox, &e)) {
		switch (e.kind) {
		case APP_EV_STATUS:
			send_statustext(a, e.severity, e.text);
			break;
		case APP_EV_PARAM:
			send_param_value(a, e.param_index);
			break;
		case APP_EV_CMD_DONE:
			if (e.cmd == APP_CMD_EXPERIMENT || e.cmd == APP_CMD_TAKEOFF || e.cmd == APP_CMD_LAND)
				send_command_ack(a, e.cmd == APP_CMD_EXPERIMENT ? MAV_CMD_USER_1
						    : (e.cmd == APP_CMD_TAKEOFF ? MAV_CMD_NAV_TAKEOFF : MAV_CMD_NAV_LAND),
						 mav_result((enum app_result)e.result), e.progress,
						 (uint8_t)(e.origin >> 8), (uint8_t)e.origin);
			break;
		case APP_EV_VALUE:
			send_named_float(a, e.text, e.value);
			break;
		default:
			break;
		}
	}
}

size_t mav_receive(struct app *a, const uint8_t *buf, size_t len)
{
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
			handle(a, &msg);
		} else if (r == MAVLINK_FRAMING_BAD_CRC || r == MAVLINK_FRAMING_BAD_SIGNATURE) {
			if (r == MAVLINK_FRAMING_BAD_CRC)
				a->mav.rx_dropped++;
			else
				a->mav.rx_unsigned++;
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
	drain(a);
	return accepted;
}

void mav_tick(struct app *a, uint64_t now_us)
{
	struct mav *m = &a->mav;
	drain(a);
	struct mav_telem_in in = telem_in(a);
	mav_telem_tick(&m->telem, &in, now_us, send_cb);
	for (int i = 0; i < MAV_N_STREAMS; i++) {
		if (m->interval_us[i] < 0)
			continue;
		if (m->last_us[i] && now_us - m->last_us[i] < (uint64_t)m->interval_us[i])
			continue;
		m->last_us[i] = now_us;
		send_stream(a, i);
	}
	for (int k = 0; k < PARAM_PER_TICK && m->param_next >= 0; k++) {
		if (m->param_last_us && now_us - m->param_last_us < PARAM_PACE_US)
			break;
		send_param_value(a, (size_t)m->param_next);
		m->param_last_us = now_us;
		if (++m->param_next >= (long)param_count)
			m->param_next = -1;
	}
}
