/*
 * lcm_log.c - the firmware log as LCM messages (the host's log_frame / log_event /
 * log_id_result).
 *
 * Channels: OCTO_FW_FRAME (octo.fw_frame_t, every frame unless thinned by
 * lcm_log_thin), OCTO_FW_EVENT
 * (octo.fw_event_t), OCTO_FW_ID_RESULT (octo.fw_id_result_t, each identification
 * result as data). With --lcm file://PATH the events are written straight
 * into an LCM event log with plant-time stamps, so two lockstep runs with the
 * same inputs give identical logs; any other URL goes through lcm_publish.
 */
#include "host.h"

#include <lcm/eventlog.h>
#include <lcm/lcm.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <octo_fw_event_t.h>
#include <octo_fw_frame_t.h>
#include <octo_fw_id_result_t.h>

#include "log.h"

int lcm_log_open(struct lcm_log *lg, const char *url)
{
	lcm_log_thin(lg, 1, false);
	if (!strncmp(url, "file://", 7)) {
		char path[4096];
		snprintf(path, sizeof path, "%s", url + 7);
		char *q = strchr(path, '?');
		if (q)
			*q = 0;
		lg->elog = lcm_eventlog_create(path, "w");
		if (!lg->elog) {
			fprintf(stderr, "octo-fw: --lcm: cannot create log %s\n", path);
			return -1;
		}
		return 0;
	}
	lg->lcm = lcm_create(url);
	if (!lg->lcm) {
		fprintf(stderr, "octo-fw: --lcm: cannot open %s\n", url);
		return -1;
	}
	return 0;
}

void lcm_log_thin(struct lcm_log *lg, unsigned every, bool phases)
{
	lg->every = every;
	lg->phases = phases;
	lg->frames_seen = 0;
}

/* Whether this frame goes into the log: all of them during an experiment with
 * --log-phases, otherwise every `every`-th, counted from the first one offered. */
static bool frame_kept(struct lcm_log *lg, const struct app_log_frame *l)
{
	if (lg->phases && l->exp_id != 0)
		return true;
	if (lg->every == 0)
		return false;
	return lg->frames_seen++ % lg->every == 0;
}

/* --log-every's value: an integer in [1, 1000000]; 0, or 1 after a message. */
int log_every_parse(const char *prog, const char *v, unsigned *out)
{
	char *e = NULL;
	long n = strtol(v, &e, 10);
	if (!*v || *e || n < 1 || n > 1000000) {
		fprintf(stderr, "%s: --log-every: expected a frame count in [1, 1000000], got '%s'\n", prog, v);
		return 1;
	}
	*out = (unsigned)n;
	return 0;
}

void lcm_log_close(struct lcm_log *lg)
{
	if (lg->elog)
		lcm_eventlog_destroy(lg->elog);
	if (lg->lcm)
		lcm_destroy(lg->lcm);
	lg->elog = NULL;
	lg->lcm = NULL;
}

static void emit(struct lcm_log *lg, const char *channel, int64_t utime, const void *data, int len)
{
	if (lg->elog) {
		lcm_eventlog_event_t ev;
		memset(&ev, 0, sizeof ev);
		ev.timestamp = utime;
		ev.channellen = (int32_t)strlen(channel);
		ev.channel = (char *)channel;
		ev.datalen = len;
		ev.data = (void *)data;
		(void)lcm_eventlog_write_event(lg->elog, &ev);
	} else if (lg->lcm) {
		(void)lcm_publish(lg->lcm, channel, data, (unsigned)len);
	}
}

static int64_t utime_of(double t_s) { return (int64_t)(t_s * 1e6 + (t_s >= 0 ? 0.5 : -0.5)); }

void lcm_log_frame(struct lcm_log *lg, const struct app_log_frame *l)
{
	if ((!lg->elog && !lg->lcm) || !frame_kept(lg, l))
		return;
	octo_fw_frame_t m;
	memset(&m, 0, sizeof m);
	m.utime = utime_of(l->t);
	/* every field of the record, by the one table (log.h); same sizes, checked */
#define COPY(c_type, lcm_type, name)                                                             \
	_Static_assert(sizeof m.name == sizeof l->name, "log field " #name " differs from LCM"); \
	memcpy(&m.name, &l->name, sizeof m.name);
#define COPY_ARR(c_type, lcm_type, name, n) COPY(c_type, lcm_type, name)
	APP_LOG_FIELDS(COPY, COPY_ARR)
#undef COPY
#undef COPY_ARR
	uint8_t buf[1024];
	int n = octo_fw_frame_t_encoded_size(&m);
	if (n <= 0 || n > (int)sizeof buf)
		return;
	if (octo_fw_frame_t_encode(buf, 0, n, &m) == n)
		emit(lg, "OCTO_FW_FRAME", m.utime, buf, n);
}

void lcm_log_event(struct lcm_log *lg, double t_s, int severity, const char *text)
{
	if (!lg->elog && !lg->lcm)
		return;
	octo_fw_event_t m;
	m.utime = utime_of(t_s);
	m.severity = (int8_t)severity;
	m.text = (char *)text;
	uint8_t buf[512];
	int n = octo_fw_event_t_encoded_size(&m);
	if (n <= 0 || n > (int)sizeof buf)
		return;
	if (octo_fw_event_t_encode(buf, 0, n, &m) == n)
		emit(lg, "OCTO_FW_EVENT", m.utime, buf, n);
}

void lcm_log_id_result(struct lcm_log *lg, double t_s, const struct app_id_result *r)
{
	if (!lg->elog && !lg->lcm)
		return;
	octo_fw_id_result_t m = {
		.utime = utime_of(t_s),
		.run_id = (int16_t)r->run_id,
		.index = (int8_t)r->index,
		.count = (int8_t)r->count,
		.run_done = (int8_t)r->run_done,
		.experiment = (int8_t)r->experiment,
		.param = (int8_t)r->param,
		.rotor = (int8_t)r->rotor,
		.value = r->value,
		.sd = r->sd,
		.accepted = (int8_t)r->accepted,
		.reason = (int16_t)r->reason,
		.source = (int8_t)r->source,
	};
	uint8_t buf[128];
	int n = octo_fw_id_result_t_encoded_size(&m);
	if (n <= 0 || n > (int)sizeof buf)
		return;
	if (octo_fw_id_result_t_encode(buf, 0, n, &m) == n)
		emit(lg, "OCTO_FW_ID_RESULT", m.utime, buf, n);
}
