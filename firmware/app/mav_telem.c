/* mav_telem.c - ground-station telemetry (see mav_telem.h). */
#include "mav_telem.h"

#include <math.h>
#include <string.h>

#include "app.h"
#include "mav_lib.h"

#define EARTH_R_M 6371008.8 /* mean radius: flat earth around the reference */
#define RAD_TO_DEG 57.29577951308232
#define REREF_M 10.0 /* row 20 and the projection disagree: new reference */

enum { S_GLOBAL, S_GPS, S_ATTITUDE, S_VFR, S_EXT_STATE, S_CURRENT_MODE, S_HOME, S_BATTERY, S_LOCAL, S_ORIGIN };

static const struct {
	uint32_t msgid;
	int64_t default_us; /* < 0: only on change and on request */
} streams[MAV_TELEM_N_STREAMS] = {
	[S_GLOBAL] = {MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 200000},
	[S_GPS] = {MAVLINK_MSG_ID_GPS_RAW_INT, 200000},
	[S_ATTITUDE] = {MAVLINK_MSG_ID_ATTITUDE, 100000},
	[S_VFR] = {MAVLINK_MSG_ID_VFR_HUD, 250000},
	[S_EXT_STATE] = {MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 1000000},
	[S_CURRENT_MODE] = {MAVLINK_MSG_ID_CURRENT_MODE, 2000000},
	/* home also when it changes; periodically as PX4 does, so that a client that
	 * subscribes after the change (MAVSDK's telemetry.home()) gets it within a second */
	[S_HOME] = {MAVLINK_MSG_ID_HOME_POSITION, 1000000},
	[S_BATTERY] = {MAVLINK_MSG_ID_BATTERY_STATUS, 1000000},
	[S_LOCAL] = {MAVLINK_MSG_ID_LOCAL_POSITION_NED, 100000},
	[S_ORIGIN] = {MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, -1},
};

/* The modes as MAVLink's standard modes see them. None is user-selectable:
 * the vehicle changes mode on arm, take-off, land and experiment commands. */
static const struct {
	uint32_t custom;
	uint8_t standard;
	uint32_t properties;
} modes[] = {
	{APP_DISARMED, MAV_STANDARD_MODE_NON_STANDARD, MAV_MODE_PROPERTY_NOT_USER_SELECTABLE},
	{APP_IDLE, MAV_STANDARD_MODE_NON_STANDARD, MAV_MODE_PROPERTY_NOT_USER_SELECTABLE},
	{APP_TAKEOFF, MAV_STANDARD_MODE_TAKEOFF, MAV_MODE_PROPERTY_NOT_USER_SELECTABLE | MAV_MODE_PROPERTY_AUTO_MODE},
	{APP_HOLD, MAV_STANDARD_MODE_POSITION_HOLD,
	 MAV_MODE_PROPERTY_NOT_USER_SELECTABLE | MAV_MODE_PROPERTY_AUTO_MODE},
	{APP_EXPERIMENT, MAV_STANDARD_MODE_NON_STANDARD,
	 MAV_MODE_PROPERTY_NOT_USER_SELECTABLE | MAV_MODE_PROPERTY_AUTO_MODE},
	{APP_LAND, MAV_STANDARD_MODE_LAND, MAV_MODE_PROPERTY_NOT_USER_SELECTABLE | MAV_MODE_PROPERTY_AUTO_MODE},
};
#define N_MODES (sizeof modes / sizeof modes[0])

void mav_telem_init(struct mav_telem *t)
{
	memset(t, 0, sizeof *t);
	for (int i = 0; i < MAV_TELEM_N_STREAMS; i++)
		t->interval_us[i] = streams[i].default_us;
}

uint8_t mav_telem_base_mode(bool armed) { return armed ? (uint8_t)MAV_MODE_FLAG_SAFETY_ARMED : 0u; }

