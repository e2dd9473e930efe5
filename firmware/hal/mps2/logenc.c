/*
 * logenc.c - the firmware log's records as the log link carries them: LCM's encoding
 * (big-endian, fields in order, boolean as one byte) of octo.fw_frame_t and
 * octo.fw_id_result_t without the 8-byte type fingerprint, which the host bridge adds
 * before it writes the event into the LCM log. The fields of the frame record come from
 * the one table of log.h, whose order is fw_frame_t's (tests/py/test_contracts.py).
 */
#include <string.h>

#include "board.h"
#include "log.h"

struct enc {
	uint8_t *p;
	size_t n, cap;
};

static void put_be(struct enc *e, uint64_t v, size_t bytes)
{
	if (e->n + bytes > e->cap) {
		e->n = e->cap + 1; /* too long: the caller sees it */
		return;
	}
	for (size_t i = 0; i < bytes; i++)
		e->p[e->n + i] = (uint8_t)(v >> (8 * (bytes - 1 - i)));
	e->n += bytes;
}

static void put_i64(struct enc *e, int64_t v) { put_be(e, (uint64_t)v, 8); }
static void put_i32(struct enc *e, int32_t v) { put_be(e, (uint32_t)v, 4); }
static void put_i16(struct enc *e, int16_t v) { put_be(e, (uint16_t)v, 2); }
static void put_i8(struct enc *e, int8_t v) { put_be(e, (uint8_t)v, 1); }
static void put_bool(struct enc *e, bool v) { put_be(e, v ? 1u : 0u, 1); }
static void put_f32(struct enc *e, float v)
{
	uint32_t u;
	memcpy(&u, &v, sizeof u);
	put_be(e, u, 4);
}
static void put_f64(struct enc *e, double v)
{
	uint64_t u;
	memcpy(&u, &v, sizeof u);
	put_be(e, u, 8);
}

#define PUT(e, v)                 \
	_Generic((v),             \
		int64_t: put_i64, \
		double: put_f64,  \
		float: put_f32,   \
		bool: put_bool,   \
		int8_t: put_i8,   \
		int16_t: put_i16, \
		int32_t: put_i32)(e, v)

/* plant time in microseconds, rounded as the host's log does */
static int64_t utime_of(double t_s) { return (int64_t)(t_s * 1e6 + (t_s >= 0 ? 0.5 : -0.5)); }

static size_t done(const struct enc *e) { return e->n <= e->cap ? e->n : 0; }

size_t board_enc_frame(uint8_t *buf, size_t cap, const struct app_log_frame *f)
{
	struct enc e = {buf, 0, cap};
	put_i64(&e, utime_of(f->t));
#define ONE(c_type, lcm_type, name) PUT(&e, f->name);
#define ARR(c_type, lcm_type, name, count)      \
	for (size_t i_ = 0; i_ < (count); i_++) \
		PUT(&e, f->name[i_]);
	APP_LOG_FIELDS(ONE, ARR)
#undef ONE
#undef ARR
	return done(&e);
}

size_t board_enc_event(uint8_t *buf, size_t cap, double t_s, int severity, const char *text)
{
	struct enc e = {buf, 0, cap};
	put_i64(&e, utime_of(t_s));
	put_i8(&e, (int8_t)severity);
	size_t n = strlen(text);
	if (e.n + n <= cap) {
		memcpy(buf + e.n, text, n);
		e.n += n;
	} else {
		e.n = cap + 1;
	}
	return done(&e);
}

size_t board_enc_id(uint8_t *buf, size_t cap, double t_s, const struct app_id_result *r)
{
	struct enc e = {buf, 0, cap};
	put_i64(&e, utime_of(t_s));
	put_i16(&e, (int16_t)r->run_id);
	put_i8(&e, (int8_t)r->index);
	put_i8(&e, (int8_t)r->count);
	put_i8(&e, (int8_t)r->run_done);
	put_i8(&e, (int8_t)r->experiment);
	put_i8(&e, (int8_t)r->param);
	put_i8(&e, (int8_t)r->rotor);
	put_f32(&e, r->value);
	put_f32(&e, r->sd);
	put_i8(&e, (int8_t)r->accepted);
	put_i16(&e, (int16_t)r->reason);
	put_i8(&e, (int8_t)r->source);
	return done(&e);
}
