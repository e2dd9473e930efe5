/* xp_proto.c - X-Plane UDP codec (see xp_proto.h). */
#include "xp_proto.h"

#include <string.h>

static void put_i32(uint8_t *p, int32_t v)
{
	uint32_t u = (uint32_t)v;
	p[0] = (uint8_t)u;
	p[1] = (uint8_t)(u >> 8);
	p[2] = (uint8_t)(u >> 16);
	p[3] = (uint8_t)(u >> 24);
}

static void put_f32(uint8_t *p, float v)
{
	uint32_t u;
	memcpy(&u, &v, 4);
	put_i32(p, (int32_t)u);
}

static int32_t get_i32(const uint8_t *p)
{
	uint32_t u = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
	return (int32_t)u;
}

static float get_f32(const uint8_t *p)
{
	uint32_t u = (uint32_t)get_i32(p);
	float v;
	memcpy(&v, &u, 4);
	return v;
}

static void put_head(uint8_t *buf, const char *tag)
{
	memcpy(buf, tag, 4);
	buf[4] = 0;
}

enum xp_msg xp_decode(const uint8_t *buf, size_t len, struct xp_msg_in *out)
{
	out->type = XP_MSG_BAD;
	out->n = 0;
	if (!buf || len < 5)
		return XP_MSG_BAD;
	for (int i = 0; i < 4; i++)
		if (buf[i] < 'A' || buf[i] > 'Z')
			return XP_MSG_BAD;
	size_t body = len - 5;
	if (!memcmp(buf, "DATA", 4)) {
		if (body == 0 || body % XP_DATA_REC_LEN || body / XP_DATA_REC_LEN > XP_MAX_DATA_RECS)
			return XP_MSG_BAD;
		out->n = body / XP_DATA_REC_LEN;
		for (size_t r = 0; r < out->n; r++) {
			const uint8_t *p = buf + 5 + r * XP_DATA_REC_LEN;
			out->data[r].row = get_i32(p);
			for (int c = 0; c < 8; c++)
				out->data[r].col[c] = get_f32(p + 4 + 4 * c);
		}
		out->type = XP_MSG_DATA;
	} else if (!memcmp(buf, "RREF", 4)) {
		if (body == 0 || body % 8 || body / 8 > XP_MAX_RREF_RECS)
			return XP_MSG_BAD;
		out->n = body / 8;
		for (size_t r = 0; r < out->n; r++) {
			out->rref[r].index = get_i32(buf + 5 + 8 * r);
			out->rref[r].value = get_f32(buf + 9 + 8 * r);
		}
		out->type = XP_MSG_RREF;
	} else {
		out->type = XP_MSG_OTHER;
	}
	return out->type;
}

size_t xp_encode_dsel(uint8_t *buf, size_t cap, int unselect, const int32_t *rows, size_t n)
{
	size_t len = 5 + 4 * n;
	if (n == 0 || cap < len)
		return 0;
	put_head(buf, unselect ? "USEL" : "DSEL");
	for (size_t i = 0; i < n; i++)
		put_i32(buf + 5 + 4 * i, rows[i]);
	return len;
}

/* path into a zero-filled field of `field` bytes; it must leave room for the NUL */
static int put_path(uint8_t *dst, size_t field, const char *path)
{
	size_t n = strlen(path);
	if (n == 0 || n >= field)
		return -1;
	memcpy(dst, path, n);
	memset(dst + n, 0, field - n); /* the NUL and the padding after the path */
	return 0;
}

size_t xp_encode_rref(uint8_t *buf, size_t cap, int32_t freq_hz, int32_t index, const char *path)
{
	if (cap < XP_RREF_REQ_LEN || freq_hz < 0)
		return 0;
	put_head(buf, "RREF");
	put_i32(buf + 5, freq_hz);
	put_i32(buf + 9, index);
	if (put_path(buf + 13, 400, path))
		return 0;
	return XP_RREF_REQ_LEN;
}

size_t xp_encode_dref(uint8_t *buf, size_t cap, float value, const char *path)
{
	if (cap < XP_DREF_LEN)
		return 0;
	put_head(buf, "DREF");
	put_f32(buf + 5, value);
	if (put_path(buf + 9, 500, path))
		return 0;
	return XP_DREF_LEN;
}

void xp_dref_set_value(uint8_t *dref, float value) { put_f32(dref + 5, value); }

size_t xp_encode_data(uint8_t *buf, size_t cap, const struct xp_data_rec *recs, size_t n)
{
	size_t len = 5 + XP_DATA_REC_LEN * n;
	if (n == 0 || cap < len)
		return 0;
	put_head(buf, "DATA");
	for (size_t r = 0; r < n; r++) {
		uint8_t *p = buf + 5 + r * XP_DATA_REC_LEN;
		put_i32(p, recs[r].row);
		for (int c = 0; c < 8; c++)
			put_f32(p + 4 + 4 * c, recs[r].col[c]);
	}
	return len;
}