static uint8_t landed_state(uint32_t mode)
{
	switch (mode) {
	case APP_TAKEOFF: return MAV_LANDED_STATE_TAKEOFF;
	case APP_HOLD:
	case APP_EXPERIMENT: return MAV_LANDED_STATE_IN_AIR;
	case APP_LAND: return MAV_LANDED_STATE_LANDING;
	default: return MAV_LANDED_STATE_ON_GROUND;
	}
}

static uint8_t standard_mode(uint32_t mode)
{
	for (size_t i = 0; i < N_MODES; i++)
		if (modes[i].custom == mode)
			return modes[i].standard;
	return MAV_STANDARD_MODE_NON_STANDARD;
}

/* ---- frames: the plant's NWU / FLU to MAVLink's NED / FRD */

static void ned_pos(const struct hal_sensor_frame *f, float p[3])
{
	p[0] = f->pos_i_m[0];
	p[1] = -f->pos_i_m[1];
	p[2] = -f->pos_i_m[2];
}

static void ned_vel(const struct hal_sensor_frame *f, float v[3])
{
	v[0] = f->vel_i_mps[0];
	v[1] = -f->vel_i_mps[1];
	v[2] = -f->vel_i_mps[2];
}

static void euler(const struct hal_sensor_frame *f, float *roll, float *pitch, float *yaw)
{
	const double w = f->q_ib[0], x = f->q_ib[1], y = -(double)f->q_ib[2], z = -(double)f->q_ib[3];
	double s = 2.0 * (w * y - z * x);
	s = s > 1.0 ? 1.0 : (s < -1.0 ? -1.0 : s);
	*roll = (float)atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
	*pitch = (float)asin(s);
	*yaw = (float)atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
}

static double heading_deg(const struct hal_sensor_frame *f)
{
	float r, p, y;
	euler(f, &r, &p, &y);
	double h = (double)y * RAD_TO_DEG;
	return h < 0.0 ? h + 360.0 : (h >= 360.0 ? h - 360.0 : h);
}

/* ---- geographic position: row 20 gives the reference, row 21 (local, to the
 * millimetre) the offsets from it; row 20's float32 degrees alone would step
 * by decimetres. */

static void project(const struct mav_telem *t, const float ned[3], double *lat, double *lon, double *alt)
{
	const double dn = (double)ned[0] - (double)t->ref_ned[0];
	const double de = (double)ned[1] - (double)t->ref_ned[1];
	const double dd = (double)ned[2] - (double)t->ref_ned[2];
	*lat = t->ref_lat_deg + dn / EARTH_R_M * RAD_TO_DEG;
	*lon = t->ref_lon_deg + de / (EARTH_R_M * cos(t->ref_lat_deg / RAD_TO_DEG)) * RAD_TO_DEG;
	*alt = t->ref_alt_m - dd;
}

static void update_reference(struct mav_telem *t, const struct hal_sensor_frame *f)
{
	if (!(f->valid & HAL_FRAME_GLOBAL) || !(f->valid & HAL_FRAME_POS))
		return;
	float ned[3];
	ned_pos(f, ned);
	if (t->ref_ok) {
		double lat, lon, alt;
		project(t, ned, &lat, &lon, &alt);
		const double dn = (lat - f->lat_deg) / RAD_TO_DEG * EARTH_R_M;
		const double de = (lon - f->lon_deg) / RAD_TO_DEG * EARTH_R_M * cos(lat / RAD_TO_DEG);
		const double dd = alt - (double)f->alt_msl_m;
		if (dn * dn + de * de + dd * dd < REREF_M * REREF_M)
			return; /* consistent: keep the smooth projection */
	}
	/* first fix, or the simulator moved its local origin */
	t->ref_ok = true;
	t->ref_lat_deg = f->lat_deg;
	t->ref_lon_deg = f->lon_deg;
	t->ref_alt_m = (double)f->alt_msl_m;
	memcpy(t->ref_ned, ned, sizeof ned);
}

