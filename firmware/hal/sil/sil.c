/*
 * sil.c - octo-sil: command line, the lockstep loop, and the struct hal of the
 * in-process platform (see sil.h).
 *
 * Clock: the struct hal's wall_us is the platform clock. Without a ground station it is
 * virtual: it starts at 1 s and advances by one frame period per pass of the
 * loop (also while the plant waits for its first command, when octo-sim would
 * re-send frame 0 at the real-time rate), so everything the app does is a
 * function of the flags alone. With --mavlink-listen it is the monotonic wall
 * clock, so that telemetry rates are in wall-clock time as with octo-fw.
 */
#include "sil.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <common/mavlink.h>

#include "host.h"
#include "mission.h"

/* ---------------------------------------------------------------- struct hal */

static uint64_t mono_us(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* The platform clock: virtual (one frame period per pass) unless a ground
 * station is served. */
static uint64_t sil_clock(const struct sil *s)
{
	return s->wall_clock ? mono_us() : s->now_us;
}

static uint64_t wall_us(void *ctx)
{
	const struct sil *s = ctx;
	return sil_clock(s);
}

static uint64_t unix_us(void *ctx)
{
	(void)ctx;
	struct timespec ts;
	clock_gettime(CLOCK_REALTIME, &ts);
	return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static void plant_actuate(void *ctx, const float thr[HAL_ROTORS])
{
	struct sil *s = ctx;
	xp_client_actuate(&s->xp, thr, sil_clock(s));
}

static void plant_stats(void *ctx, struct hal_plant_stats *out)
{
	const struct sil *s = ctx;
	*out = s->xp.stats;
}

static void note_text(struct sil *s, const char *text, int severity)
{
	snprintf(s->seen.text, sizeof s->seen.text, "%s", text);
	if (severity <= MAV_SEVERITY_ERROR) {
		/* the firmware's reason for a failure: its "... failed: ..." line and what it adds */
		char *f = s->seen.fail_text;
		size_t n = strlen(f);
		if (strstr(text, "failed"))
			snprintf(f, sizeof s->seen.fail_text, "%s", text);
		else if (n > 0 && n < sizeof s->seen.fail_text)
			snprintf(f + n, sizeof s->seen.fail_text - n, "; %s", text);
	}
	if (!strncmp(text, "ID", 2))
		snprintf(s->seen.id_text, sizeof s->seen.id_text, "%s", text);
	s->seen.texts++;
}

/* A STATUSTEXT: id 0 is a whole line; a nonzero id is one chunk of a long line, joined until
 * the chunk that is not full (its NUL ends the line). A chunk out of order restarts the line
 * from what arrived, marked "[...]" (the link is in-process: only a bug could cause it). */
static void note_chunk(struct sil *s, const mavlink_statustext_t *t)
{
	enum { W = MAVLINK_MSG_STATUSTEXT_FIELD_TEXT_LEN };
	char text[W + 1];
	memcpy(text, t->text, W);   /* no NUL when full */
	text[W] = 0;
	if (t->id == 0) {
		note_text(s, text, t->severity);
		return;
	}
	char *c = s->seen.chunks;
	if (t->id != s->seen.chunk_id || t->chunk_seq != s->seen.chunk_next) {
		snprintf(c, sizeof s->seen.chunks, "%s", t->chunk_seq == 0 ? "" : "[...]");
		s->seen.chunk_id = t->id;
	}
	size_t n = strlen(c);
	if (n < sizeof s->seen.chunks)
		snprintf(c + n, sizeof s->seen.chunks - n, "%s", text);
	s->seen.chunk_next = (uint8_t)(t->chunk_seq + 1u);
	if (strlen(text) < W) {
		note_text(s, c, t->severity);
		c[0] = 0;
		s->seen.chunk_id = 0;
	}
}

/* The app's MAVLink output: decoded for the mission (acks, parameter values,
 * status lines), and sent to the ground station when one is served. */
static void ground_send(void *ctx, const uint8_t *buf, size_t len)
{
	struct sil *s = ctx;
	if (s->mav_fd >= 0)
		(void)sendto(s->mav_fd, buf, len, 0, (const struct sockaddr *)&s->gcs, sizeof s->gcs);
	if (!s->mission)
		return;
	/* The app hands over one message per call: only acknowledgements, parameter
	 * values and status lines concern the mission, the telemetry is skipped by
	 * its id (MAVLink 2: 0xFD, then the id in bytes 7..9) without running the
	 * parser over it. */
	if (len >= 10 && buf[0] == MAVLINK_STX) {
		uint32_t id = (uint32_t)buf[7] | (uint32_t)buf[8] << 8 | (uint32_t)buf[9] << 16;
		if (id != MAVLINK_MSG_ID_COMMAND_ACK && id != MAVLINK_MSG_ID_PARAM_VALUE &&
		    id != MAVLINK_MSG_ID_STATUSTEXT)
			return;
	}
	mavlink_message_t msg;
	mavlink_status_t st;
	for (size_t i = 0; i < len; i++) {
		uint8_t r = mavlink_frame_char_buffer(&s->rx_msg, &s->rx_status, buf[i], &msg, &st);
		if (r == MAVLINK_FRAMING_BAD_CRC || r == MAVLINK_FRAMING_BAD_SIGNATURE)
			s->rx_status.parse_state = MAVLINK_PARSE_STATE_IDLE;   /* as mavlink_parse_char does */
		if (r != MAVLINK_FRAMING_OK)
			continue;
		if (msg.msgid == MAVLINK_MSG_ID_COMMAND_ACK) {
			mavlink_command_ack_t a;
			mavlink_msg_command_ack_decode(&msg, &a);
			if (a.command == MAV_CMD_USER_1 && a.result != MAV_RESULT_IN_PROGRESS) {
				/* a refusal, or the final answer of a running experiment */
				s->seen.exp_final = true;
				s->seen.exp_result = a.result;
			}
			if ((a.command == MAV_CMD_NAV_TAKEOFF || a.command == MAV_CMD_NAV_LAND) &&
			    a.result == MAV_RESULT_FAILED)
				s->seen.phase_failed = true;   /* the phase ran out of its time limit */
			s->seen.ack = true;
			s->seen.ack_command = a.command;
			s->seen.ack_result = a.result;
		} else if (msg.msgid == MAVLINK_MSG_ID_PARAM_VALUE) {
			mavlink_param_value_t v;
			mavlink_msg_param_value_decode(&msg, &v);
			memcpy(s->seen.param_id, v.param_id, 16);
			s->seen.param_id[16] = 0;
			s->seen.param_value = v.param_value;
			s->seen.param = true;
		} else if (msg.msgid == MAVLINK_MSG_ID_STATUSTEXT) {
			mavlink_statustext_t t;
			mavlink_msg_statustext_decode(&msg, &t);
			note_chunk(s, &t);
		}
	}
}

static bool ground_signing_key(void *ctx, uint8_t key[32])
{
	(void)ctx;
	(void)key;
	return false;
}

static int param_store(void *ctx, const char *text, size_t len)
{
	const struct sil *s = ctx;
	return param_file_store(&s->params, text, len);
}

static long param_fetch(void *ctx, char *buf, size_t cap)
{
	const struct sil *s = ctx;
	return param_file_fetch(&s->params, buf, cap);
}

static void log_frame(void *ctx, const struct app_log_frame *f)
{
	struct sil *s = ctx;
	lcm_log_frame(&s->log, f);
}

static void log_event(void *ctx, double t_s, int severity, const char *text)
{
	struct sil *s = ctx;
	lcm_log_event(&s->log, t_s, severity, text);
}

static void log_id_result(void *ctx, double t_s, const struct app_id_result *r)
{
	struct sil *s = ctx;
	lcm_log_id_result(&s->log, t_s, r);
}

/* The firmware's console: stderr, unless --quiet. */
static void report(void *ctx, const char *line)
{
	const struct sil *s = ctx;
	if (!s->quiet)
		fprintf(stderr, "octo-fw: %s\n", line);
}

static void sil_hal_bind(struct sil *s)
{
	s->hal = (struct hal){
		.ctx = s,
		.wall_us = wall_us,
		.unix_us = unix_us,
		.plant_actuate = plant_actuate,
		.plant_stats = plant_stats,
		.ground_send = ground_send,
		.ground_signing_key = ground_signing_key,
		.param_store = param_store,
		.param_fetch = param_fetch,
		.log_frame = log_frame,
		.log_event = log_event,
		.log_id_result = log_id_result,
		.report = report,
	};
}

/* The console of hal/host's parts that octo-sil links (parameter file, X-Plane
 * client): host.h declares it, host_hal.c defines it for octo-fw, this for octo-sil.
 * Their lines are errors or once-per-run notes, printed even with --quiet. */
void host_report(const char *fmt, ...)
{
	char line[256];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(line, sizeof line, fmt, ap);
	va_end(ap);
	fprintf(stderr, "octo-fw: %s\n", line);
}

/* ---------------------------------------------------------------- plant link */

static void to_plant(void *ctx, const uint8_t *buf, size_t len)
{
	struct sil_queue *q = ctx;
	if (len > 0xFFFFu || q->used + 2 + len > sizeof q->buf) {
		q->overflow++;
		return;
	}
	q->buf[q->used] = (uint8_t)(len & 0xFFu);
	q->buf[q->used + 1] = (uint8_t)(len >> 8);
	memcpy(q->buf + q->used + 2, buf, len);
	q->used += 2 + len;
}

/* The firmware's queued datagrams into the plant's decoder, in order. The
 * client's socket (--xp-listen 49005 on 127.0.0.1) is the source address. */
static void flush_to_plant(struct sil *s)
{
	size_t p = 0;
	while (p + 2 <= s->to_plant.used) {
		size_t len = (size_t)s->to_plant.buf[p] | (size_t)s->to_plant.buf[p + 1] << 8;
		octo_plant_receive(s->plant, s->to_plant.buf + p + 2, len, htonl(INADDR_LOOPBACK), 49005);
		p += 2 + len;
	}
	s->to_plant.used = 0;
}

/* The plant's datagrams through the client's decoder into the app. */
static void flush_to_fw(struct sil *s)
{
	long n;
	while ((n = octo_plant_pop(s->plant, s->from_plant, sizeof s->from_plant, NULL, NULL)) >= 0) {
		/* a longer datagram arrives cut, as from a socket; the client drops it */
		size_t len = (size_t)n > sizeof s->from_plant ? sizeof s->from_plant : (size_t)n;
		if (xp_client_input(&s->xp, s->from_plant, len, &s->xplane, &s->frame, sil_clock(s)) > 0)
			app_on_frame(&s->app, &s->frame);
	}
}

static void mavlink_in(struct sil *s)
{
	for (int k = 0; k < 64; k++) {
		uint8_t buf[2048];
		struct sockaddr_in from;
		socklen_t fl = sizeof from;
		ssize_t n = recvfrom(s->mav_fd, buf, sizeof buf, 0, (struct sockaddr *)&from, &fl);
		if (n < 0)
			break;
		if (mav_receive(&s->mav, buf, (size_t)n) > 0 && fl >= sizeof from && from.sin_family == AF_INET)
			s->gcs = from;
	}
}

/* ---------------------------------------------------------------- command line */

static const char usage[] =
	"usage: octo-sil [options]\n"
	"  octo-fw's app and octo-sim's plant in one process, lockstep, deterministic: the\n"
	"  X-Plane datagrams pass as bytes through both sides' encoders and decoders, without\n"
	"  sockets. Same flags, same bytes (LCM logs, parameter file).\n"
	"\n"
	"firmware:\n"
	"  --params FILE            parameter storage (loaded at start, saved atomically)\n"
	"  --actuation dref|data25  throttles as DREFs (default) or one DATA row 25 datagram\n"
	"  --lcm-fw URL             octo-fw's log (file://PATH: LCM log in simulated time)\n"
	"  --mavlink-listen PORT    serve MAVLink on UDP PORT to watch a run (telemetry rates\n"
	"  --gcs HOST:PORT          then in wall-clock time; ground station 127.0.0.1:14550)\n"
	"\n"
	"plant (octo-sim's flags):\n"
	"  --vehicle FILE.json  --ideal  --seed N  --rate HZ  --step S  --xplane-version 11|12\n"
	"  --rows LIST  --drop P  --burst N  --burst-prob P  --delay-frames K  --duplicate P\n"
	"  --reorder P          (see octo-sim --help)\n"
	"  --lcm-sim URL            octo-sim's truth log (OCTO_TRUTH)\n"
	"\n"
	"run:\n"
	"  --duration S             stop after S simulated seconds (0: until the mission ends\n"
	"                           or SIGINT/SIGTERM)\n"
	"  --mission FILE|TEXT      the ground station's steps, one per line or ';':\n"
	"                           param NAME VALUE, arm, takeoff H, wait hold, experiment N,\n"
	"                           wait experiment, land, wait disarmed, sleep S.\n"
	"                           Exit 0 when every step completed; 1 naming the step that\n"
	"                           failed and the firmware's reason\n"
	"  --quiet                  no firmware console messages on stderr\n"
	"  --help                   this text\n"
	"exit status: 0 done, 1 a mission step failed or did not complete, 2 bad arguments\n";

/* SIGINT or SIGTERM arrived (they are blocked and taken here, between passes,
 * so that no handler and no flag outside struct sil are needed). */
static bool stop_requested(const sigset_t *stop_set)
{
	const struct timespec no_wait = {0, 0};
	return sigtimedwait(stop_set, NULL, &no_wait) >= 0;
}

static double parse_duration(const char *v)
{
	char *e = NULL;
	double d = strtod(v, &e);
	if (!*v || *e || !(d >= 0.0) || d > 1e9) {
		fprintf(stderr, "octo-sil: --duration: expected seconds in [0, 1e9], got '%s'\n", v);
		return -1.0;
	}
	return d;
}

static int run(struct sil *s, int argc, char **argv)
{
	s->mav_fd = -1;
	const char *params = NULL, *lcm_fw = NULL, *lcm_sim = NULL, *mission_spec = NULL;
	uint16_t mav_listen = 0;
	double duration = 0.0;
	enum xp_actuation act = XP_ACT_DREF;
	if (udp_parse_hostport("octo-sil", "--gcs", "127.0.0.1:14550", &s->gcs))
		return 2;

	/* octo-sil's own flags here; the rest are the plant's */
	char **plant_argv = calloc((size_t)argc + 1, sizeof *plant_argv);
	if (!plant_argv)
		return 1;
	int plant_argc = 0;
	plant_argv[plant_argc++] = argv[0];
	for (int i = 1; i < argc; i++) {
		const char *f = argv[i];
		if (!strcmp(f, "--help") || !strcmp(f, "-h")) {
			fputs(usage, stdout);
			return 0;
		}
		if (!strcmp(f, "--quiet")) {
			s->quiet = true;
			continue;
		}
		static const char *const own[] = {"--params", "--actuation", "--lcm-fw", "--lcm-sim", "--mission",
						  "--duration", "--mavlink-listen", "--gcs"};
		bool mine = false;
		for (size_t k = 0; k < sizeof own / sizeof own[0]; k++)
			mine = mine || !strcmp(f, own[k]);
		if (!mine) {
			plant_argv[plant_argc++] = argv[i];
			continue;
		}
		if (i + 1 >= argc) {
			fprintf(stderr, "octo-sil: %s needs a value (see --help)\n", f);
			return 2;
		}
		const char *v = argv[++i];
		if (!strcmp(f, "--params"))
			params = v;
		else if (!strcmp(f, "--lcm-fw"))
			lcm_fw = v;
		else if (!strcmp(f, "--lcm-sim"))
			lcm_sim = v;
		else if (!strcmp(f, "--mission"))
			mission_spec = v;
		else if (!strcmp(f, "--duration")) {
			duration = parse_duration(v);
			if (duration < 0.0)
				return 2;
		} else if (!strcmp(f, "--mavlink-listen")) {
			if (udp_parse_port("octo-sil", f, v, &mav_listen))
				return 2;
		} else if (!strcmp(f, "--gcs")) {
			if (udp_parse_hostport("octo-sil", f, v, &s->gcs))
				return 2;
		} else if (!strcmp(f, "--actuation")) {
			if (!strcmp(v, "dref"))
				act = XP_ACT_DREF;
			else if (!strcmp(v, "data25"))
				act = XP_ACT_DATA25;
			else {
				fprintf(stderr, "octo-sil: --actuation: '%s' is not dref or data25\n", v);
				return 2;
			}
		}
	}
	int status = 0;
	s->plant = octo_plant_create("octo-sil", plant_argc, plant_argv, &status);
	free(plant_argv);
	if (!s->plant)
		return status;
	if (mission_spec) {
		s->mission = mission_parse(mission_spec);
		if (!s->mission)
			return 2;
	}
	if (!s->mission && duration <= 0.0)
		fprintf(stderr, "octo-sil: neither --mission nor --duration: running until SIGINT/SIGTERM\n");

	signal(SIGPIPE, SIG_IGN);
	sigset_t stop_set;
	sigemptyset(&stop_set);
	sigaddset(&stop_set, SIGINT);
	sigaddset(&stop_set, SIGTERM);
	sigprocmask(SIG_BLOCK, &stop_set, NULL);

	if (lcm_sim && octo_plant_open_truth(s->plant, lcm_sim))
		return 1;
	sil_hal_bind(s);
	param_file_set_path(&s->params, params);
	if (lcm_fw && lcm_log_open(&s->log, lcm_fw))
		return 1;
	if (mav_listen) {
		s->mav_fd = udp_open_ground("octo-sil", mav_listen);
		if (s->mav_fd < 0)
			return 1;
		s->wall_clock = true;
	}
	/* the plant as the client sees it: X-Plane at 127.0.0.1:49000 */
	memset(&s->xplane, 0, sizeof s->xplane);
	s->xplane.sin_family = AF_INET;
	s->xplane.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	s->xplane.sin_port = htons(49000);
	xp_client_init(&s->xp, &s->xplane, act);
	s->xp.send = to_plant;
	s->xp.send_ctx = &s->to_plant;

	const double rate = octo_plant_rate(s->plant);
	const double period_us = 1e6 / rate;
	uint64_t pass = 0;
	s->now_us = 1000000u;
	app_init(&s->app, &s->hal);
	mav_init(&s->mav, &s->app, &s->hal, hal_wall_us(&s->hal));

	bool started = false;
	int result = 0;   /* mission: 0 running, 1 done, -1 failed */
	struct octo_plant_truth tr;
	bool stop = false, crash_said = false;
	/* The signal check is a system call: every pass when a ground station sets
	 * the pace, every 64 passes (well under a wall second) otherwise. */
	const uint64_t check_every = s->wall_clock ? 1u : 64u;
	while (!(pass % check_every == 0 && (stop = stop_requested(&stop_set)))) {
		s->now_us = 1000000u + (uint64_t)((double)pass * period_us + 0.5);
		bool delivered = octo_plant_emit(s->plant, started);
		flush_to_fw(s);
		xp_client_poll(&s->xp, sil_clock(s));
		if (s->mav_fd >= 0)
			mavlink_in(s);
		app_tick(&s->app);
		mav_tick(&s->mav, hal_wall_us(&s->hal));
		if (s->mission && result == 0)
			result = mission_run(s->mission, s);
		flush_to_plant(s);
		if (result != 0)
			break;
		octo_plant_truth(s->plant, &tr);
		if (tr.crashed && !crash_said) {
			/* the plant's verdict, not the firmware's: a mission cannot go on */
			char why[200];
			snprintf(why, sizeof why,
				 "the vehicle crashed at t=%.2f s: hit the ground at %.1f m/s, %.0f deg from level", tr.crash_t,
				 tr.crash_speed, tr.crash_tilt_deg);
			crash_said = true;
			if (s->mission && result == 0) {
				result = mission_abort(s->mission, s, why);
				break;
			}
			fprintf(stderr, "octo-sil: %s\n", why);
		}
		if (duration > 0.0 && (tr.t >= duration - 1e-9 || (double)(s->now_us - 1000000u) * 1e-6 >= duration))
			break;
		pass++;
		if (!started) {
			if (!octo_plant_commanded(s->plant)) {
				/* time stands still until the first command; a watched run waits for
				 * its ground station at the real-time rate, as octo-sim does */
				if (s->wall_clock)
					(void)nanosleep(&(struct timespec){.tv_sec = 0, .tv_nsec = (long)(period_us * 1e3)},
							NULL);
				continue;
			}
			started = true;
		} else if (!delivered) {
			s->withheld++;     /* the fault injector withheld it: nobody can answer */
		} else if (!octo_plant_commanded(s->plant)) {
			s->unanswered++;   /* answered (or not) in this pass: no later answer comes */
		}
		octo_plant_advance(s->plant);
	}
	app_tick(&s->app);   /* a pending parameter save */
	mav_tick(&s->mav, hal_wall_us(&s->hal));
	lcm_log_close(&s->log);
	octo_plant_truth(s->plant, &tr);
	int rc = 0;
	if (s->mission && result < 0) {
		rc = 1;
	} else if (s->mission && result == 0) {
		fprintf(stderr, "octo-sil: mission not completed at t=%.2f s%s: %s\n", tr.t,
			stop ? " (stopped by a signal)" : " (--duration reached)", mission_pending(s->mission));
		rc = 1;
	}
	fprintf(stderr,
		"octo-sil: stopped at t=%.3f s after %llu frames (%u received by the firmware, %llu withheld by "
		"faults, %llu unanswered, %u requests lost to a full queue); plant %s\n",
		tr.t, (unsigned long long)tr.frame, s->xp.stats.frames, (unsigned long long)s->withheld,
		(unsigned long long)s->unanswered, s->to_plant.overflow, octo_plant_counters(s->plant));
	if (s->mission)
		mission_free(s->mission);
	octo_plant_destroy(s->plant);
	if (s->mav_fd >= 0)
		close(s->mav_fd);
	return rc;
}

int main(int argc, char **argv)
{
	struct sil *s = calloc(1, sizeof *s);
	if (!s) {
		fprintf(stderr, "octo-sil: out of memory\n");
		return 1;
	}
	int rc = run(s, argc, argv);
	free(s);
	return rc;
}
