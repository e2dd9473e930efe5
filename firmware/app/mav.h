/*
 * mav.h - MAVLink 2 endpoint of the autopilot: system 1, component 1,
 * MAV_TYPE_OCTOROTOR, MAV_AUTOPILOT_GENERIC; headers generated from the
 * project's dialect (firmware/mavlink/octo.xml: common.xml and what it adds).
 *
 * - telemetry: one table of streams (message id, default interval, pack
 *   function), intervals in wall-clock time, changed by SET_MESSAGE_INTERVAL;
 * - the parameter protocol (docs/mavlink.md): paced PARAM_REQUEST_LIST,
 *   reads by name and by index, PARAM_SET always answered with the current
 *   value, refusals and unknown names as STATUSTEXT;
 * - COMMAND_LONG / COMMAND_INT, always acknowledged;
 * - ground-station telemetry (global position, home, landed state, standard
 *   modes, sensor health: mav_telem.h);
 * - component metadata over a read-only FTP (mav_ftp.h; every other file
 *   FileNotFound), MISSION_REQUEST_LIST -> MISSION_COUNT 0;
 * - MAVLink 2 signing when the platform has a key: outgoing signed, incoming
 *   unsigned / wrongly signed / replayed packets rejected and counted (only
 *   RADIO_STATUS may come unsigned);
 * - identification results as data (OCTO_ID_RESULT, docs/mavlink.md).
 *
 * The module reads the app through the view it publishes (app_view) and acts
 * through its command functions; the app does not know this module. The
 * platform owns one struct mav beside its struct app and calls mav_init after
 * app_init, mav_receive for each ground datagram and mav_tick after app_tick.
 */
#ifndef OCTO_MAV_H
#define OCTO_MAV_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <mavlink_types.h>

#include "mav_ftp.h"
#include "mav_telem.h"

#define MAV_SYSID 1
#define MAV_COMPID 1
#define MAV_N_STREAMS 6

struct app;
struct hal;

struct mav {
	struct app *app; /* the app this endpoint serves (mav_init) */
	const struct hal *hal;
	int64_t interval_us[MAV_N_STREAMS]; /* < 0: off */
	uint64_t last_us[MAV_N_STREAMS];
	long param_next; /* next index of a list stream, -1 = none */
	uint64_t param_last_us;
	uint64_t boot_us;
	uint8_t gcs_sysid, gcs_compid;
	float text_tokens; /* STATUSTEXT rate limit */
	uint64_t text_last_us;
	uint16_t text_id; /* the last long STATUSTEXT's chunk id (0 = none yet) */
	uint32_t rx_msgs, rx_dropped, text_dropped;
	uint32_t rx_unsigned; /* rejected by signing (unsigned, bad, replayed) */
	bool signing;         /* MAVLink 2 signing on (hal_signing_key) */
	/* the channel's signing state; the library's channel status points here */
	mavlink_signing_t signing_state;
	mavlink_signing_streams_t signing_streams;
	struct mav_telem telem; /* ground-station telemetry (mav_telem.c) */
	struct mav_ftp ftp;     /* component metadata and its FTP (mav_ftp.c) */
};

void mav_init(struct mav *m, struct app *a, const struct hal *hal, uint64_t now_us);
/* Parses one datagram from the ground station (whole packets: the parser
 * restarts at its first byte) and handles complete messages, after the app's
 * work between frames (app_settle: commands see the last step's results
 * applied); returns how many were accepted (valid checksum, and signature when
 * signing is on): the platform may learn the ground station's address from a
 * datagram that had one. */
size_t mav_receive(struct mav *m, const uint8_t *buf, size_t len);
/* Sends the app's events (its outbox), due telemetry and parameters. */
void mav_tick(struct mav *m, uint64_t now_us);

#endif /* OCTO_MAV_H */