static bool global_ok(const struct mav_telem *t, const struct mav_telem_in *in) { return t->ref_ok && in->frame_ok; }

static int32_t e7(double deg) { return (int32_t)lround(deg * 1e7); }

static int32_t mm(double m) { return (int32_t)lround(m * 1000.0); }

/* ---- messages */

/* home's x, y, z: in the local frame, from the local origin */
static void send_home(const struct mav_telem *t, const struct mav_telem_in *in, mav_telem_send_fn send)
{
	const float q[4] = {1.0f, 0.0f, 0.0f, 0.0f};
	float h[3];
	for (int i = 0; i < 3; i++)
		h[i] = t->home_ned[i] - t->origin_ned[i];
	mavlink_message_t msg;
	mavlink_msg_home_position_pack_chan(in->sysid, in->compid, in->chan, &msg, t->home_lat_e7, t->home_lon_e7,
					    t->home_alt_mm, h[0], h[1], h[2], q, 0.0f, 0.0f, 0.0f,
					    (uint64_t)in->time_boot_ms * 1000u);
	send(in->ctx, &msg);
}

static void send_origin(struct mav_telem *t, const struct mav_telem_in *in, mav_telem_send_fn send)
{
	double lat, lon, alt;
	project(t, t->origin_ned, &lat, &lon, &alt);
	mavlink_message_t msg;
	mavlink_msg_gps_global_origin_pack_chan(in->sysid, in->compid, in->chan, &msg, e7(lat), e7(lon), mm(alt),
						(uint64_t)in->time_boot_ms * 1000u);
	send(in->ctx, &msg);
	t->origin_sent = true;
}

static void send_current_mode(const struct mav_telem_in *in, mav_telem_send_fn send)
{
	mavlink_message_t msg;
	mavlink_msg_current_mode_pack_chan(in->sysid, in->compid, in->chan, &msg, standard_mode(in->mode), in->mode,
					   in->mode);
	send(in->ctx, &msg);
}

static void send_available_mode(const struct mav_telem_in *in, size_t i, mav_telem_send_fn send)
{
	char name[MAVLINK_MSG_AVAILABLE_MODES_FIELD_MODE_NAME_LEN]; /* zero-filled, full size */
	memset(name, 0, sizeof name);
	const char *n = app_mode_name((enum app_mode)modes[i].custom);
	size_t len = strlen(n);
	memcpy(name, n, len < sizeof name - 1 ? len : sizeof name - 1);
	mavlink_message_t msg;
	mavlink_msg_available_modes_pack_chan(in->sysid, in->compid, in->chan, &msg, (uint8_t)N_MODES, (uint8_t)(i + 1),
					      modes[i].standard, modes[i].custom, modes[i].properties, name);
	send(in->ctx, &msg);
}

