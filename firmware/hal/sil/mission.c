/* mission.c - the ground station's steps on the platform's clock (see mission.h). */
#include "mission.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <common/mavlink.h>

#include "sil.h"

#define GCS_SYSID 255
#define GCS_COMPID 190
#define STEP_TEXT 96
#define MAX_STEPS 512

enum step_kind { ST_PARAM, ST_ARM, ST_TAKEOFF, ST_WAIT_HOLD, ST_EXPERIMENT, ST_WAIT_EXP, ST_LAND, ST_WAIT_DISARMED, ST_SLEEP };

/* How long a step may take (platform clock, s) and how often a refused command
 * is retried (arm: until the vehicle has frames; experiment: until it hovers, or while it answers
 * TEMPORARILY_REJECTED). */
static const double step_timeout_s[] = {
	[ST_PARAM] = 1.0, [ST_ARM] = 10.0, [ST_TAKEOFF] = 1.0, [ST_WAIT_HOLD] = 60.0, [ST_EXPERIMENT] = 10.0,
	[ST_WAIT_EXP] = 30000.0, [ST_LAND] = 1.0, [ST_WAIT_DISARMED] = 120.0, [ST_SLEEP] = 0.0,
};
#define RETRY_S 0.5

struct step {
	enum step_kind kind;
	char name[17];
	float value;
	char text[STEP_TEXT];   /* the step as written, for messages */
};

struct mission {
	struct step steps[MAX_STEPS];
	size_t n, cur;
	bool begun;             /* the current step has started */
	uint64_t t0_us;         /* when it started */
	uint64_t last_try_us;
	char msg[640];
};

static const char *mode_name(enum app_mode m)
{
	return app_mode_name(m);
}

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

struct mission *mission_parse(const char *spec)
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
			fprintf(stderr, "octo-sil: --mission: %s is longer than %zu bytes\n", spec, cap);
			free(text);
			return NULL;
		}
		text[n] = 0;
	} else {
		text = strdup(spec);
		if (!text)
			return NULL;
	}
	struct mission *m = calloc(1, sizeof *m);
	if (!m) {
		free(text);
		return NULL;
	}
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
					"octo-sil: --mission: line %d: '%s' is not a step (param NAME VALUE, arm, takeoff H, wait "
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
		fprintf(stderr, "octo-sil: --mission: no steps\n");
		free(m);
		return NULL;
	}
	return m;
}

void mission_free(struct mission *m)
{
	free(m);
}

const char *mission_pending(struct mission *m)
{
	if (m->cur >= m->n)
		return "all steps completed";
	snprintf(m->msg, sizeof m->msg, "step %zu '%s' still running", m->cur + 1, m->steps[m->cur].text);
	return m->msg;
}

/* ---------------------------------------------------------------- commands */

static void send_msg(struct sil *s, const mavlink_message_t *msg)
{
	uint8_t buf[MAVLINK_MAX_PACKET_LEN];
	uint16_t n = mavlink_msg_to_send_buffer(buf, msg);
	(void)mav_receive(&s->mav, buf, n);
}

/* COMMAND_LONG to the vehicle; returns the MAV_RESULT of its COMMAND_ACK (-1:
 * none) and leaves the reason, when there is one, in s->seen.text. */
