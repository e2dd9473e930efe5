/*
 * sil.c - octo-sil: the lockstep loop and the struct hal of the in-process platform
 * (see sil.h; the command line is cmdline.c, the ground station's steps script.c).
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
#include "script.h"

/* ---------------------------------------------------------------- struct hal */

static uint64_t mono_us(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* The platform clock: virtual (one frame period per pass) unless a ground
 * station is served. */
static uint64_t sil_clock(const struct sil *s) { return s->wall_clock ? mono_us() : s->now_us; }

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

/* The app's MAVLink output: to the ground station when one is served, and to the
 * script (acknowledgements, parameter values, status lines). */
static void ground_send(void *ctx, const uint8_t *buf, size_t len)
{
	struct sil *s = ctx;
	if (s->mav_fd >= 0)
		(void)sendto(s->mav_fd, buf, len, 0, (const struct sockaddr *)&s->gcs, sizeof s->gcs);
	if (s->script)
		script_on_vehicle(s->script, buf, len);
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

/* ---------------------------------------------------------------- the run */

/* SIGINT or SIGTERM arrived (they are blocked and taken here, between passes,
 * so that no handler and no flag outside struct sil are needed). */
static bool stop_requested(const sigset_t *stop_set)
{
	const struct timespec no_wait = {0, 0};
	return sigtimedwait(stop_set, NULL, &no_wait) >= 0;
}

/* The plant, the script, the signals to stop on (*stop_set), the logs, the ground link and
 * the client, from the command line; the app started. Returns -1 to fly, or the exit status. */
static int start(struct sil *s, const struct sil_config *cfg, sigset_t *stop_set)
{
	int status = 0;
	s->plant = octo_plant_create("octo-sil", cfg->plant_argc, cfg->plant_argv, &status);
	if (!s->plant)
		return status;
	if (cfg->script) {
		s->script = script_parse(cfg->script, cfg->quiet);
		if (!s->script)
			return 2;
	}
	if (!s->script && cfg->duration <= 0.0)
		fprintf(stderr, "octo-sil: neither --script nor --duration: running until SIGINT/SIGTERM\n");

	signal(SIGPIPE, SIG_IGN);
	sigemptyset(stop_set);
	sigaddset(stop_set, SIGINT);
	sigaddset(stop_set, SIGTERM);
	sigprocmask(SIG_BLOCK, stop_set, NULL);

	if (cfg->lcm_sim && octo_plant_open_truth(s->plant, cfg->lcm_sim))
		return 1;
	sil_hal_bind(s);
	param_file_set_path(&s->params, cfg->params);
	if (cfg->lcm_fw && lcm_log_open(&s->log, cfg->lcm_fw))
		return 1;
	lcm_log_thin(&s->log, cfg->log_every, cfg->log_phases);
	if (cfg->mav_listen) {
		s->mav_fd = udp_open_ground("octo-sil", cfg->mav_listen);
		if (s->mav_fd < 0)
			return 1;
		s->wall_clock = true;
	}
	/* the plant as the client sees it: X-Plane at 127.0.0.1:49000 */
	memset(&s->xplane, 0, sizeof s->xplane);
	s->xplane.sin_family = AF_INET;
	s->xplane.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	s->xplane.sin_port = htons(49000);
	xp_client_init(&s->xp, &s->xplane, cfg->act);
	s->xp.send = to_plant;
	s->xp.send_ctx = &s->to_plant;
	/* the configured rate: the plant's frame period (the stamps are not needed to measure it) */
	xp_clock_set_period(&s->xp.clock, 1.0 / octo_plant_rate(s->plant));

	s->now_us = 1000000u;
	app_init(&s->app, &s->hal);
	mav_init(&s->mav, &s->app, &s->hal, hal_wall_us(&s->hal));
	return -1;
}

/* One frame's exchange at platform time now_us: the plant's frame into the app, the app's
 * step, the script's current step, the app's answer into the plant. *delivered: the plant's
 * frame left its fault injector. Returns the script's result (0 running, 1 done, -1 failed). */
static int exchange(struct sil *s, bool started, int result, bool *delivered)
{
	*delivered = octo_plant_emit(s->plant, started);
	flush_to_fw(s);
	xp_client_poll(&s->xp, sil_clock(s));
	if (s->mav_fd >= 0)
		mavlink_in(s);
	app_tick(&s->app);
	mav_tick(&s->mav, hal_wall_us(&s->hal));
	if (s->script && result == 0)
		result = script_run(s->script, &s->app, &s->mav, s->now_us);
	flush_to_plant(s);
	return result;
}

/* The plant's crash verdict, said once: it fails the script's current step (-1), or is
 * reported when no script runs. Returns the script's result. */
static int crash_check(struct sil *s, const struct octo_plant_truth *tr, bool *crash_said, int result)
{
	if (!tr->crashed || *crash_said)
		return result;
	/* the plant's verdict, not the firmware's: a script cannot go on */
	char why[200];
	snprintf(why, sizeof why, "the vehicle crashed at t=%.2f s: hit the ground at %.1f m/s, %.0f deg from level",
		 tr->crash_t, tr->crash_speed, tr->crash_tilt_deg);
	*crash_said = true;
	if (s->script && result == 0)
		return script_abort(s->script, &s->app, &s->mav, why);
	fprintf(stderr, "octo-sil: %s\n", why);
	return result;
}

/* After a pass: whether the plant advances. Until the first command time stands still (a
 * watched run waits for its ground station at the real-time rate, as octo-sim does); then
 * frames the faults withheld or the firmware did not answer are counted. */
static bool may_advance(struct sil *s, bool *started, bool delivered, double period_us)
{
	if (!*started) {
		if (!octo_plant_commanded(s->plant)) {
			if (s->wall_clock)
				(void)nanosleep(&(struct timespec){.tv_sec = 0, .tv_nsec = (long)(period_us * 1e3)},
						NULL);
			return false;
		}
		*started = true;
	} else if (!delivered) {
		s->withheld++; /* the fault injector withheld it: nobody can answer */
	} else if (!octo_plant_commanded(s->plant)) {
		s->unanswered++; /* answered (or not) in this pass: no later answer comes */
	}
	return true;
}

/* The lockstep loop: one pass per frame until the script ends, --duration is reached or a
 * signal arrives (*stopped). Returns the script's result (0 when it did not end). */
static int fly(struct sil *s, double duration, const sigset_t *stop_set, bool *stopped)
{
	const double rate = octo_plant_rate(s->plant);
	const double period_us = 1e6 / rate;
	uint64_t pass = 0;
	bool started = false, crash_said = false;
	int result = 0; /* script: 0 running, 1 done, -1 failed */
	struct octo_plant_truth tr;
	/* The signal check is a system call: every pass when a ground station sets
	 * the pace, every 64 passes (well under a wall second) otherwise. */
	const uint64_t check_every = s->wall_clock ? 1u : 64u;
	while (!(pass % check_every == 0 && (*stopped = stop_requested(stop_set)))) {
		s->now_us = 1000000u + (uint64_t)((double)pass * period_us + 0.5);
		bool delivered;
		result = exchange(s, started, result, &delivered);
		if (result != 0)
			break;
		octo_plant_truth(s->plant, &tr);
		result = crash_check(s, &tr, &crash_said, result);
		if (result != 0)
			break;
		if (duration > 0.0 &&
		    (tr.t - tr.t0 >= duration - 1e-9 || (double)(s->now_us - 1000000u) * 1e-6 >= duration))
			break;
		pass++;
		if (may_advance(s, &started, delivered, period_us))
			octo_plant_advance(s->plant);
	}
	return result;
}

/* The last parameter save, the logs closed, the closing lines; everything freed. Returns
 * the exit status: 1 when a script step failed or did not complete. */
static int finish(struct sil *s, int result, bool stopped)
{
	struct octo_plant_truth tr;
	app_tick(&s->app); /* a pending parameter save */
	mav_tick(&s->mav, hal_wall_us(&s->hal));
	lcm_log_close(&s->log);
	octo_plant_truth(s->plant, &tr);
	int rc = 0;
	if (s->script && result < 0) {
		rc = 1;
	} else if (s->script && result == 0) {
		fprintf(stderr, "octo-sil: script not completed at t=%.2f s%s: %s\n", tr.t,
			stopped ? " (stopped by a signal)" : " (--duration reached)", script_pending(s->script));
		rc = 1;
	}
	fprintf(stderr,
		"octo-sil: stopped at t=%.3f s after %llu frames (%u received by the firmware, %llu withheld by "
		"faults, %llu unanswered, %u requests lost to a full queue); plant %s\n",
		tr.t, (unsigned long long)tr.frame, s->xp.stats.frames, (unsigned long long)s->withheld,
		(unsigned long long)s->unanswered, s->to_plant.overflow, octo_plant_counters(s->plant));
	if (s->script)
		script_free(s->script);
	octo_plant_destroy(s->plant);
	if (s->mav_fd >= 0)
		close(s->mav_fd);
	return rc;
}

static int run(struct sil *s, int argc, char **argv)
{
	s->mav_fd = -1;
	struct sil_config cfg;
	int rc = sil_parse_args(argc, argv, &cfg);
	if (rc >= 0)
		return rc;
	s->quiet = cfg.quiet;
	s->gcs = cfg.gcs;

	sigset_t stop_set;
	rc = start(s, &cfg, &stop_set);
	free(cfg.plant_argv);
	if (rc >= 0)
		return rc;
	bool stopped = false;
	int result = fly(s, cfg.duration, &stop_set, &stopped);
	return finish(s, result, stopped);
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
