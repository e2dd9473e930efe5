/* script.c - the ground station's steps on the platform's clock (see script.h). */
#include "script.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <common/mavlink.h>

#define GCS_SYSID 255
#define GCS_COMPID 190
#define STEP_TEXT 96
#define MAX_STEPS 512
#define SEEN_TEXT 256

enum step_kind {
	ST_PARAM,
	ST_ARM,
	ST_TAKEOFF,
	ST_WAIT_HOLD,
	ST_EXPERIMENT,
	ST_WAIT_EXP,
	ST_LAND,
	ST_WAIT_DISARMED,
	ST_SLEEP
};

/* How long a step may take (platform clock, s) and how often a refused command
 * is retried (arm: until the vehicle has frames; experiment: until it hovers, or while it answers
 * TEMPORARILY_REJECTED). */
static const double step_timeout_s[] = {
	[ST_PARAM] = 1.0,       [ST_ARM] = 10.0,         [ST_TAKEOFF] = 1.0, [ST_WAIT_HOLD] = 60.0,
	[ST_EXPERIMENT] = 10.0, [ST_WAIT_EXP] = 30000.0, [ST_LAND] = 1.0,    [ST_WAIT_DISARMED] = 120.0,
	[ST_SLEEP] = 0.0,
};
#define RETRY_S 0.5

struct step {
	enum step_kind kind;
	char name[17];
	float value;
	char text[STEP_TEXT]; /* the step as written, for messages */
};

/* What the app last said on MAVLink, decoded as a ground station would: acknowledgements,
 * parameter values, and the status lines (STATUSTEXT) that carry the firmware's reasons. */
struct seen {
	bool ack; /* a COMMAND_ACK since the last clear */
	uint16_t ack_command;
	uint8_t ack_result;
	bool exp_final; /* the final ACK of MAV_CMD_USER_1 arrived */
	uint8_t exp_result;
	bool param; /* a PARAM_VALUE since the last clear */
	char param_id[17];
	float param_value;
	uint64_t texts;            /* reports seen so far */
	char text[SEEN_TEXT];      /* the last STATUSTEXT */
	char id_text[SEEN_TEXT];   /* the last "ID ..." STATUSTEXT */
	bool phase_failed;         /* a final COMMAND_ACK FAILED of take-off or landing (its time limit) */
	char fail_text[SEEN_TEXT]; /* the last error line saying "failed", and the error lines after it */
	char chunks[SEEN_TEXT];    /* a long STATUSTEXT's chunks so far (id chunk_id, next chunk_next) */
	uint16_t chunk_id;
	uint8_t chunk_next;
};

struct script {
	struct step steps[MAX_STEPS];
	size_t n, cur;
	bool begun;     /* the current step has started */
	bool quiet;     /* no line per step done */
	uint64_t t0_us; /* when it started */
	uint64_t last_try_us;
	char msg[640];
	/* the vehicle and the time of the script_run in progress */
	struct app *app;
	struct mav *mav; /* the vehicle's MAVLink endpoint: the path a ground station's bytes take */
	uint64_t now_us;
	/* MAVLink parser and sender state (the library's per-channel globals are not used):
	 * the app's output is parsed here, the script's messages are sequenced here */
	mavlink_message_t rx_msg;
	mavlink_status_t rx_status, gcs_tx;
	struct seen seen;
};

/* ---------------------------------------------------------------- parsing */

static char *trim(char *s)
{
	while (isspace((unsigned char)*s))
		s++;
	char *e = s + strlen(s);
	while (e > s && isspace((unsigned char)e[-1]))
		*--e = 0;
	return s;
}

static bool number(const char *s, float *out)
{
	char *e = NULL;
	errno = 0;
	double d = strtod(s, &e);
	if (!*s || *e || errno || !isfinite(d))
		return false;
	*out = (float)d;
	return true;
}