static bool send_stream(struct mav_telem *t, const struct mav_telem_in *in, int s, mav_telem_send_fn send)
{
	const struct hal_sensor_frame *f = in->fr;
	float ned[3], vel[3];
	ned_pos(f, ned);
	ned_vel(f, vel);
	const double gs = hypot((double)vel[0], (double)vel[1]);
	mavlink_message_t msg;
	switch (s) {
	case S_GLOBAL: {
		if (!global_ok(t, in))
			return false;
		double lat, lon, alt;
		project(t, ned, &lat, &lon, &alt);
		const double rel = t->home_ok ? alt - (double)t->home_alt_mm * 1e-3 : 0.0;
		mavlink_msg_global_position_int_pack_chan(
			in->sysid, in->compid, in->chan, &msg, in->time_boot_ms, e7(lat), e7(lon), mm(alt), mm(rel),
			(int16_t)lround((double)vel[0] * 100.0), (int16_t)lround((double)vel[1] * 100.0),
			(int16_t)lround((double)vel[2] * 100.0), (uint16_t)lround(heading_deg(f) * 100.0) % 36000u);
		break;
	}
	case S_GPS: {
		if (!global_ok(t, in))
			return false;
		double lat, lon, alt;
		project(t, ned, &lat, &lon, &alt);
		/* the simulator's own position: a 3D fix whose dilution and satellite
		 * count are unknown (the MAVLink "unknown" values) */
		double cog = atan2((double)vel[1], (double)vel[0]) * RAD_TO_DEG;
		cog = cog < 0.0 ? cog + 360.0 : cog;
		/* course over ground in cdeg, unknown (UINT16_MAX) when hardly moving */
		uint16_t cog_cdeg = UINT16_MAX;
		if (gs > 0.2)
			cog_cdeg = (uint16_t)(lround(cog * 100.0) % 36000);
		mavlink_msg_gps_raw_int_pack_chan(in->sysid, in->compid, in->chan, &msg,
						  (uint64_t)in->time_boot_ms * 1000u, GPS_FIX_TYPE_3D_FIX, e7(lat),
						  e7(lon), mm(alt), UINT16_MAX, UINT16_MAX,
						  (uint16_t)lround(gs * 100.0), cog_cdeg, UINT8_MAX, 0, 0, 0, 0, 0, 0);
		break;
	}
	case S_ATTITUDE: {
		if (!in->frame_ok)
			return false;
		float r, p, y;
		euler(f, &r, &p, &y);
		mavlink_msg_attitude_pack_chan(in->sysid, in->compid, in->chan, &msg, in->time_boot_ms, r, p, y,
					       f->rate_b_rps[0], -f->rate_b_rps[1], -f->rate_b_rps[2]);
		break;
	}
	case S_VFR: {
		if (!in->frame_ok)
			return false;
		double lat, lon, alt = -(double)ned[2];
		if (global_ok(t, in))
			project(t, ned, &lat, &lon, &alt);
		float thr = in->throttle < 0.0f ? 0.0f : (in->throttle > 1.0f ? 1.0f : in->throttle);
		/* no wind in the simulation: airspeed = ground speed */
		mavlink_msg_vfr_hud_pack_chan(in->sysid, in->compid, in->chan, &msg, (float)gs, (float)gs,
					      (int16_t)lround(heading_deg(f)) % 360, (uint16_t)lroundf(thr * 100.0f),
					      (float)alt, -vel[2]);
		break;
	}
	case S_EXT_STATE:
		mavlink_msg_extended_sys_state_pack_chan(in->sysid, in->compid, in->chan, &msg,
							 MAV_VTOL_STATE_UNDEFINED, landed_state(in->mode));
		break;
	case S_CURRENT_MODE: send_current_mode(in, send); return true;
	case S_HOME:
		if (!t->home_ok)
			return false;
		send_home(t, in, send);
		return true;
	case S_LOCAL:
		if (!in->frame_ok || !t->origin_ok)
			return false;
		mavlink_msg_local_position_ned_pack_chan(in->sysid, in->compid, in->chan, &msg, in->time_boot_ms,
							 ned[0] - t->origin_ned[0], ned[1] - t->origin_ned[1],
							 ned[2] - t->origin_ned[2], vel[0], vel[1], vel[2]);
		break;
	case S_ORIGIN:
		if (!t->origin_ok || !t->ref_ok)
			return false;
		send_origin(t, in, send);
		return true;
	case S_BATTERY: {
		/* no battery is simulated: every field holds MAVLink's "unknown" value */
		uint16_t v[10], vext[4];
		for (int i = 0; i < 10; i++)
			v[i] = UINT16_MAX;
		memset(vext, 0, sizeof vext);
		mavlink_msg_battery_status_pack_chan(in->sysid, in->compid, in->chan, &msg, 0,
						     MAV_BATTERY_FUNCTION_UNKNOWN, MAV_BATTERY_TYPE_UNKNOWN, INT16_MAX,
						     v, -1, -1, -1, -1, 0, MAV_BATTERY_CHARGE_STATE_UNDEFINED, vext, 0,
						     0);
		break;
	}
	default: return false;
	}
	send(in->ctx, &msg);
	return true;
}