static int command(struct sil *s, uint16_t cmd, float p1, float p7)
{
	mavlink_message_t msg;
	mavlink_msg_command_long_pack_status(GCS_SYSID, GCS_COMPID, &s->gcs_tx, &msg, 1, 1, cmd, 0, p1, 0, 0, 0, 0, 0,
					   p7);
	s->seen.ack = false;
	if (cmd == MAV_CMD_USER_1)
		s->seen.exp_final = false;
	s->seen.text[0] = 0;
	if (cmd == MAV_CMD_NAV_TAKEOFF || cmd == MAV_CMD_NAV_LAND || cmd == MAV_CMD_USER_1) {
		s->seen.phase_failed = false;
		s->seen.fail_text[0] = 0;
	}
	send_msg(s, &msg);
	if (!s->seen.ack || s->seen.ack_command != cmd)
		return -1;
	return s->seen.ack_result;
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

static int fail(struct mission *m, struct sil *s, const char *fmt, const char *detail)
{
	char what[420];
	snprintf(what, sizeof what, fmt, detail);
	snprintf(m->msg, sizeof m->msg, "step %zu '%s' failed at t=%.2f s: %s", m->cur + 1, m->steps[m->cur].text,
		 s->app.fr.t_s, what);
	fprintf(stderr, "octo-sil: mission %s\n", m->msg);
	return -1;
}

int mission_abort(struct mission *m, struct sil *s, const char *why)
{
	return fail(m, s, "%s", why);
}

static int refused(struct mission *m, struct sil *s, int r)
{
	char d[400];
	snprintf(d, sizeof d, "%s%s%s", result_name(r), s->seen.text[0] ? ": " : "", s->seen.text);
	return fail(m, s, "refused: %s", d);
}

static bool waited_too_long(const struct mission *m, const struct sil *s)
{
	double limit = step_timeout_s[m->steps[m->cur].kind];
	return (double)(s->now_us - m->t0_us) * 1e-6 > limit;
}

static int wait_mode(struct mission *m, struct sil *s, enum app_mode want)
{
	if (s->app.mode == want)
		return 1;
	if (s->seen.phase_failed)   /* the firmware gave up the phase: its reason, at once */
		return fail(m, s, "%s", s->seen.fail_text[0] ? s->seen.fail_text : "COMMAND_ACK FAILED, no reason given");
	if (!waited_too_long(m, s))
		return 0;
	char d[400];
	snprintf(d, sizeof d, "vehicle still in mode %s after %g s (last message: %s)", mode_name(s->app.mode),
		 step_timeout_s[m->steps[m->cur].kind], s->seen.text[0] ? s->seen.text : "none");
	return fail(m, s, "%s", d);
}

/* One step: 1 done, 0 running, -1 failed. */
static int step(struct mission *m, struct sil *s, const struct step *st, bool first)
{
	bool retry_due = first || (double)(s->now_us - m->last_try_us) * 1e-6 >= RETRY_S;
	switch (st->kind) {
	case ST_PARAM: {
		mavlink_message_t msg;
		mavlink_msg_param_set_pack_status(GCS_SYSID, GCS_COMPID, &s->gcs_tx, &msg, 1, 1, st->name, st->value,
						MAV_PARAM_TYPE_REAL32);
		s->seen.param = false;
		s->seen.text[0] = 0;
		send_msg(s, &msg);
		if (!s->seen.param || strcmp(s->seen.param_id, st->name))
			return fail(m, s, "no such parameter (%s)", s->seen.text[0] ? s->seen.text : "no answer");
		if (s->seen.param_value != st->value) {
			char d[400];
			snprintf(d, sizeof d, "value is %g%s%s", (double)s->seen.param_value, s->seen.text[0] ? ": " : "",
				 s->seen.text);
			return fail(m, s, "refused, %s", d);
		}
		return 1;
	}
	case ST_ARM: {
		if (!retry_due)
			return 0;
		m->last_try_us = s->now_us;
		int r = command(s, MAV_CMD_COMPONENT_ARM_DISARM, 1.0f, 0.0f);
		if (r == MAV_RESULT_ACCEPTED)
			return 1;
		return waited_too_long(m, s) ? refused(m, s, r) : 0;
	}
	case ST_TAKEOFF: {
		int r = command(s, MAV_CMD_NAV_TAKEOFF, 0.0f, st->value);
		return r == MAV_RESULT_ACCEPTED ? 1 : refused(m, s, r);
	}
	case ST_EXPERIMENT: {
		if (!retry_due)
			return 0;
		m->last_try_us = s->now_us;
		int r = command(s, MAV_CMD_USER_1, st->value, 0.0f);
		if (r == MAV_RESULT_IN_PROGRESS || r == MAV_RESULT_ACCEPTED)
			return 1;
		/* a vehicle still settling after take-off answers "not hovering"; one whose attitude
		 * still oscillates (the guard lowering its gain), TEMPORARILY_REJECTED */
		if ((r == MAV_RESULT_TEMPORARILY_REJECTED || (r == MAV_RESULT_DENIED && strstr(s->seen.text, "hover"))) &&
		    !waited_too_long(m, s))
			return 0;
		return refused(m, s, r);
	}
	case ST_WAIT_EXP:
		if (s->seen.exp_final) {
			if (s->seen.exp_result == MAV_RESULT_ACCEPTED)
				return 1;
			char d[400];
			/* a phase over its time limit: the firmware's "ID <phase> failed: ..." and what
			 * it adds; otherwise its last ID line ("ID aborted: ...") */
			const char *why = s->seen.fail_text[0] ? s->seen.fail_text
					  : s->seen.id_text[0] ? s->seen.id_text : "no reason given";
			snprintf(d, sizeof d, "experiment ended %s (%s)", result_name(s->seen.exp_result), why);
			return fail(m, s, "%s", d);
		}
		if (!waited_too_long(m, s))
			return 0;
		return fail(m, s, "experiment still running after %s s", "30000");
	case ST_LAND: {
		if (s->app.mode == APP_DISARMED)
			return 1;
		int r = command(s, MAV_CMD_NAV_LAND, 0.0f, 0.0f);
		return r == MAV_RESULT_ACCEPTED ? 1 : refused(m, s, r);
	}
	case ST_WAIT_HOLD:
		return wait_mode(m, s, APP_HOLD);
	case ST_WAIT_DISARMED:
		return wait_mode(m, s, APP_DISARMED);
	case ST_SLEEP:
		return (double)(s->now_us - m->t0_us) * 1e-6 >= (double)st->value - 1e-9 ? 1 : 0;
	}
	return -1;
}

int mission_run(struct mission *m, struct sil *s)
{
	while (m->cur < m->n) {
		const struct step *st = &m->steps[m->cur];
		bool first = !m->begun;
		if (first) {
			m->begun = true;
			m->t0_us = s->now_us;
			m->last_try_us = s->now_us;
		}
		int r = step(m, s, st, first);
		if (r < 0)
			return -1;
		if (r == 0)
			return 0;
		if (!s->quiet)
			fprintf(stderr, "octo-sil: t=%.2f s: step %zu '%s' done\n", s->app.fr.t_s, m->cur + 1, st->text);
		m->cur++;
		m->begun = false;
	}
	return 1;
}