static int parse_step(char *text, struct step *st)
{
	char *w[4] = {0};
	int n = 0;
	char *save = NULL;
	for (char *tok = strtok_r(text, " \t", &save); tok; tok = strtok_r(NULL, " \t", &save)) {
		if (n == 4)
			return -1;
		w[n++] = tok;
	}
	if (n == 3 && !strcmp(w[0], "param")) {
		if (strlen(w[1]) > 16)
			return -1;
		snprintf(st->name, sizeof st->name, "%s", w[1]);
		st->kind = ST_PARAM;
		return number(w[2], &st->value) ? 0 : -1;
	}
	if (n == 1 && !strcmp(w[0], "arm"))
		return st->kind = ST_ARM, 0;
	if (n == 2 && !strcmp(w[0], "takeoff")) {
		st->kind = ST_TAKEOFF;
		return number(w[1], &st->value) && st->value > 0.0f ? 0 : -1;
	}
	if (n == 2 && !strcmp(w[0], "wait") && !strcmp(w[1], "hold"))
		return st->kind = ST_WAIT_HOLD, 0;
	if (n == 2 && !strcmp(w[0], "wait") && !strcmp(w[1], "experiment"))
		return st->kind = ST_WAIT_EXP, 0;
	if (n == 2 && !strcmp(w[0], "wait") && !strcmp(w[1], "disarmed"))
		return st->kind = ST_WAIT_DISARMED, 0;
	if (n == 2 && !strcmp(w[0], "experiment")) {
		st->kind = ST_EXPERIMENT;
		return number(w[1], &st->value) && st->value >= 1.0f && st->value <= 6.0f &&
				       st->value == floorf(st->value)
			       ? 0
			       : -1;
	}
	if (n == 1 && !strcmp(w[0], "land"))
		return st->kind = ST_LAND, 0;
	if (n == 2 && !strcmp(w[0], "sleep")) {
		st->kind = ST_SLEEP;
		return number(w[1], &st->value) && st->value >= 0.0f ? 0 : -1;
	}
	return -1;
}

struct script *script_parse(const char *spec, bool quiet)
{
	char *text = NULL;
	FILE *f = fopen(spec, "rb");
	if (f) {
		size_t cap = 1 << 16, n = 0;
		text = malloc(cap + 1);
		if (text)
			n = fread(text, 1, cap, f);
		bool more = fgetc(f) != EOF;
		fclose(f);
		if (!text)
			return NULL;
		if (more) {
			fprintf(stderr, "octo-sil: --script: %s is longer than %zu bytes\n", spec, cap);
			free(text);
			return NULL;
		}
		text[n] = 0;
	} else {
		text = strdup(spec);
		if (!text)
			return NULL;
	}
	struct script *m = calloc(1, sizeof *m);
	if (!m) {
		free(text);
		return NULL;
	}
	m->quiet = quiet;
	/* steps: lines and ';'; '#' to the end of the line is a comment */
	char *p = text;
	int line = 1;
	while (*p) {
		size_t len = strcspn(p, "\n;");
		char sep = p[len];
		p[len] = 0;
		char *hash = strchr(p, '#');
		if (hash)
			*hash = 0;
		char *t = trim(p);
		if (*t) {
			struct step st;
			memset(&st, 0, sizeof st);
			snprintf(st.text, sizeof st.text, "%s", t);
			char work[256];
			snprintf(work, sizeof work, "%s", t);
			if (m->n == MAX_STEPS || parse_step(work, &st)) {
				fprintf(stderr,
					"octo-sil: --script: line %d: '%s' is not a step (param NAME VALUE, arm, takeoff H, wait "
					"hold, experiment 1..6, wait experiment, land, wait disarmed, sleep S)%s\n",
					line, st.text, m->n == MAX_STEPS ? " (too many steps)" : "");
				free(m);
				free(text);
				return NULL;
			}
			m->steps[m->n++] = st;
		}
		if (sep == '\n')
			line++;
		p += len + (sep ? 1 : 0);
	}
	free(text);
	if (!m->n) {
		fprintf(stderr, "octo-sil: --script: no steps\n");
		free(m);
		return NULL;
	}
	return m;
}

void script_free(struct script *m) { free(m); }

const char *script_pending(struct script *m)
{
	if (m->cur >= m->n)
		return "all steps completed";
	snprintf(m->msg, sizeof m->msg, "step %zu '%s' still running", m->cur + 1, m->steps[m->cur].text);
	return m->msg;
}

/* ---------------------------------------------------------------- the vehicle's answers */

