/*
 * xp_proto.h - X-Plane 11/12 native UDP protocol: octo-fw's own encoder/decoder.
 *
 * Byte layouts: docs/xplane-protocol.md (little-endian, one message per
 * datagram, 4-letter type + 1 byte that receivers ignore). Pure functions: no
 * sockets, no state; every decoder checks lengths before reading a byte.
 */
#ifndef OCTO_XP_PROTO_H
#define OCTO_XP_PROTO_H

#include <stddef.h>
#include <stdint.h>

#define XP_DATA_REC_LEN 36 /* int32 row + 8 float32 */
#define XP_DREF_LEN 509
#define XP_RREF_REQ_LEN 413
#define XP_MAX_DATA_RECS 64 /* more records than this: datagram rejected */
#define XP_MAX_RREF_RECS 183
#define XP_LEAVE_ALONE (-999.0f)

struct xp_data_rec {
	int32_t row;
	float col[8]; /* col[0] is X-Plane's column 1 */
};

struct xp_rref_rec {
	int32_t index;
	float value;
};

enum xp_msg { XP_MSG_BAD = 0, XP_MSG_DATA, XP_MSG_RREF, XP_MSG_OTHER };

/* Decoded datagram. */
struct xp_msg_in {
	enum xp_msg type;
	size_t n; /* records */
	struct xp_data_rec data[XP_MAX_DATA_RECS];
	struct xp_rref_rec rref[XP_MAX_RREF_RECS];
};

/* Classifies and decodes one datagram. DATA and RREF replies are decoded; any
 * other well-formed 4-letter message is XP_MSG_OTHER; a wrong length, an empty
 * record list or too many records is XP_MSG_BAD. */
enum xp_msg xp_decode(const uint8_t *buf, size_t len, struct xp_msg_in *out);

/* Encoders: return the datagram length, or 0 if cap is too small or an argument
 * is out of range. Byte 4 is 0x00 (Laminar's documentation). */
size_t xp_encode_dsel(uint8_t *buf, size_t cap, int unselect, const int32_t *rows, size_t n);
size_t xp_encode_rref(uint8_t *buf, size_t cap, int32_t freq_hz, int32_t index, const char *path);
size_t xp_encode_dref(uint8_t *buf, size_t cap, float value, const char *path);
/* The value of a DREF encoded by xp_encode_dref, rewritten in place (its path stays). */
void xp_dref_set_value(uint8_t *dref, float value);
size_t xp_encode_data(uint8_t *buf, size_t cap, const struct xp_data_rec *recs, size_t n);

#endif /* OCTO_XP_PROTO_H */
