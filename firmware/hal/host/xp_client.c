/* xp_client.c - X-Plane client: rows, version, conventions, actuation (see xp_client.h). */
#include "xp_client.h"

#include "host_report.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

static const int32_t wanted_rows[] = {XP_ROW_TIMES,  XP_ROW_RATES,  XP_ROW_ATT,    XP_ROW_GLOBAL,  XP_ROW_LOCAL,
				      XP_ROW_THRUST, XP_ROW_TORQUE, XP_ROW_GLOADS, XP_ROW_PROP_RPM};
#define N_WANTED (sizeof wanted_rows / sizeof wanted_rows[0])
_Static_assert(N_WANTED <= sizeof((struct xp_client *)0)->row_seen_us / sizeof(uint64_t),
	       "a last-seen time per wanted row");
static const uint32_t wanted_bits[N_WANTED] = {HAL_FRAME_TIME,   HAL_FRAME_RATES, HAL_FRAME_ATT,
					       HAL_FRAME_GLOBAL, HAL_FRAME_POS,   HAL_FRAME_THRUST,
					       HAL_FRAME_TORQUE, HAL_FRAME_ACCEL, HAL_FRAME_RPM};

#define LB_TO_N 4.4482216152605
#define FTLB_TO_NM 1.3558179483314
#define RPM_TO_RPS (2.0 * 3.14159265358979323846 / 60.0)
#define DEG_TO_RAD 0.017453292519943295
#define FT_TO_M 0.3048
#define ROW_FRESH_US 1000000u /* a row not seen for 1 s is selected again */
#define DSEL_PERIOD_US 1000000u
#define RREF_PERIOD_US 5000000u
#define OVERRIDE_PERIOD_US 1000000u
#define XP_SILENCE_US 1000000u           /* DATA silent this long: re-detect the version */
#define XP_STALE_S 0.25                  /* older by less than this: a reordered frame */
#define XP_NOMINAL_PERIOD_S (1.0 / 90.0) /* the period until one is known */
#define XP_MEASURE_EVERY 90u             /* frames between measurements of the period */
#define XP_MEASURE_REL 1e-3              /* ... taken when the stamps' error is below this of the span */
#define XP_MAX_COUNT 1e9                 /* frames one step may count (a day's silence is 8e6) */

static const char VERSION_REF[] = "sim/version/xplane_internal_version";
static const char OVERRIDE_REF[] = "sim/operation/override/override_throttles";
static const char *const THRO_USE_REF[HAL_ROTORS] = {
	"sim/flightmodel/engine/ENGN_thro_use[0]", "sim/flightmodel/engine/ENGN_thro_use[1]",
	"sim/flightmodel/engine/ENGN_thro_use[2]", "sim/flightmodel/engine/ENGN_thro_use[3]",
	"sim/flightmodel/engine/ENGN_thro_use[4]", "sim/flightmodel/engine/ENGN_thro_use[5]",
	"sim/flightmodel/engine/ENGN_thro_use[6]", "sim/flightmodel/engine/ENGN_thro_use[7]"};

/* ---------------------------------------------------------------- the plant's time line */

void xp_clock_init(struct xp_clock *k)
{
	memset(k, 0, sizeof *k);
	k->period_s = XP_NOMINAL_PERIOD_S;
}

/* The time line of the current period starts at the newest frame. */
static void clock_base(struct xp_clock *k)
{
	k->base_n = k->frame_n;
	k->base_us = k->t_us;
}

/* The period's measurement starts over at the newest frame. */
static void clock_ref(struct xp_clock *k)
{
	k->ref_s = k->last_s;
	k->ref_n = k->frame_n;
	k->measured_n = k->frame_n;
}

void xp_clock_set_period(struct xp_clock *k, double period_s)
{
	if (!(period_s > 0.0))
		return;
	clock_base(k);
	k->period_s = period_s;
	k->period_fixed = k->period_known = true;
}

/* The spacing of float32 values at the magnitude of x (its ulp), s. */
static double f32_ulp(float x)
{
	int e;
	(void)frexpf(fabsf(x), &e); /* |x| = m 2^e, m in [0.5, 1) */
	return ldexp(1.0, (e < -125 ? -125 : e) - 24);
}