static void note_text(struct script *m, const char *text, int severity)
{
	snprintf(m->seen.text, sizeof m->seen.text, "%s", text);
	if (severity <= MAV_SEVERITY_ERROR) {
		/* the firmware's reason for a failure: its "... failed: ..." line and what it adds */
		char *f = m->seen.fail_text;
		size_t n = strlen(f);
		if (strstr(text, "failed"))
			snprintf(f, sizeof m->seen.fail_text, "%s", text);
		else if (n > 0 && n < sizeof m->seen.fail_text)
			snprintf(f + n, sizeof m->seen.fail_text - n, "; %s", text);
	}
	if (!strncmp(text, "ID", 2))
		snprintf(m->seen.id_text, sizeof m->seen.id_text, "%s", text);
	m->seen.texts++;
}

/* A STATUSTEXT: id 0 is a whole line; a nonzero id is one chunk of a long line, joined until
 * the chunk that is not full (its NUL ends the line). A chunk out of order restarts the line
 * from what arrived, marked "[...]" (the link is in-process: only a bug could cause it). */
static void note_chunk(struct script *m, const mavlink_statustext_t *t)
{
	enum { W = MAVLINK_MSG_STATUSTEXT_FIELD_TEXT_LEN };
	char text[W + 1];
	memcpy(text, t->text, W); /* no NUL when full */
	text[W] = 0;
	if (t->id == 0) {
		note_text(m, text, t->severity);
		return;
	}
	char *c = m->seen.chunks;
	if (t->id != m->seen.chunk_id || t->chunk_seq != m->seen.chunk_next) {
		snprintf(c, sizeof m->seen.chunks, "%s", t->chunk_seq == 0 ? "" : "[...]");
		m->seen.chunk_id = t->id;
	}
	size_t n = strlen(c);
	if (n < sizeof m->seen.chunks)
		snprintf(c + n, sizeof m->seen.chunks - n, "%s", text);
	m->seen.chunk_next = (uint8_t)(t->chunk_seq + 1u);
	if (strlen(text) < W) {
		note_text(m, c, t->severity);
		c[0] = 0;
		m->seen.chunk_id = 0;
	}
}

void script_on_vehicle(struct script *m, const uint8_t *buf, size_t len)
{
	/* The app hands over one message per call: only acknowledgements, parameter
	 * values and status lines concern the script, the telemetry is skipped by
	 * its id (MAVLink 2: 0xFD, then the id in bytes 7..9) without running the
	 * parser over it. */
	if (len >= 10 && buf[0] == MAVLINK_STX) {
		uint32_t id = (uint32_t)buf[7] | (uint32_t)buf[8] << 8 | (uint32_t)buf[9] << 16;
		if (id != MAVLINK_MSG_ID_COMMAND_ACK && id != MAVLINK_MSG_ID_PARAM_VALUE &&
		    id != MAVLINK_MSG_ID_STATUSTEXT)
			return;
	}
	mavlink_message_t msg;
	mavlink_status_t st;
	for (size_t i = 0; i < len; i++) {
		uint8_t r = mavlink_frame_char_buffer(&m->rx_msg, &m->rx_status, buf[i], &msg, &st);
		if (r == MAVLINK_FRAMING_BAD_CRC || r == MAVLINK_FRAMING_BAD_SIGNATURE)
			m->rx_status.parse_state = MAVLINK_PARSE_STATE_IDLE; /* as mavlink_parse_char does */
		if (r != MAVLINK_FRAMING_OK)
			continue;
		if (msg.msgid == MAVLINK_MSG_ID_COMMAND_ACK) {
			mavlink_command_ack_t a;
			mavlink_msg_command_ack_decode(&msg, &a);
			if (a.command == MAV_CMD_USER_1 && a.result != MAV_RESULT_IN_PROGRESS) {
				/* a refusal, or the final answer of a running experiment */
				m->seen.exp_final = true;
				m->seen.exp_result = a.result;
			}
			if ((a.command == MAV_CMD_NAV_TAKEOFF || a.command == MAV_CMD_NAV_LAND) &&
			    a.result == MAV_RESULT_FAILED)
				m->seen.phase_failed = true; /* the phase ran out of its time limit */
			m->seen.ack = true;
			m->seen.ack_command = a.command;
			m->seen.ack_result = a.result;
		} else if (msg.msgid == MAVLINK_MSG_ID_PARAM_VALUE) {
			mavlink_param_value_t v;
			mavlink_msg_param_value_decode(&msg, &v);
			memcpy(m->seen.param_id, v.param_id, 16);
			m->seen.param_id[16] = 0;
			m->seen.param_value = v.param_value;
			m->seen.param = true;
		} else if (msg.msgid == MAVLINK_MSG_ID_STATUSTEXT) {
			mavlink_statustext_t t;
			mavlink_msg_statustext_decode(&msg, &t);
			note_chunk(m, &t);
		}
	}
}

