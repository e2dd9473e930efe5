/*
 * hal.h - the only platform interface the autopilot (firmware/app) calls.
 *
 * The app never does I/O itself. A platform (hal/host/ on POSIX; a simulator
 * linked into the same process; a microcontroller) fills one struct hal with
 * its functions and its own context pointer, hands it to app_init(), and then
 * drives the app through the entry points declared in app.h:
 *
 *   app_init(app, hal)          defaults, then the stored parameters
 *   app_on_frame(app, frame)    once per sensor frame received from the plant;
 *                               the app answers each frame that brings a new
 *                               time stamp with exactly one plant_actuate (from
 *                               the first arming on; duplicates and reordered
 *                               frames get none)
 *   app_on_ground(app, b, n)    bytes received on the ground link
 *   app_tick(app)               often (>= 50 Hz wall clock): telemetry, link
 *                               supervision, paced parameter streaming
 *
 * Every function gets the platform's ctx back as its first argument, so a
 * platform keeps its state in one struct of its own and can exist more than
 * once in a process. All members must be set (a platform without a log gives
 * functions that do nothing). The calls cost one indirect call each; the 90 Hz
 * path makes two (plant_actuate, log_frame).
 *
 * Frames: the sensor frame is already in the paper's frames (docs/xplane-protocol.md):
 *   S_I  inertial, X_I north, Y_I west, Z_I up (gravity [0, 0, -g]);
 *   S_B  body, X_B forward, Y_B left, Z_B up (thrust along +Z_B).
 * q_ib = [w, x, y, z] is the Hamilton quaternion of the body attitude in S_I:
 * v_I = R(q_ib) v_B. A platform converts its plant's conventions in exactly one
 * place (hal/host/xp_client.c for X-Plane).
 */
#ifndef OCTO_HAL_H
#define OCTO_HAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define HAL_ROTORS 8

/* Bits of hal_sensor_frame.valid: which parts the plant delivered in this frame. */
enum {
	HAL_FRAME_TIME = 1u << 0,    /* plant time */
	HAL_FRAME_RATES = 1u << 1,   /* body rates */
	HAL_FRAME_ATT = 1u << 2,     /* attitude */
	HAL_FRAME_POS = 1u << 3,     /* position and velocity */
	HAL_FRAME_THRUST = 1u << 4,  /* measured rotor thrusts */
	HAL_FRAME_TORQUE = 1u << 5,  /* measured rotor reaction torques */
	HAL_FRAME_THR_CMD = 1u << 6, /* echo of the throttle command */
	HAL_FRAME_GLOBAL = 1u << 7,  /* geodetic position (latitude, longitude, altitude MSL) */
	HAL_FRAME_ACCEL = 1u << 8,   /* specific force (accelerometer) */
	HAL_FRAME_RPM = 1u << 9,     /* rotor speeds (ESC telemetry) */
};
#define HAL_FRAME_NEEDED (HAL_FRAME_TIME | HAL_FRAME_RATES | HAL_FRAME_ATT | HAL_FRAME_POS)

/* One sensor frame in the paper's frames and SI units. */
/* app.c's frame_copy copies it field by field: a field added here goes there too. */
struct hal_sensor_frame {
	/* Time: the plant's time line in the platform's integer microseconds. frame_n counts the
	 * plant's frames since the first (lost ones included), t_us is its time (frame_n frame
	 * periods after the first frame's); both never run backwards, and a frame that brings
	 * no new plant time (duplicate, older) keeps them. The app takes the frames since its
	 * last step from frame_n and the frame period from differences of t_us (docs/time.md). */
	uint64_t t_us;                     /* plant time, us */
	uint64_t frame_n;                  /* plant frames since the first */
	double t_s;                        /* t_us in seconds (logs, events, 1 s schedules) */
	uint32_t seq;                      /* frames received so far (1 = first) */
	uint32_t valid;                    /* HAL_FRAME_* bits */
	float q_ib[4];                     /* attitude [w, x, y, z], body FLU in S_I (NWU) */
	float rate_b_rps[3];               /* omega_x, omega_y, omega_z about FLU, rad/s */
	float pos_i_m[3];                  /* position in S_I (north, west, up), m */
	float vel_i_mps[3];                /* velocity in S_I, m/s */
	float rotor_thrust_n[HAL_ROTORS];  /* measured thrust f_j, N */
	float rotor_torque_nm[HAL_ROTORS]; /* measured reaction torque tau_j, N m */
	float thr_cmd_echo[HAL_ROTORS];    /* throttle command as the plant saw it */
	double lat_deg, lon_deg;           /* plant's geodetic position, WGS84 degrees */
	float alt_msl_m;                   /* altitude above mean sea level, m */
	float accel_b_g[3];                /* specific force in FLU over the plant's gravity, g:
	                                        (0, 0, +1) level at rest or in steady hover */
	float rotor_speed_rps[HAL_ROTORS]; /* rotor speed, rad/s */
};

