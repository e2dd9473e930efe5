/* host_hal.c - the struct hal of the host platform: clocks, the two UDP links,
 * the parameter file, the LCM log and stderr, all on one struct host. */
#include "host.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>

static uint64_t clock_us(clockid_t id)
{
	struct timespec ts;
	clock_gettime(id, &ts);
	return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static uint64_t wall_us(void *ctx)
{
	(void)ctx;
	return clock_us(CLOCK_MONOTONIC);
}

static uint64_t unix_us(void *ctx)
{
	(void)ctx;
	return clock_us(CLOCK_REALTIME);
}

static void plant_actuate(void *ctx, const float thr[HAL_ROTORS])
{
	struct host *h = ctx;
	xp_client_actuate(&h->xp, thr, clock_us(CLOCK_MONOTONIC));
}

static void plant_stats(void *ctx, struct hal_plant_stats *out)
{
	const struct host *h = ctx;
	*out = h->xp.stats;
}

static void ground_send(void *ctx, const uint8_t *buf, size_t len)
{
	const struct host *h = ctx;
	if (h->mav_fd >= 0)
		(void)sendto(h->mav_fd, buf, len, 0, (const struct sockaddr *)&h->gcs, sizeof h->gcs);
}

static bool ground_signing_key(void *ctx, uint8_t key[32])
{
	const struct host *h = ctx;
	if (h->have_key)
		memcpy(key, h->signing_key, sizeof h->signing_key);
	return h->have_key;
}

static int param_store(void *ctx, const char *text, size_t len)
{
	const struct host *h = ctx;
	return param_file_store(&h->params, text, len);
}

static long param_fetch(void *ctx, char *buf, size_t cap)
{
	const struct host *h = ctx;
	return param_file_fetch(&h->params, buf, cap);
}

static void log_frame(void *ctx, const struct app_log_frame *f)
{
	struct host *h = ctx;
	lcm_log_frame(&h->log, f);
}

static void log_id_result(void *ctx, double t_s, const struct app_id_result *r)
{
	struct host *h = ctx;
	lcm_log_id_result(&h->log, t_s, r);
}

static void log_event(void *ctx, double t_s, int severity, const char *text)
{
	struct host *h = ctx;
	lcm_log_event(&h->log, t_s, severity, text);
}

static void report(void *ctx, const char *line)
{
	(void)ctx;
	fprintf(stderr, "octo-fw: %s\n", line);
}

void host_report(const char *fmt, ...)
{
	char line[256];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(line, sizeof line, fmt, ap);
	va_end(ap);
	report(NULL, line);
}

void host_hal_bind(struct host *h)
{
	h->hal = (struct hal){
		.ctx = h,
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