/* ---------------------------------------------------------------- commands */

static void send_msg(struct script *m, const mavlink_message_t *msg)
{
	uint8_t buf[MAVLINK_MAX_PACKET_LEN];
	uint16_t n = mavlink_msg_to_send_buffer(buf, msg);
	(void)mav_receive(m->mav, buf, n);
}

/* COMMAND_LONG to the vehicle; returns the MAV_RESULT of its COMMAND_ACK (-1:
 * none) and leaves the reason, when there is one, in m->seen.text. */
static int command(struct script *m, uint16_t cmd, float p1, float p7)
{
	mavlink_message_t msg;
	mavlink_msg_command_long_pack_status(GCS_SYSID, GCS_COMPID, &m->gcs_tx, &msg, 1, 1, cmd, 0, p1, 0, 0, 0, 0, 0,
					     p7);
	m->seen.ack = false;
	if (cmd == MAV_CMD_USER_1)
		m->seen.exp_final = false;
	m->seen.text[0] = 0;
	if (cmd == MAV_CMD_NAV_TAKEOFF || cmd == MAV_CMD_NAV_LAND || cmd == MAV_CMD_USER_1) {
		m->seen.phase_failed = false;
		m->seen.fail_text[0] = 0;
	}
	send_msg(m, &msg);
	if (!m->seen.ack || m->seen.ack_command != cmd)
		return -1;
	return m->seen.ack_result;
}

static const char *result_name(int r)
{
	switch (r) {
	case MAV_RESULT_ACCEPTED: return "ACCEPTED";
	case MAV_RESULT_TEMPORARILY_REJECTED: return "TEMPORARILY_REJECTED";
	case MAV_RESULT_DENIED: return "DENIED";
	case MAV_RESULT_UNSUPPORTED: return "UNSUPPORTED";
	case MAV_RESULT_FAILED: return "FAILED";
	case MAV_RESULT_IN_PROGRESS: return "IN_PROGRESS";
	case -1: return "no answer";
	default: return "unknown result";
	}
}

static int fail(struct script *m, const char *fmt, const char *detail)
{
	char what[420];
	snprintf(what, sizeof what, fmt, detail);
	snprintf(m->msg, sizeof m->msg, "step %zu '%s' failed at t=%.2f s: %s", m->cur + 1, m->steps[m->cur].text,
		 m->app->fr.t_s, what);
	fprintf(stderr, "octo-sil: script %s\n", m->msg);
	return -1;
}

int script_abort(struct script *m, struct app *app, struct mav *mav, const char *why)
{
	m->app = app;
	m->mav = mav;
	return fail(m, "%s", why);
}

static int refused(struct script *m, int r)
{
	char d[400];
	snprintf(d, sizeof d, "%s%s%s", result_name(r), m->seen.text[0] ? ": " : "", m->seen.text);
	return fail(m, "refused: %s", d);
}

static bool waited_too_long(const struct script *m)
{
	double limit = step_timeout_s[m->steps[m->cur].kind];
	return (double)(m->now_us - m->t0_us) * 1e-6 > limit;
}

static int wait_mode(struct script *m, enum app_mode want)
{
	if (m->app->mode == want)
		return 1;
	if (m->seen.phase_failed) /* the firmware gave up the phase: its reason, at once */
		return fail(m, "%s", m->seen.fail_text[0] ? m->seen.fail_text : "COMMAND_ACK FAILED, no reason given");
	if (!waited_too_long(m))
		return 0;
	char d[400];
	snprintf(d, sizeof d, "vehicle still in mode %s after %g s (last message: %s)", app_mode_name(m->app->mode),
		 step_timeout_s[m->steps[m->cur].kind], m->seen.text[0] ? m->seen.text : "none");
	return fail(m, "%s", d);
}

