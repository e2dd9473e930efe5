/*
 * stub_hal.h - a struct hal without I/O, for the app's C tests, the fuzz
 * harnesses and the step benchmark: a clock the caller advances, an optional
 * signing key, a parameter "file" in memory, and counters of what the app did
 * (actuations, bytes sent, log frames, events, reports). Portable C11 (also
 * built for Cortex-M under QEMU).
 */
#ifndef OCTO_STUB_HAL_H
#define OCTO_STUB_HAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "hal.h"
#include "id_result.h"

#define STUB_STORE_CAP 8192
#define STUB_IDS 32

struct stub_hal {
	struct hal hal;        /* hand &s->hal to app_init */
	uint64_t now_us;       /* monotonic clock; the caller advances it */
	uint64_t unix_base_us; /* unix_us = unix_base_us + now_us */
	bool have_key;
	uint8_t key[32];
	struct hal_plant_stats plant; /* returned by plant_stats */

	float thr[HAL_ROTORS]; /* the last actuation */
	uint32_t n_actuate;
	size_t sent_bytes; /* ground link: bytes and datagrams sent */
	uint32_t sent_datagrams;
	uint8_t sent_sum; /* every sent byte is read (sanitizers see overreads) */
	bool store_fails; /* param_store refuses (a full disk) */
	char store[STUB_STORE_CAP];
	long store_len; /* -1: nothing stored */
	uint32_t n_stores;
	uint32_t n_log_frames, n_events, n_reports;
	int last_severity; /* of the last event */
	char last_event[128];
	char last_report[256];
	uint32_t n_id_results; /* identification results logged; the first STUB_IDS kept */
	struct app_id_result id_results[STUB_IDS];
};

/* Zeroes *s, sets the clock to 1 s and binds s->hal to the stub functions. */
void stub_hal_init(struct stub_hal *s);

#endif /* OCTO_STUB_HAL_H */
