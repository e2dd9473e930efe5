/*
 * xp_client.h - octo-fw's X-Plane 11/12 client (host platform).
 *
 * One UDP socket bound to --xp-listen: DATA output arrives there (the user or
 * the simulator points X-Plane's Data Output at it), RREF replies too (they go
 * to the source port of the request, which is this socket). The client:
 *   - DSELs the rows it needs, re-sending every second until each row has been
 *     seen recently, and USELs rows it did not ask for;
 *   - detects X-Plane 11 vs 12 by RREF of sim/version/xplane_internal_version
 *     at 1 Hz, re-requested every 5 s (>= 120000: X-Plane 12);
 *   - accepts datagrams only from the configured X-Plane host IP (any port:
 *     X-Plane sends from another port than it receives on); malformed or
 *     foreign datagrams are dropped and counted;
 *   - converts X-Plane's conventions to the paper's frames (xp_frame_convert,
 *     the one place where that happens in octo-fw);
 *   - actuates with 8 DREFs ENGN_thro_use[i] plus override_throttles, or one
 *     DATA row 25 datagram;
 *   - keeps the plant's time line in integer microseconds (struct xp_clock): X-Plane's
 *     float32 mission time tells order, gaps and lost frames only as far as its
 *     resolution allows (docs/time.md).
 */
#ifndef OCTO_XP_CLIENT_H
#define OCTO_XP_CLIENT_H

#include <netinet/in.h>
#include <stdbool.h>
#include <stdint.h>

#include "hal.h"
#include "xp_proto.h"

enum xp_actuation { XP_ACT_DREF = 0, XP_ACT_DATA25 = 1 };

#define XP_VERSION_12 120000u
#define XP_RREF_VERSION_INDEX 1

/* Row numbers the client needs and the HAL_FRAME_* bit each one fills. */
#define XP_ROW_TIMES 1
#define XP_ROW_GLOADS 4
#define XP_ROW_RATES 16
#define XP_ROW_ATT 17
#define XP_ROW_GLOBAL 20
#define XP_ROW_LOCAL 21
#define XP_ROW_THR_CMD 25
#define XP_ROW_THRUST 35
#define XP_ROW_TORQUE 36
#define XP_ROW_PROP_RPM 38

/*
 * The plant's time line from row 1's mission time, a float32 whose resolution (its ulp)
 * grows with the time: 3.9 ms from 2^15 s, 62.5 ms from 2^19 s. Each new stamp advances
 * the count of plant frames by the difference of the stamps rounded to the period, when
 * that count is the only one within the stamp's resolution (|d - n P| <= ulp, n >= 1).
 * When several counts are (the resolution is as coarse as the period or coarser), each
 * new datagram counts as one frame: lost frames are then not seen, and when the stamp
 * cannot tell consecutive frames apart (ulp >= P) neither are duplicates.
 * The time is t_us = base_us + (frame_n - base_n) P, in integers of microseconds from the
 * first frame's stamp. P is configured (xp_clock_set_period) or measured: the first step
 * a fine stamp shows, then the stamps' difference over all frames counted since a
 * reference frame, once its error (the ulp over that span) is below 1e-3 of it; each new
 * measurement moves the base, so t_us never jumps.
 */
struct xp_clock {
	bool have;                /* a first stamp seen */
	bool period_fixed;        /* P configured: not measured */
	bool period_known;        /* P configured or measured (else the nominal 1/90 s) */
	float last_raw;           /* the newest frame's stamp as sent */
	double last_s;            /* ... re-based (offset_s added) */
	double offset_s;          /* re-basing after a step back (an X-Plane reload) */
	double period_s;          /* P */
	uint64_t frame_n, t_us;   /* the newest frame's count and time */
	uint64_t base_n, base_us; /* where the time line of the current P starts */
	double ref_s;             /* the measurement's reference frame: stamp ... */
	uint64_t ref_n;           /* ... and count */
	uint64_t measured_n;      /* frame_n at the last measurement */
	uint32_t coarse;          /* new datagrams counted as one frame: the stamp could not tell */
	uint32_t off_grid;        /* steps no count of the period explained (jitter, another rate) */
	uint32_t rebased;         /* steps back taken for a reload */
};

