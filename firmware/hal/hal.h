/*
 * hal.h - the only platform interface the autopilot (firmware/app) calls.
 *
 * The app never does I/O itself. A platform (hal/host/ on POSIX, later a
 * Cortex-M directory) implements the functions below and drives the app
 * through the three entry points declared in app.h:
 *
 *   app_on_frame(app, frame)   once per sensor frame received from the plant;
 *                              the app answers each frame that brings a new
 *                              time stamp with exactly one hal_actuate() (from
 *                              the first arming on; duplicates and reordered
 *                              frames get none)
 *   app_on_mavlink(app, b, n)  bytes received from the ground station
 *   app_tick(app)              often (>= 50 Hz wall clock): telemetry, link
 *                              supervision, paced parameter streaming
 *
 * Frames: the sensor frame is already in the paper's frames (DESIGN.md):
 *   S_I  inertial, X_I north, Y_I west, Z_I up (gravity [0, 0, -g]);
 *   S_B  body, X_B forward, Y_B left, Z_B up (thrust along +Z_B).
 * q_ib = [w, x, y, z] is the Hamilton quaternion of the body attitude in S_I:
 * v_I = R(q_ib) v_B. The platform converts the simulator's conventions in
 * exactly one place (hal/host/xp_client.c for X-Plane).
 */
#ifndef OCTO_HAL_H
#define OCTO_HAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define HAL_ROTORS 8

/* Bits of hal_sensor_frame.valid: which parts the plant delivered in this frame. */
enum {
	HAL_FRAME_TIME = 1u << 0,     /* row 1 */
	HAL_FRAME_RATES = 1u << 1,    /* row 16 */
	HAL_FRAME_ATT = 1u << 2,      /* row 17 */
	HAL_FRAME_POS = 1u << 3,      /* row 21 */
	HAL_FRAME_THRUST = 1u << 4,   /* row 35 */
	HAL_FRAME_TORQUE = 1u << 5,   /* row 36 */
	HAL_FRAME_THR_CMD = 1u << 6,  /* row 25 (echo of the throttle command) */
	HAL_FRAME_GLOBAL = 1u << 7,   /* row 20 (latitude, longitude, altitude MSL) */
};
#define HAL_FRAME_NEEDED (HAL_FRAME_TIME | HAL_FRAME_RATES | HAL_FRAME_ATT | HAL_FRAME_POS)

/* One sensor frame in the paper's frames and SI units. */
struct hal_sensor_frame {
	double t_s;                          /* plant time, re-based: never runs backwards */
	uint32_t seq;                        /* frames received so far (1 = first) */
	uint32_t valid;                      /* HAL_FRAME_* bits */
	float q_ib[4];                       /* attitude [w, x, y, z], body FLU in S_I (NWU) */
	float rate_b_rps[3];                 /* omega_x, omega_y, omega_z about FLU, rad/s */
	float pos_i_m[3];                    /* position in S_I (north, west, up), m */
	float vel_i_mps[3];                  /* velocity in S_I, m/s */
	float rotor_thrust_n[HAL_ROTORS];    /* measured thrust f_j, N (row 35) */
	float rotor_torque_nm[HAL_ROTORS];   /* measured reaction torque tau_j, N m (row 36) */
	float thr_cmd_echo[HAL_ROTORS];      /* throttle command as the plant saw it (row 25) */
	double lat_deg, lon_deg;             /* simulator's position, WGS84 degrees (row 20) */
	float alt_msl_m;                     /* altitude above mean sea level, m (row 20) */
};

/* ---- time */
/* Wall-clock monotonic time in microseconds (telemetry rates, link supervision). */
uint64_t hal_wall_us(void);

/* ---- plant link (X-Plane on the host) */
/* Command the 8 throttles (ratio 0..1, rotor j = index j-1). Once per frame. */
void hal_actuate(const float thr[HAL_ROTORS]);

struct hal_link_stats {
	uint32_t frames;          /* DATA frames accepted */
	uint32_t dropped;         /* datagrams dropped: malformed, foreign host, unknown */
	uint32_t foreign;         /* of which from a host other than the configured one */
	uint32_t stale;           /* frames older than the newest (reordered, delayed) */
	uint32_t xp_version;      /* sim/version/xplane_internal_version, 0 = unknown yet */
	uint32_t rows_missing;    /* HAL_FRAME_* bits of wanted rows not seen yet */
};
void hal_link_stats(struct hal_link_stats *out);

/* ---- ground-station link (MAVLink bytes; framing is the app's business) */
void hal_mav_send(const uint8_t *buf, size_t len);
/* MAVLink 2 signing: true (and the 32-byte secret in key) when the platform was
 * configured with a key; then unsigned or badly signed input is rejected. */
bool hal_signing_key(uint8_t key[32]);
/* Wall-clock time since the UNIX epoch, microseconds (signing time stamps). */
uint64_t hal_unix_us(void);

/* ---- parameter storage: text, written atomically (all old or all new) */
/* Returns 0 on success, -1 on failure (reason reported through hal_report). */
int hal_param_store(const char *text, size_t len);
/* Reads the stored text into buf (NUL-terminated); returns its length, -1 if none. */
long hal_param_fetch(char *buf, size_t cap);

/* ---- log (LCM on the host) */
struct app_log_frame;   /* defined in app/log.h; the platform serialises it */
void hal_log_frame(const struct app_log_frame *f);
/* An event (mode change, warning) stamped with plant time. */
void hal_log_event(double t_s, int severity, const char *text);

/* ---- console / diagnostics (stderr on the host) */
void hal_report(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

#endif /* OCTO_HAL_H */