/* s in whole microseconds; a stamp beyond 2^64 us (a corrupt one) saturates. */
static uint64_t us_of(double s)
{
	if (!(s > 0.0))
		return 0u;
	return s < 1.8e13 ? (uint64_t)(s * 1e6 + 0.5) : UINT64_MAX;
}

enum xp_stamp xp_clock_stamp(struct xp_clock *k, float stamp, uint64_t *n)
{
	*n = 0;
	if (!((double)stamp >= 0.0 && (double)stamp <= XP_STAMP_MAX_S))
		return XP_STAMP_BAD; /* the clock never takes it: time stays monotonic */
	double s = (double)stamp + k->offset_s;
	if (!k->have) {
		k->have = true;
		k->last_raw = stamp;
		k->last_s = s;
		k->t_us = us_of(s);
		clock_base(k);
		clock_ref(k);
		return XP_STAMP_NEW;
	}
	double u = f32_ulp(fabsf(stamp) > fabsf(k->last_raw) ? stamp : k->last_raw);
	double d = s - k->last_s, p = k->period_s;
	double c;             /* frames counted */
	bool restart = false; /* the measurement starts over after this frame */
	if (d < 0.0) {
		if (-d < XP_STALE_S + u)
			return XP_STAMP_OLD; /* reordered or delayed */
		/* a larger step back: X-Plane reloaded or the simulator restarted; the time line
		 * goes on one period after the newest frame */
		k->offset_s += k->last_s + p - s;
		s = k->last_s + p;
		c = 1.0;
		k->rebased++;
		restart = true;
	} else if (d == 0.0) {
		if (u < p)
			return XP_STAMP_SAME; /* consecutive frames always differ: a duplicate */
		c = 1.0;                      /* too coarse to tell: a new datagram is a new frame */
		k->coarse++;
	} else if (!k->period_fixed && 8.0 * u <= d && (!k->period_known || d < 0.75 * p)) {
		/* the first step a fine stamp shows, or a shorter one (the first was a gap): the period */
		clock_base(k);
		clock_ref(k);
		k->period_s = p = d;
		k->period_known = true;
		c = 1.0;
	} else {
		/* the counts n >= 1 with |d - n p| <= u */
		double lo = ceil((d - u) / p), hi = floor((d + u) / p);
		if (lo < 1.0)
			lo = 1.0;
		if (lo == hi) {
			c = lo;
		} else if (lo < hi) {
			c = 1.0; /* several: the stamp is too coarse to count lost frames */
			k->coarse++;
		} else {
			c = floor(d / p + 0.5); /* none: jitter, or another period */
			c = c < 1.0 ? 1.0 : c;
			k->off_grid++;
			restart = true;
		}
	}
	if (c > XP_MAX_COUNT)
		c = XP_MAX_COUNT;
	*n = (uint64_t)c;
	k->frame_n += *n;
	k->last_raw = stamp;
	k->last_s = s;
	k->t_us = k->base_us + us_of((double)(k->frame_n - k->base_n) * k->period_s);
	if (restart) {
		clock_ref(k);
	} else if (!k->period_fixed && k->frame_n - k->measured_n >= XP_MEASURE_EVERY) {
		/* the stamps' difference over the frames counted since the reference: its error is
		 * at most the ulp (half of each stamp's) */
		double span = s - k->ref_s;
		if (span > 0.0 && u <= XP_MEASURE_REL * span) {
			clock_base(k);
			k->period_s = span / (double)(k->frame_n - k->ref_n);
			k->period_known = true;
		}
		k->measured_n = k->frame_n;
	}
	return XP_STAMP_NEW;
}

/* ---------------------------------------------------------------- the client */

static void send_to_xp(struct xp_client *c, const uint8_t *buf, size_t len)
{
	if (!len)
		return;
	if (c->send) {
		c->send(c->send_ctx, buf, len);
		return;
	}
	/* UDP: a full socket buffer or an ICMP error from an absent X-Plane must
	 * not stop the loop; the next frame sends again. */
	(void)sendto(c->fd, buf, len, 0, (const struct sockaddr *)&c->xp, sizeof c->xp);
}

