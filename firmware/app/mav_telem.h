/* mav_telem.h - the telemetry common ground stations use (QGroundControl, MAVSDK,
 * MAVProxy): local and global position, GPS, attitude, HUD, home, local origin,
 * landed state, standard modes, sensor health.
 *
 * Frames as PX4 and ArduPilot give them: LOCAL_POSITION_NED is relative to the local
 * origin, the position of the first frame that has one (the vehicle boots on the
 * ground), kept across arming and moved only by SET_GPS_GLOBAL_ORIGIN while disarmed;
 * GPS_GLOBAL_ORIGIN gives it geodetically. HOME_POSITION's x, y, z are home in that
 * frame, and GLOBAL_POSITION_INT.relative_alt is the height above home.
 *
 * It reads only what it is given (struct mav_telem_in, rebuilt by the caller
 * for every call) and sends through a callback, so it does not depend on the
 * application's structure. Its own state (the geographic reference, home, the
 * stream intervals) lives in struct mav_telem, a member of struct mav.
 */
#ifndef OCTO_MAV_TELEM_H
#define OCTO_MAV_TELEM_H

#include <stdbool.h>
#include <stdint.h>

#include "hal.h"

#define MAV_TELEM_N_STREAMS 10

/* The generated headers' message type, declared without them: struct mav (and
 * so app.h) embeds this module's state, and the app does not see MAVLink. */
typedef struct __mavlink_message mavlink_message_t;

/* Sends one message; ctx is mav_telem_in.ctx. */
typedef void (*mav_telem_send_fn)(const void *ctx, const mavlink_message_t *msg);

struct mav_telem_in {
	uint32_t time_boot_ms;
	const struct hal_sensor_frame *fr; /* the newest frame (paper's frames, NWU / FLU) */
	bool frame_ok;                     /* complete frames arrive (link up) */
	bool armed;
	bool armable;   /* an arm command would be accepted now */
	uint32_t mode;  /* enum app_mode, also HEARTBEAT.custom_mode */
	float throttle; /* mean rotor throttle, 0..1 */
	uint8_t sysid, compid, chan;
	const void *ctx;   /* handed back to the send callback */
	bool rotor_failed; /* a rotor has failed: motor outputs unhealthy */
};

struct mav_telem {
	/* geographic reference: row 20's position at the local position ref_ned */
	bool ref_ok;
	double ref_lat_deg, ref_lon_deg;
	double ref_alt_m;
	float ref_ned[3];
	/* the local origin (NED, in the frame's continuous local position) */
	bool origin_ok;
	float origin_ned[3];
	bool origin_sent; /* GPS_GLOBAL_ORIGIN sent since it was last set */
	/* home: set on the ground once the position is known, again at arming */
	bool home_ok;
	int32_t home_lat_e7, home_lon_e7, home_alt_mm;
	float home_ned[3];
	bool was_armed;
	uint8_t landed_last; /* landed state last sent on change (0: none yet) */
	uint32_t mode_last;  /* mode last sent in CURRENT_MODE on change */
	bool mode_sent;
	int64_t interval_us[MAV_TELEM_N_STREAMS]; /* < 0: off */
	uint64_t last_us[MAV_TELEM_N_STREAMS];
};

void mav_telem_init(struct mav_telem *t);

/* Updates reference, home, landed state and mode; sends what changed and the
 * streams that are due. */
void mav_telem_tick(struct mav_telem *t, const struct mav_telem_in *in, uint64_t now_us, mav_telem_send_fn send);

/* MAV_CMD_REQUEST_MESSAGE for `msgid` (param2: the AVAILABLE_MODES index, 0 =
 * all). mav_telem_request_result gives the MAV_RESULT to acknowledge, or -1
 * when msgid is not one of this module's; after the ACK, on ACCEPTED,
 * mav_telem_request_send sends the message(s). */
int mav_telem_request_result(const struct mav_telem *t, uint32_t msgid, float param2);
void mav_telem_request_send(struct mav_telem *t, const struct mav_telem_in *in, uint32_t msgid, float param2,
			    mav_telem_send_fn send);

/* MAV_CMD_SET_MESSAGE_INTERVAL: MAV_RESULT, or -1 when msgid is not this module's. */
int mav_telem_set_interval(struct mav_telem *t, uint32_t msgid, float interval_us);
/* SET_MESSAGE_INTERVAL's param2 as a stream's interval (*out): -1 off, 0 the default,
 * else 10 ms .. 1000 s. false: not finite (the request is DENIED). Shared by every stream table. */
bool mav_interval_of_request(float interval_us, int64_t default_us, int64_t *out);
/* MAV_CMD_GET_MESSAGE_INTERVAL: true when msgid is this module's, with its interval
 * (-1: only on change and on request, or disabled). */
bool mav_telem_get_interval(const struct mav_telem *t, uint32_t msgid, int32_t *interval_us);

/* SET_GPS_GLOBAL_ORIGIN: moves the local origin to (lat, lon in 1e-7 degrees, altitude
 * MSL in mm) while disarmed; then GPS_GLOBAL_ORIGIN and HOME_POSITION go out. Returns
 * false (nothing changed) when armed or when no geodetic position is known yet. */
bool mav_telem_set_origin(struct mav_telem *t, const struct mav_telem_in *in, int32_t lat_e7, int32_t lon_e7,
			  int32_t alt_mm, mav_telem_send_fn send);

/* SYS_STATUS sensor bits (present, enabled, health) for what the plant link provides. */
void mav_telem_sensors(const struct mav_telem_in *in, uint32_t *present, uint32_t *enabled, uint32_t *health);

/* HEARTBEAT base_mode: armed flag only. MAV_MODE_FLAG_CUSTOM_MODE_ENABLED stays
 * clear so that tools do not read custom_mode with ArduPilot's mode tables; the
 * modes' names come with AVAILABLE_MODES / CURRENT_MODE. */
uint8_t mav_telem_base_mode(bool armed);

#endif