/* Health of the plant link, as the platform counts it. */
struct hal_plant_stats {
	uint32_t frames;        /* sensor frames accepted */
	uint32_t dropped;       /* datagrams or messages dropped: malformed, foreign, unknown */
	uint32_t foreign;       /* of which from a sender other than the configured plant */
	uint32_t stale;         /* frames older than the newest (reordered, delayed) */
	uint32_t parts_missing; /* HAL_FRAME_* bits of wanted parts not seen yet */
};

struct app_log_frame; /* defined in app/log.h; the platform serialises it */
struct app_id_result; /* defined in app/id_result.h */

struct hal {
	void *ctx; /* the platform's own state, passed back to every function */

	/* ---- time */
	/* Monotonic wall-clock time, microseconds (telemetry rates, link supervision). */
	uint64_t (*wall_us)(void *ctx);
	/* Wall-clock time since the UNIX epoch, microseconds (signing time stamps). */
	uint64_t (*unix_us)(void *ctx);

	/* ---- plant link */
	/* Command the 8 throttles (ratio 0..1, rotor j = index j-1). Once per frame. */
	void (*plant_actuate)(void *ctx, const float thr[HAL_ROTORS]);
	void (*plant_stats)(void *ctx, struct hal_plant_stats *out);

	/* ---- ground link (bytes; the framing is the MAVLink module's business) */
	void (*ground_send)(void *ctx, const uint8_t *buf, size_t len);
	/* MAVLink 2 signing: true (and the 32-byte secret in key) when the platform
	 * was configured with a key; then unsigned or badly signed input is rejected. */
	bool (*ground_signing_key)(void *ctx, uint8_t key[32]);

	/* ---- parameter storage: text, written atomically (all old or all new) */
	/* Returns 0 on success, -1 on failure (the platform reports the reason). */
	int (*param_store)(void *ctx, const char *text, size_t len);
	/* Reads the stored text into buf (NUL-terminated); its length, -1 if none. */
	long (*param_fetch)(void *ctx, char *buf, size_t cap);

	/* ---- log */
	void (*log_frame)(void *ctx, const struct app_log_frame *f);
	/* An event (mode change, warning) stamped with plant time. */
	void (*log_event)(void *ctx, double t_s, int severity, const char *text);
	/* An identification result as data, stamped with plant time (NULL: not logged). */
	void (*log_id_result)(void *ctx, double t_s, const struct app_id_result *r);

	/* ---- console / diagnostics: one line, without its newline */
	void (*report)(void *ctx, const char *line);
};

/* Call sites read as before: hal_actuate(h, thr) instead of h->plant_actuate(h->ctx, thr). */
static inline uint64_t hal_wall_us(const struct hal *h) { return h->wall_us(h->ctx); }
static inline uint64_t hal_unix_us(const struct hal *h) { return h->unix_us(h->ctx); }
static inline void hal_actuate(const struct hal *h, const float thr[HAL_ROTORS]) { h->plant_actuate(h->ctx, thr); }
static inline void hal_plant_stats(const struct hal *h, struct hal_plant_stats *out) { h->plant_stats(h->ctx, out); }
static inline void hal_ground_send(const struct hal *h, const uint8_t *buf, size_t len)
{
	h->ground_send(h->ctx, buf, len);
}
static inline bool hal_signing_key(const struct hal *h, uint8_t key[32]) { return h->ground_signing_key(h->ctx, key); }
static inline int hal_param_store(const struct hal *h, const char *text, size_t len)
{
	return h->param_store(h->ctx, text, len);
}
static inline long hal_param_fetch(const struct hal *h, char *buf, size_t cap)
{
	return h->param_fetch(h->ctx, buf, cap);
}
static inline void hal_log_frame(const struct hal *h, const struct app_log_frame *f) { h->log_frame(h->ctx, f); }
/* Sets a frame's time: plant frame n at t_us (t_s follows). */
static inline void hal_frame_time(struct hal_sensor_frame *f, uint64_t frame_n, uint64_t t_us)
{
	f->frame_n = frame_n;
	f->t_us = t_us;
	f->t_s = (double)t_us * 1e-6;
}
static inline void hal_log_event(const struct hal *h, double t_s, int severity, const char *text)
{
	h->log_event(h->ctx, t_s, severity, text);
}
static inline void hal_log_id_result(const struct hal *h, double t_s, const struct app_id_result *r)
{
	if (h->log_id_result)
		h->log_id_result(h->ctx, t_s, r);
}
/* printf-style line to the platform's console (formatted into 256 bytes). */
void hal_reportf(const struct hal *h, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* A parameter store held in RAM (a board's sector image, a test's file) for the param_store and
 * param_fetch hooks: buf of cap bytes holds the text, *len its length (-1: nothing stored).
 * hal_ram_param_put returns -1 when the text does not fit (nothing changed), else 0;
 * hal_ram_param_get copies at most out_cap - 1 bytes and a NUL, returning the count (-1: none). */
int hal_ram_param_put(char *buf, size_t cap, long *len, const char *text, size_t n);
long hal_ram_param_get(const char *buf, long len, char *out, size_t out_cap);

#endif /* OCTO_HAL_H */