void xp_client_init(struct xp_client *c, const struct sockaddr_in *xplane, enum xp_actuation act)
{
	memset(c, 0, sizeof *c);
	c->fd = -1;
	c->xp = *xplane;
	c->act = act;
	xp_clock_init(&c->clock);
	c->stats.parts_missing = HAL_FRAME_TIME | HAL_FRAME_RATES | HAL_FRAME_ATT | HAL_FRAME_GLOBAL | HAL_FRAME_POS |
				 HAL_FRAME_THRUST | HAL_FRAME_TORQUE | HAL_FRAME_ACCEL | HAL_FRAME_RPM;
	for (int i = 0; i < HAL_ROTORS; i++)
		(void)xp_encode_dref(c->thro_dref[i], sizeof c->thro_dref[i], 0.0f, THRO_USE_REF[i]);
	memset(c->wanted_slot, -1, sizeof c->wanted_slot);
	for (size_t i = 0; i < N_WANTED; i++)
		c->wanted_slot[wanted_rows[i]] = (int8_t)i;
}

int xp_client_open(struct xp_client *c, uint16_t listen_port, const struct sockaddr_in *xplane, enum xp_actuation act)
{
	xp_client_init(c, xplane, act);
	c->fd = socket(AF_INET, SOCK_DGRAM, 0);
	if (c->fd < 0) {
		perror("octo-fw: X-Plane socket");
		return -1;
	}
	/* no SO_REUSEADDR: with it a second process binds the same UDP port without an error
	 * and the kernel hands the frames to one of the two, so two vehicles on one port would
	 * fly on each other's frames; this way the second is refused at start, saying why */
	struct sockaddr_in a;
	memset(&a, 0, sizeof a);
	a.sin_family = AF_INET;
	a.sin_addr.s_addr = htonl(INADDR_ANY);
	a.sin_port = htons(listen_port);
	if (bind(c->fd, (struct sockaddr *)&a, sizeof a) < 0) {
		fprintf(stderr, "octo-fw: cannot bind X-Plane port %u: %s\n", listen_port, strerror(errno));
		close(c->fd);
		c->fd = -1;
		return -1;
	}
	(void)fcntl(c->fd, F_SETFL, fcntl(c->fd, F_GETFL) | O_NONBLOCK);
	return 0;
}

static void quat_of_euler_ned(float phi_deg, float theta_deg, float psi_deg, double q[4])
{
	double hp = 0.5 * (double)phi_deg * DEG_TO_RAD, ht = 0.5 * (double)theta_deg * DEG_TO_RAD,
	       hs = 0.5 * (double)psi_deg * DEG_TO_RAD;
	double cp = cos(hp), sp = sin(hp), ct = cos(ht), st = sin(ht), cs = cos(hs), ss = sin(hs);
	q[0] = cp * ct * cs + sp * st * ss;
	q[1] = sp * ct * cs - cp * st * ss;
	q[2] = cp * st * cs + sp * ct * ss;
	q[3] = cp * ct * ss - sp * st * cs;
}

/*
 * The one place where X-Plane's conventions become the paper's frames.
 *   X-Plane: Euler Z-Y-X from NED to body FRD (row 17: c1 pitch, c2 roll,
 *            c3 true heading, degrees); rates P, Q, R about FRD (row 16: XP 10/11
 *            c1 Q, c2 P, c3 R in rad/s; XP 12 c1 P, c2 Q, c3 R in deg/s);
 *            OpenGL local frame +X east, +Y up, +Z south (row 21).
 *   Paper:   S_I = (north, west, up) ("NWU"), S_B = (forward, left, up) ("FLU").
 *   NWU = F * NED and FLU = F * FRD with F = diag(1, -1, -1), a half turn about
 *   X, so the attitude quaternion is conjugated by that half turn:
 *   q_ib = [w, x, -y, -z] of X-Plane's q_ned_frd; omega_B = [P, -Q, -R];
 *   r_I = [north, west, up] = [-Z, -X, Y] of OpenGL, likewise for velocity.
 *   Row 4's load factors (c5 normal, up +; c6 axial, forward +; c7 side, right +)
 *   give the specific force over g in FLU: [axial, -side, normal].
 *   Row 38's prop rpm gives the rotor speed: rad/s = rpm * 2 pi / 60.
 */