/* One step: 1 done, 0 running, -1 failed. */
static int step(struct script *m, const struct step *st, bool first)
{
	bool retry_due = first || (double)(m->now_us - m->last_try_us) * 1e-6 >= RETRY_S;
	switch (st->kind) {
	case ST_PARAM: {
		mavlink_message_t msg;
		mavlink_msg_param_set_pack_status(GCS_SYSID, GCS_COMPID, &m->gcs_tx, &msg, 1, 1, st->name, st->value,
						  MAV_PARAM_TYPE_REAL32);
		m->seen.param = false;
		m->seen.text[0] = 0;
		send_msg(m, &msg);
		if (!m->seen.param || strcmp(m->seen.param_id, st->name))
			return fail(m, "no such parameter (%s)", m->seen.text[0] ? m->seen.text : "no answer");
		if (m->seen.param_value != st->value) {
			char d[400];
			snprintf(d, sizeof d, "value is %g%s%s", (double)m->seen.param_value,
				 m->seen.text[0] ? ": " : "", m->seen.text);
			return fail(m, "refused, %s", d);
		}
		return 1;
	}
	case ST_ARM: {
		if (!retry_due)
			return 0;
		m->last_try_us = m->now_us;
		int r = command(m, MAV_CMD_COMPONENT_ARM_DISARM, 1.0f, 0.0f);
		if (r == MAV_RESULT_ACCEPTED)
			return 1;
		return waited_too_long(m) ? refused(m, r) : 0;
	}
	case ST_TAKEOFF: {
		int r = command(m, MAV_CMD_NAV_TAKEOFF, 0.0f, st->value);
		return r == MAV_RESULT_ACCEPTED ? 1 : refused(m, r);
	}
	case ST_EXPERIMENT: {
		if (!retry_due)
			return 0;
		m->last_try_us = m->now_us;
		int r = command(m, MAV_CMD_USER_1, st->value, 0.0f);
		if (r == MAV_RESULT_IN_PROGRESS || r == MAV_RESULT_ACCEPTED)
			return 1;
		/* a vehicle still settling after take-off answers "not hovering"; one whose attitude
		 * still oscillates (the guard lowering its gain), TEMPORARILY_REJECTED */
		if ((r == MAV_RESULT_TEMPORARILY_REJECTED ||
		     (r == MAV_RESULT_DENIED && strstr(m->seen.text, "hover"))) &&
		    !waited_too_long(m))
			return 0;
		return refused(m, r);
	}
	case ST_WAIT_EXP:
		if (m->seen.exp_final) {
			if (m->seen.exp_result == MAV_RESULT_ACCEPTED)
				return 1;
			char d[400];
			/* a phase over its time limit: the firmware's "ID <phase> failed: ..." and what
			 * it adds; otherwise its last ID line ("ID aborted: ...") */
			const char *why = m->seen.fail_text[0] ? m->seen.fail_text
					  : m->seen.id_text[0] ? m->seen.id_text
							       : "no reason given";
			snprintf(d, sizeof d, "experiment ended %s (%s)", result_name(m->seen.exp_result), why);
			return fail(m, "%s", d);
		}
		if (!waited_too_long(m))
			return 0;
		return fail(m, "experiment still running after %s s", "30000");
	case ST_LAND: {
		if (m->app->mode == APP_DISARMED)
			return 1;
		int r = command(m, MAV_CMD_NAV_LAND, 0.0f, 0.0f);
		return r == MAV_RESULT_ACCEPTED ? 1 : refused(m, r);
	}
	case ST_WAIT_HOLD: return wait_mode(m, APP_HOLD);
	case ST_WAIT_DISARMED: return wait_mode(m, APP_DISARMED);
	case ST_SLEEP: return (double)(m->now_us - m->t0_us) * 1e-6 >= (double)st->value - 1e-9 ? 1 : 0;
	}
	return -1;
}

int script_run(struct script *m, struct app *app, struct mav *mav, uint64_t now_us)
{
	m->app = app;
	m->mav = mav;
	m->now_us = now_us;
	while (m->cur < m->n) {
		const struct step *st = &m->steps[m->cur];
		bool first = !m->begun;
		if (first) {
			m->begun = true;
			m->t0_us = m->now_us;
			m->last_try_us = m->now_us;
		}
		int r = step(m, st, first);
		if (r < 0)
			return -1;
		if (r == 0)
			return 0;
		if (!m->quiet)
			fprintf(stderr, "octo-sil: t=%.2f s: step %zu '%s' done\n", m->app->fr.t_s, m->cur + 1,
				st->text);
		m->cur++;
		m->begun = false;
	}
	return 1;
}
