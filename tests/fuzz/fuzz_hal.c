/*
 * fuzz_hal.c - hal.h for the firmware fuzz harnesses: no I/O, a fake clock the
 * harness advances, an optional signing key, and a parameter "file" in memory.
 */
#include "fuzz_hal.h"

#include <stdarg.h>
#include <string.h>

uint64_t fuzz_now_us = 1000000u;
bool fuzz_have_key;
uint8_t fuzz_key[32];
size_t fuzz_sent_bytes;
static char store[8192];
static long store_len = -1;

uint64_t hal_wall_us(void) { return fuzz_now_us; }
uint64_t hal_unix_us(void) { return 1700000000ull * 1000000ull + fuzz_now_us; }

void hal_actuate(const float thr[HAL_ROTORS]) { (void)thr; }

void hal_link_stats(struct hal_link_stats *out)
{
	memset(out, 0, sizeof *out);
	out->xp_version = 120100u;
}

void hal_mav_send(const uint8_t *buf, size_t len)
{
	/* touch every byte so that ASan sees an overread of a send buffer */
	volatile uint8_t sink = 0;
	for (size_t i = 0; i < len; i++)
		sink ^= buf[i];
	(void)sink;
	fuzz_sent_bytes += len;
}

bool hal_signing_key(uint8_t key[32])
{
	if (fuzz_have_key)
		memcpy(key, fuzz_key, 32);
	return fuzz_have_key;
}

int hal_param_store(const char *text, size_t len)
{
	if (len >= sizeof store)
		return -1;
	memcpy(store, text, len);
	store[len] = 0;
	store_len = (long)len;
	return 0;
}

long hal_param_fetch(char *buf, size_t cap)
{
	if (store_len < 0 || cap == 0)
		return -1;
	size_t n = (size_t)store_len < cap - 1 ? (size_t)store_len : cap - 1;
	memcpy(buf, store, n);
	buf[n] = 0;
	return (long)n;
}

void fuzz_hal_reset(void)
{
	store_len = -1;
	fuzz_sent_bytes = 0;
}

void hal_log_frame(const struct app_log_frame *f) { (void)f; }

void hal_log_event(double t_s, int severity, const char *text)
{
	(void)t_s;
	(void)severity;
	(void)strlen(text);
}

void hal_report(const char *fmt, ...)
{
	char text[256];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(text, sizeof text, fmt, ap);
	va_end(ap);
}