uint32_t xp_frame_convert(const struct xp_data_rec *recs, size_t n, uint32_t xp_version, struct hal_sensor_frame *f,
			  float *raw_time_s)
{
	uint32_t bits = 0;
	for (size_t r = 0; r < n; r++) {
		const float *c = recs[r].col;
		switch (recs[r].row) {
		case XP_ROW_TIMES:
			if (!isfinite(c[2]))
				break;
			*raw_time_s = c[2];
			bits |= HAL_FRAME_TIME;
			break;
		case XP_ROW_RATES: {
			if (!xp_version)
				break; /* column order and units unknown until the version is */
			double p, q, rr;
			if (xp_version >= XP_VERSION_12) {
				p = (double)c[0] * DEG_TO_RAD;
				q = (double)c[1] * DEG_TO_RAD;
				rr = (double)c[2] * DEG_TO_RAD;
			} else {
				q = (double)c[0];
				p = (double)c[1];
				rr = (double)c[2];
			}
			if (!isfinite(p) || !isfinite(q) || !isfinite(rr))
				break;
			f->rate_b_rps[0] = (float)p;
			f->rate_b_rps[1] = (float)-q;
			f->rate_b_rps[2] = (float)-rr;
			bits |= HAL_FRAME_RATES;
			break;
		}
		case XP_ROW_ATT: {
			if (!isfinite(c[0]) || !isfinite(c[1]) || !isfinite(c[2]))
				break;
			double q[4];
			quat_of_euler_ned(c[1], c[0], c[2], q);
			f->q_ib[0] = (float)q[0];
			f->q_ib[1] = (float)q[1];
			f->q_ib[2] = (float)-q[2];
			f->q_ib[3] = (float)-q[3];
			bits |= HAL_FRAME_ATT;
			break;
		}
		case XP_ROW_GLOBAL:
			if (!isfinite(c[0]) || !isfinite(c[1]) || !isfinite(c[2]) || fabsf(c[0]) > 90.0f ||
			    fabsf(c[1]) > 180.0f)
				break;
			f->lat_deg = (double)c[0];
			f->lon_deg = (double)c[1];
			f->alt_msl_m = (float)((double)c[2] * FT_TO_M);
			bits |= HAL_FRAME_GLOBAL;
			break;
		case XP_ROW_LOCAL: {
			bool ok = true;
			for (int i = 0; i < 6; i++)
				ok = ok && isfinite(c[i]);
			if (!ok)
				break;
			f->pos_i_m[0] = -c[2];
			f->pos_i_m[1] = -c[0];
			f->pos_i_m[2] = c[1];
			f->vel_i_mps[0] = -c[5];
			f->vel_i_mps[1] = -c[3];
			f->vel_i_mps[2] = c[4];
			bits |= HAL_FRAME_POS;
			break;
		}
		case XP_ROW_THRUST:
			for (int i = 0; i < HAL_ROTORS; i++)
				f->rotor_thrust_n[i] = isfinite(c[i]) ? (float)((double)c[i] * LB_TO_N) : 0.0f;
			bits |= HAL_FRAME_THRUST;
			break;
		case XP_ROW_TORQUE:
			for (int i = 0; i < HAL_ROTORS; i++)
				f->rotor_torque_nm[i] = isfinite(c[i]) ? (float)((double)c[i] * FTLB_TO_NM) : 0.0f;
			bits |= HAL_FRAME_TORQUE;
			break;
		case XP_ROW_GLOADS:
			if (!isfinite(c[4]) || !isfinite(c[5]) || !isfinite(c[6]))
				break;
			f->accel_b_g[0] = c[5];
			f->accel_b_g[1] = -c[6];
			f->accel_b_g[2] = c[4];
			bits |= HAL_FRAME_ACCEL;
			break;
		case XP_ROW_PROP_RPM:
			for (int i = 0; i < HAL_ROTORS; i++)
				f->rotor_speed_rps[i] =
					isfinite(c[i]) && c[i] > 0.0f ? (float)((double)c[i] * RPM_TO_RPS) : 0.0f;
			bits |= HAL_FRAME_RPM;
			break;
		case XP_ROW_THR_CMD:
			for (int i = 0; i < HAL_ROTORS; i++)
				f->thr_cmd_echo[i] = isfinite(c[i]) ? c[i] : 0.0f;
			bits |= HAL_FRAME_THR_CMD;
			break;
		default: break;
		}
	}
	return bits;
}