/* What one stamp was: a new frame (n frames on), a duplicate, or older than the newest. */
enum xp_stamp { XP_STAMP_NEW = 1, XP_STAMP_SAME = 0, XP_STAMP_OLD = -1, XP_STAMP_BAD = -2 };
/* The largest plant time a stamp may carry (about 31 years): beyond it, or negative or not
 * finite, a stamp is corrupt (XP_STAMP_BAD) and its frame cannot be placed. */
#define XP_STAMP_MAX_S 1.0e9

void xp_clock_init(struct xp_clock *k);
/* Configures the period (s > 0): counted with it, not measured. */
void xp_clock_set_period(struct xp_clock *k, double period_s);
/* Takes one stamp: XP_STAMP_NEW with *n frames counted (k->frame_n, k->t_us updated), or
 * SAME / OLD / BAD (*n = 0, nothing changed). */
enum xp_stamp xp_clock_stamp(struct xp_clock *k, float stamp, uint64_t *n);

struct xp_client {
	int fd; /* -1 without a socket (see send) */
	/* Where requests go when set (in-process platforms); otherwise sendto(fd). */
	void (*send)(void *ctx, const uint8_t *buf, size_t len);
	void *send_ctx;
	struct sockaddr_in xp; /* where X-Plane receives (requests go there) */
	enum xp_actuation act;
	struct hal_plant_stats stats;
	uint32_t xp_version;      /* sim/version/xplane_internal_version, 0 = unknown yet */
	uint64_t row_seen_us[12]; /* per wanted row, wall time last seen */
	uint64_t last_dsel_us, last_rref_us, last_override_us, last_usel_us;
	uint64_t last_data_us;       /* wall time of the last DATA datagram */
	uint8_t unselected[256 / 8]; /* rows already USEL'd */
	struct xp_clock clock;       /* the plant's time line */
	uint32_t seq;
	struct xp_msg_in msg; /* decode buffer (large: kept off the stack) */
	/* the throttle DREFs (ENGN_thro_use[i]), encoded once: a frame rewrites their values */
	uint8_t thro_dref[HAL_ROTORS][XP_DREF_LEN];
	int8_t wanted_slot[256]; /* row -> its index among the wanted rows, -1: not wanted */
};

/* Sets the client up without a socket: requests go to c->send (set it after). */
void xp_client_init(struct xp_client *c, const struct sockaddr_in *xplane, enum xp_actuation act);
/* Opens the socket; returns 0 or -1 (reason on stderr). */
int xp_client_open(struct xp_client *c, uint16_t listen_port, const struct sockaddr_in *xplane, enum xp_actuation act);
/* Reads one datagram (non-blocking). Returns 1 when it was a DATA frame turned
 * into *frame (absent rows keep their previous values), 0 for any other
 * datagram (RREF, dropped), -1 when there was nothing to read. */
int xp_client_receive(struct xp_client *c, struct hal_sensor_frame *frame, uint64_t now_us);
/* The same for one datagram already received (n bytes from `from`): 1 for a DATA
 * frame, 0 otherwise. n larger than any X-Plane message counts as dropped. */
int xp_client_input(struct xp_client *c, const uint8_t *buf, size_t n, const struct sockaddr_in *from,
		    struct hal_sensor_frame *frame, uint64_t now_us);
/* Periodic duties: DSEL/USEL re-sends, RREF re-requests. */
void xp_client_poll(struct xp_client *c, uint64_t now_us);
void xp_client_actuate(struct xp_client *c, const float thr[HAL_ROTORS], uint64_t now_us);
/* Hands the throttles back to X-Plane (override_throttles = 0). */
void xp_client_release(struct xp_client *c);

/* Pure conversion of decoded DATA records into the paper's frames: fills the
 * fields of *f for the rows present and returns their HAL_FRAME_* bits. Rates
 * need the version (0 = unknown: rates left out). Time is not re-based here. */
uint32_t xp_frame_convert(const struct xp_data_rec *recs, size_t n, uint32_t xp_version, struct hal_sensor_frame *f,
			  float *raw_time_s);

#endif /* OCTO_XP_CLIENT_H */