void mav_telem_tick(struct mav_telem *t, const struct mav_telem_in *in, uint64_t now_us, mav_telem_send_fn send)
{
	const struct hal_sensor_frame *f = in->fr;
	if (in->frame_ok)
		update_reference(t, f);
	/* the local origin: the first position (the vehicle boots on the ground) */
	if (in->frame_ok && !t->origin_ok && (f->valid & HAL_FRAME_POS)) {
		ned_pos(f, t->origin_ned);
		t->origin_ok = true;
	}
	if (t->origin_ok && t->ref_ok && !t->origin_sent)
		send_origin(t, in, send);
	/* home: on the ground once the position is known, and again at arming */
	const bool arming = in->armed && !t->was_armed;
	t->was_armed = in->armed;
	if (global_ok(t, in) && (arming || (!t->home_ok && !in->armed))) {
		float ned[3];
		double lat, lon, alt;
		ned_pos(f, ned);
		project(t, ned, &lat, &lon, &alt);
		int32_t la = e7(lat), lo = e7(lon), al = mm(alt);
		bool changed = !t->home_ok || la != t->home_lat_e7 || lo != t->home_lon_e7 || al != t->home_alt_mm;
		t->home_ok = true;
		t->home_lat_e7 = la;
		t->home_lon_e7 = lo;
		t->home_alt_mm = al;
		memcpy(t->home_ned, ned, sizeof ned);
		if (changed)
			send_home(t, in, send);
	}
	const uint8_t ls = landed_state(in->mode);
	if (ls != t->landed_last) {
		t->landed_last = ls;
		send_stream(t, in, S_EXT_STATE, send);
		t->last_us[S_EXT_STATE] = now_us;
	}
	if (!t->mode_sent || in->mode != t->mode_last) {
		t->mode_sent = true;
		t->mode_last = in->mode;
		send_current_mode(in, send);
		t->last_us[S_CURRENT_MODE] = now_us;
	}
	for (int i = 0; i < MAV_TELEM_N_STREAMS; i++) {
		if (t->interval_us[i] < 0)
			continue;
		if (t->last_us[i] && now_us - t->last_us[i] < (uint64_t)t->interval_us[i])
			continue;
		t->last_us[i] = now_us;
		send_stream(t, in, i, send);
	}
}

static int stream_of(uint32_t msgid)
{
	for (int i = 0; i < MAV_TELEM_N_STREAMS; i++)
		if (streams[i].msgid == msgid)
			return i;
	return -1;
}

int mav_telem_request_result(const struct mav_telem *t, uint32_t msgid, float param2)
{
	if (msgid == MAVLINK_MSG_ID_AVAILABLE_MODES) {
		if (!(param2 >= 0.0f && param2 <= (float)N_MODES && param2 == floorf(param2)))
			return MAV_RESULT_DENIED;
		return MAV_RESULT_ACCEPTED;
	}
	int s = stream_of(msgid);
	if (s < 0)
		return -1;
	/* no position yet */
	if ((s == S_HOME && !t->home_ok) || (s == S_LOCAL && !t->origin_ok) ||
	    (s == S_ORIGIN && !(t->origin_ok && t->ref_ok)) || ((s == S_GLOBAL || s == S_GPS) && !t->ref_ok))
		return MAV_RESULT_TEMPORARILY_REJECTED;
	return MAV_RESULT_ACCEPTED;
}

void mav_telem_request_send(struct mav_telem *t, const struct mav_telem_in *in, uint32_t msgid, float param2,
			    mav_telem_send_fn send)
{
	if (msgid == MAVLINK_MSG_ID_AVAILABLE_MODES) {
		for (size_t i = 0; i < N_MODES; i++)
			if (param2 == 0.0f || (size_t)param2 == i + 1)
				send_available_mode(in, i, send);
		return;
	}
	int s = stream_of(msgid);
	if (s >= 0)
		send_stream(t, in, s, send);
}