static void note_rows(struct xp_client *c, const struct xp_msg_in *m, uint64_t now_us)
{
	int32_t unsel[XP_MAX_DATA_RECS];
	size_t nu = 0;
	for (size_t r = 0; r < m->n; r++) {
		int32_t row = m->data[r].row;
		int slot = row >= 0 && row < 256 ? c->wanted_slot[row] : -1;
		bool found = slot >= 0;
		if (found)
			c->row_seen_us[slot] = now_us;
		if (!found && row >= 0 && row < 256 && !(c->unselected[row / 8] & (1u << (row % 8)))) {
			unsel[nu++] = row;
		}
	}
	if (nu && now_us - c->last_usel_us >= 200000u) {
		uint8_t buf[5 + 4 * XP_MAX_DATA_RECS];
		send_to_xp(c, buf, xp_encode_dsel(buf, sizeof buf, 1, unsel, nu));
		for (size_t i = 0; i < nu; i++)
			c->unselected[unsel[i] / 8] |= (uint8_t)(1u << (unsel[i] % 8));
		c->last_usel_us = now_us;
	}
	uint32_t missing = 0;
	for (size_t i = 0; i < N_WANTED; i++)
		if (!c->row_seen_us[i] || now_us - c->row_seen_us[i] > ROW_FRESH_US)
			missing |= wanted_bits[i];
	c->stats.parts_missing = missing;
}

int xp_client_receive(struct xp_client *c, struct hal_sensor_frame *frame, uint64_t now_us)
{
	uint8_t buf[2048];
	struct sockaddr_in from;
	socklen_t fl = sizeof from;
	memset(&from, 0, sizeof from);
	ssize_t n = recvfrom(c->fd, buf, sizeof buf, 0, (struct sockaddr *)&from, &fl);
	if (n < 0)
		return -1;
	if (fl < sizeof from)
		from.sin_family = AF_UNSPEC; /* not an IPv4 sender: foreign */
	return xp_client_input(c, buf, (size_t)n, &from, frame, now_us);
}

int xp_client_input(struct xp_client *c, const uint8_t *buf, size_t n, const struct sockaddr_in *from,
		    struct hal_sensor_frame *frame, uint64_t now_us)
{
	if (from->sin_family != AF_INET || from->sin_addr.s_addr != c->xp.sin_addr.s_addr) {
		c->stats.dropped++;
		c->stats.foreign++;
		return 0;
	}
	if (n >= 2048) { /* truncated: larger than any X-Plane message we take */
		c->stats.dropped++;
		return 0;
	}
	switch (xp_decode(buf, n, &c->msg)) {
	case XP_MSG_RREF:
		for (size_t r = 0; r < c->msg.n; r++)
			if (c->msg.rref[r].index == XP_RREF_VERSION_INDEX) {
				float v = c->msg.rref[r].value;
				if (isfinite(v) && v >= 1.0f && v < 1.0e7f && (uint32_t)v != c->xp_version) {
					c->xp_version = (uint32_t)v;
					host_report("X-Plane version %" PRIu32 " (row 16 as X-Plane %s)", c->xp_version,
						    c->xp_version >= XP_VERSION_12 ? "12: P,Q,R deg/s"
										   : "10/11: Q,P,R rad/s");
				}
			}
		return 0;
	case XP_MSG_DATA: break;
	default: c->stats.dropped++; return 0;
	}
	/* DATA again after a silence: X-Plane may have been restarted (another
	 * version): ask for the version now instead of at the next 5 s re-request */
	if (c->last_data_us && now_us - c->last_data_us > XP_SILENCE_US) {
		uint8_t req[XP_RREF_REQ_LEN];
		send_to_xp(c, req, xp_encode_rref(req, sizeof req, 1, XP_RREF_VERSION_INDEX, VERSION_REF));
		c->last_rref_us = now_us;
	}
	c->last_data_us = now_us;
	note_rows(c, &c->msg, now_us);
	struct hal_sensor_frame f = *frame; /* keeps the previous values of absent rows */
	float raw_t = 0.0f;
	uint32_t bits = xp_frame_convert(c->msg.data, c->msg.n, c->xp_version, &f, &raw_t);
	if (!(bits & HAL_FRAME_TIME)) {
		c->stats.dropped++; /* a frame without time cannot be placed */
		return 0;
	}
	/* Time never runs backwards (xp_clock_stamp). A frame older than the newest was
	 * reordered or delayed: the newest state stands, the frame still counts (it is answered
	 * with one actuation) but carries no news. A duplicate brings its own (equal) values and
	 * the same time. */
	uint64_t n_new;
	enum xp_stamp st = xp_clock_stamp(&c->clock, raw_t, &n_new);
	if (st == XP_STAMP_BAD) {
		c->stats.dropped++; /* a corrupt time cannot be placed either */
		return 0;
	}
	if (st == XP_STAMP_OLD) {
		c->stats.stale++;
		frame->seq = ++c->seq;
		c->stats.frames++;
		return 1;
	}
	hal_frame_time(&f, c->clock.frame_n, c->clock.t_us);
	f.valid = bits;
	f.seq = ++c->seq;
	*frame = f;
	c->stats.frames++;
	return 1;
}

