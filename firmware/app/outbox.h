/*
 * outbox.h - what the app tells the ground station, without speaking its
 * protocol: command results, status-line severities, and the events the app
 * posts (status line, parameter changed, long command finished) for the
 * MAVLink module (mav.c) to drain and translate.
 */
#ifndef OCTO_APP_OUTBOX_H
#define OCTO_APP_OUTBOX_H

#include <stdbool.h>
#include <stdint.h>

#include "id_result.h"

/* Outcome of a command. mav.c maps it to MAV_RESULT. */
enum app_result {
	APP_ACCEPTED = 0, /* done (or nothing to do: a retry) */
	APP_IN_PROGRESS,  /* started; a final result follows as an event */
	APP_BUSY,         /* not now (state, link): may work later */
	APP_DENIED,       /* never with these arguments */
	APP_FAILED,       /* tried and failed (storage, an aborted experiment) */
	APP_UNSUPPORTED,  /* no such command */
};

/* Severity of a status line: the syslog levels (MAVLink's MAV_SEVERITY uses the same). */
enum app_severity {
	APP_SEV_CRITICAL = 2,
	APP_SEV_ERROR = 3,
	APP_SEV_WARNING = 4,
	APP_SEV_INFO = 6,
};

/* Who sent a command: opaque to the app, handed back with its final result. */
typedef uint32_t app_origin;
/* No one to answer (a command the app gives itself: failsafe landing). */
#define APP_ORIGIN_NONE 0xFFFFFFFFu

/* Long-running commands whose result comes later as an event. */
enum app_command {
	APP_CMD_EXPERIMENT = 1,
	APP_CMD_TAKEOFF, /* final result only when it fails (its time limit) */
	APP_CMD_LAND,    /* likewise */
};

enum app_event_kind {
	APP_EV_STATUS = 1, /* text, severity */
	APP_EV_PARAM,      /* param_index changed */
	APP_EV_CMD_DONE,   /* cmd finished with result (progress 0..100) for origin */
	APP_EV_VALUE,      /* a named live value: text (name, 10 characters at most), value */
	APP_EV_ID_RESULT,  /* an identification result: id */
};

#define APP_EVENT_TEXT 96
struct app_event {
	uint8_t kind;     /* enum app_event_kind */
	uint8_t severity; /* enum app_severity */
	uint8_t cmd;      /* enum app_command */
	uint8_t result;   /* enum app_result */
	uint8_t progress;
	uint16_t param_index;
	app_origin origin;
	float value;
	union {
		char text[APP_EVENT_TEXT];
		struct app_id_result id;
	};
};

/* Room for one experiment turn's results (EXP_MAX_RESULTS parameter events, applied
 * together, and as many identification results) and the status lines of the same pass
 * before the ground-station module drains (app.c checks). */
#define APP_OUTBOX_LEN 72
/* A ring of events; a full outbox drops the newest and counts it. */
struct app_outbox {
	struct app_event ev[APP_OUTBOX_LEN];
	uint8_t head, count;
	uint32_t dropped;
};

void outbox_post(struct app_outbox *o, const struct app_event *e);
/* The next slot for an event written in place (no copy of it): its fields before the union
 * zeroed, the union's bytes the caller's to write (a text up to its NUL: the ground-station
 * module reads no further); NULL when the outbox is full (the event dropped and counted). */
struct app_event *outbox_put(struct app_outbox *o);
/* Takes the oldest event into *e; false when empty. */
bool outbox_pop(struct app_outbox *o, struct app_event *e);

#endif /* OCTO_APP_OUTBOX_H */