int mav_telem_set_interval(struct mav_telem *t, uint32_t msgid, float interval_us)
{
	int s = stream_of(msgid);
	if (s < 0)
		return -1;
	return mav_interval_of_request(interval_us, streams[s].default_us, &t->interval_us[s]) ? MAV_RESULT_ACCEPTED
											       : MAV_RESULT_DENIED;
}

bool mav_interval_of_request(float interval_us, int64_t default_us, int64_t *out)
{
	if (!isfinite(interval_us))
		return false;
	if (interval_us < 0.0f)
		*out = -1;
	else if (interval_us == 0.0f)
		*out = default_us;
	else /* 10 ms .. 1000 s: a huge float must not reach the integer cast */
		*out = interval_us < 10000.0f ? 10000 : (interval_us > 1.0e9f ? 1000000000 : (int64_t)interval_us);
	return true;
}

bool mav_telem_get_interval(const struct mav_telem *t, uint32_t msgid, int32_t *interval_us)
{
	int s = stream_of(msgid);
	if (s < 0)
		return false;
	*interval_us = t->interval_us[s] < 0 ? -1 : (int32_t)t->interval_us[s];
	return true;
}

bool mav_telem_set_origin(struct mav_telem *t, const struct mav_telem_in *in, int32_t lat_e7, int32_t lon_e7,
			  int32_t alt_mm, mav_telem_send_fn send)
{
	if (in->armed || !t->ref_ok)
		return false;
	/* the inverse of project(): the geodetic point in the local frame */
	const double lat = lat_e7 * 1e-7, lon = lon_e7 * 1e-7, alt = alt_mm * 1e-3;
	t->origin_ned[0] = t->ref_ned[0] + (float)((lat - t->ref_lat_deg) / RAD_TO_DEG * EARTH_R_M);
	t->origin_ned[1] = t->ref_ned[1] +
			   (float)((lon - t->ref_lon_deg) / RAD_TO_DEG * EARTH_R_M * cos(t->ref_lat_deg / RAD_TO_DEG));
	t->origin_ned[2] = t->ref_ned[2] - (float)(alt - t->ref_alt_m);
	t->origin_ok = true;
	send_origin(t, in, send);
	if (t->home_ok)
		send_home(t, in, send);
	return true;
}

void mav_telem_sensors(const struct mav_telem_in *in, uint32_t *present, uint32_t *enabled, uint32_t *health)
{
	/* The simulator measures rates, attitude (with the magnetic heading), the
	 * position and the motors' outputs; the vehicle estimates its attitude and
	 * position from them (AHRS). */
	const uint32_t sensors = MAV_SYS_STATUS_SENSOR_3D_GYRO | MAV_SYS_STATUS_SENSOR_3D_ACCEL |
				 MAV_SYS_STATUS_SENSOR_3D_MAG | MAV_SYS_STATUS_SENSOR_GPS | MAV_SYS_STATUS_AHRS |
				 MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS | MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL |
				 MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION |
				 MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL | MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL |
				 MAV_SYS_STATUS_PREARM_CHECK;
	const uint32_t gps = MAV_SYS_STATUS_SENSOR_GPS;
	const struct hal_sensor_frame *f = in->fr;
	*present = sensors;
	*enabled = sensors;
	uint32_t h = 0;
	if (in->frame_ok) {
		h = sensors & ~(gps | MAV_SYS_STATUS_PREARM_CHECK);
		if (f->valid & HAL_FRAME_GLOBAL)
			h |= gps;
		if (in->armable)
			h |= MAV_SYS_STATUS_PREARM_CHECK;
		if (in->rotor_failed)
			h &= ~(uint32_t)MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
	}
	/* no geofence: not present, never breached (a clear health bit reads as a breach) */
	*health = h | MAV_SYS_STATUS_GEOFENCE;
}