void xp_client_poll(struct xp_client *c, uint64_t now_us)
{
	uint8_t buf[XP_DREF_LEN];
	bool stale = false;
	for (size_t i = 0; i < N_WANTED; i++)
		if (!c->row_seen_us[i] || now_us - c->row_seen_us[i] > ROW_FRESH_US)
			stale = true;
	if (stale && (!c->last_dsel_us || now_us - c->last_dsel_us >= DSEL_PERIOD_US)) {
		send_to_xp(c, buf, xp_encode_dsel(buf, sizeof buf, 0, wanted_rows, N_WANTED));
		c->last_dsel_us = now_us;
		/* rows USEL'd before may be wanted by nobody still; forget them so a
		 * restarted X-Plane that shows them again gets them unselected again */
		memset(c->unselected, 0, sizeof c->unselected);
	}
	if (!c->last_rref_us || now_us - c->last_rref_us >= RREF_PERIOD_US) {
		send_to_xp(c, buf, xp_encode_rref(buf, sizeof buf, 1, XP_RREF_VERSION_INDEX, VERSION_REF));
		c->last_rref_us = now_us;
	}
	if (stale) {
		uint32_t missing = 0;
		for (size_t i = 0; i < N_WANTED; i++)
			if (!c->row_seen_us[i] || now_us - c->row_seen_us[i] > ROW_FRESH_US)
				missing |= wanted_bits[i];
		c->stats.parts_missing = missing;
	}
}

void xp_client_actuate(struct xp_client *c, const float thr[HAL_ROTORS], uint64_t now_us)
{
	float t[HAL_ROTORS];
	for (int i = 0; i < HAL_ROTORS; i++) {
		float v = thr[i];
		t[i] = !(v > 0.0f) ? 0.0f : (v > 1.0f ? 1.0f : v); /* NaN -> 0 */
	}
	if (c->act == XP_ACT_DATA25) {
		struct xp_data_rec r = {.row = XP_ROW_THR_CMD};
		memcpy(r.col, t, sizeof t);
		uint8_t buf[5 + XP_DATA_REC_LEN];
		send_to_xp(c, buf, xp_encode_data(buf, sizeof buf, &r, 1));
		return;
	}
	uint8_t buf[XP_DREF_LEN];
	if (!c->last_override_us || now_us - c->last_override_us >= OVERRIDE_PERIOD_US) {
		send_to_xp(c, buf, xp_encode_dref(buf, sizeof buf, 1.0f, OVERRIDE_REF));
		c->last_override_us = now_us;
	}
	for (int i = 0; i < HAL_ROTORS; i++) {
		xp_dref_set_value(c->thro_dref[i], t[i]);
		send_to_xp(c, c->thro_dref[i], sizeof c->thro_dref[i]);
	}
}

void xp_client_release(struct xp_client *c)
{
	if (c->fd < 0 || c->act != XP_ACT_DREF || !c->last_override_us)
		return;
	uint8_t buf[XP_DREF_LEN];
	send_to_xp(c, buf, xp_encode_dref(buf, sizeof buf, 0.0f, OVERRIDE_REF));
}
