/* stub_hal.c - the struct hal of the tests (see stub_hal.h). */
#include "stub_hal.h"

#include <string.h>

static void copy_text(char *dst, size_t cap, const char *src)
{
	size_t n = strlen(src);
	if (n >= cap)
		n = cap - 1;
	memcpy(dst, src, n);
	dst[n] = 0;
}

static uint64_t wall_us(void *ctx)
{
	const struct stub_hal *s = ctx;
	return s->now_us;
}

static uint64_t unix_us(void *ctx)
{
	const struct stub_hal *s = ctx;
	return s->unix_base_us + s->now_us;
}

static void plant_actuate(void *ctx, const float thr[HAL_ROTORS])
{
	struct stub_hal *s = ctx;
	memcpy(s->thr, thr, sizeof s->thr);
	s->n_actuate++;
}

static void plant_stats(void *ctx, struct hal_plant_stats *out)
{
	const struct stub_hal *s = ctx;
	*out = s->plant;
}

static void ground_send(void *ctx, const uint8_t *buf, size_t len)
{
	struct stub_hal *s = ctx;
	/* Every byte is read: eight at a time, then the last 8 to 15 one by one, so that an
	 * overread past the end is a byte read of its own. The XOR of the words, folded, is the
	 * XOR of the bytes. */
	uint64_t x = 0;
	size_t i = 0;
	for (; i + 16 <= len; i += 8) {
		uint64_t w;
		memcpy(&w, buf + i, sizeof w);
		x ^= w;
	}
	for (; i < len; i++)
		x ^= buf[i];
	x ^= x >> 32;
	x ^= x >> 16;
	x ^= x >> 8;
	s->sent_sum ^= (uint8_t)x;
	s->sent_bytes += len;
	s->sent_datagrams++;
}

static bool ground_signing_key(void *ctx, uint8_t key[32])
{
	const struct stub_hal *s = ctx;
	if (s->have_key)
		memcpy(key, s->key, sizeof s->key);
	return s->have_key;
}

static int param_store(void *ctx, const char *text, size_t len)
{
	struct stub_hal *s = ctx;
	if (s->store_fails || hal_ram_param_put(s->store, sizeof s->store, &s->store_len, text, len) < 0)
		return -1;
	s->n_stores++;
	return 0;
}

static long param_fetch(void *ctx, char *buf, size_t cap)
{
	const struct stub_hal *s = ctx;
	return hal_ram_param_get(s->store, s->store_len, buf, cap);
}

static void log_frame(void *ctx, const struct app_log_frame *f)
{
	struct stub_hal *s = ctx;
	(void)f;
	s->n_log_frames++;
}

static void log_event(void *ctx, double t_s, int severity, const char *text)
{
	struct stub_hal *s = ctx;
	(void)t_s;
	s->n_events++;
	s->last_severity = severity;
	copy_text(s->last_event, sizeof s->last_event, text);
}

static void log_id_result(void *ctx, double t_s, const struct app_id_result *r)
{
	struct stub_hal *s = ctx;
	(void)t_s;
	if (s->n_id_results < STUB_IDS)
		s->id_results[s->n_id_results] = *r;
	s->n_id_results++;
}

static void report(void *ctx, const char *line)
{
	struct stub_hal *s = ctx;
	s->n_reports++;
	copy_text(s->last_report, sizeof s->last_report, line);
}

void stub_hal_init(struct stub_hal *s)
{
	memset(s, 0, sizeof *s);
	s->now_us = 1000000u;
	s->unix_base_us = 1700000000ull * 1000000ull;
	s->store_len = -1;
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
