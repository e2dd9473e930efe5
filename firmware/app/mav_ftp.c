/* mav_ftp.c - component metadata and the read-only MAVLink FTP server (see mav_ftp.h). */
#include "mav_ftp.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include <octo/mavlink.h>

#include "params.h"

/* MAVLink FTP payload layout and codes (MAVLink's FTP protocol) */
enum { P_SEQ = 0, P_SESSION = 2, P_OPCODE = 3, P_SIZE = 4, P_REQ_OPCODE = 5, P_BURST_COMPLETE = 6,
       P_OFFSET = 8, P_DATA = 12 };
#define FTP_DATA_MAX 239
enum { OP_TERMINATE = 1, OP_RESET = 2, OP_OPEN_RO = 4, OP_READ = 5, OP_CRC32 = 14, OP_BURST_READ = 15,
       OP_ACK = 128, OP_NAK = 129 };
enum { ERR_FAIL = 1, ERR_INVALID_SESSION = 4, ERR_EOF = 6, ERR_UNKNOWN_COMMAND = 7, ERR_FILE_NOT_FOUND = 10 };

#define GENERAL_PATH "octo/general.json"
#define PARAM_PATH "octo/param.json"
#define URI_PREFIX "mftp://"


/* CRC-32 (IEEE 802.3, as zlib computes it) */
static uint32_t crc32_of(const void *data, size_t n)
{
	const uint8_t *p = data;
	uint32_t c = 0xFFFFFFFFu;
	for (size_t i = 0; i < n; i++) {
		c ^= p[i];
		for (int k = 0; k < 8; k++)
			c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
	}
	return ~c;
}

struct out {
	char *buf;
	size_t cap, len;
	bool full;
};

static void put(struct out *o, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(struct out *o, const char *fmt, ...)
{
	if (o->full)
		return;
	va_list ap;
	va_start(ap, fmt);
	int n = vsnprintf(o->buf + o->len, o->cap - o->len, fmt, ap);
	va_end(ap);
	if (n < 0 || (size_t)n >= o->cap - o->len) {
		o->full = true;
		return;
	}
	o->len += (size_t)n;
}

static void put_str(struct out *o, const char *s)
{
	put(o, "\"");
	for (; *s; s++) {
		unsigned char c = (unsigned char)*s;
		if (c == '"' || c == '\\')
			put(o, "\\%c", c);
		else if (c < 0x20)
			put(o, "\\u%04x", c);
		else
			put(o, "%c", c);
	}
	put(o, "\"");
}

bool mav_ftp_init(struct mav_ftp *f)
{
	memset(f, 0, sizeof *f);
	struct out p = {f->param_json, sizeof f->param_json, 0, false};
	put(&p, "{\"version\": 1, \"parameters\": [");
	for (size_t i = 0; i < param_count; i++) {
		const struct param_def *d = &param_defs[i];
		char def[32], min[32], max[32], group[PARAM_ID_LEN + 1];
		params_fmt_float(def, sizeof def, d->def);
		params_fmt_float(min, sizeof min, d->min);
		params_fmt_float(max, sizeof max, d->max);
		/* the group is the name's prefix, as in VEH_KF -> VEH */
		size_t g = strcspn(d->name, "_");
		if (g > PARAM_ID_LEN)
			g = PARAM_ID_LEN;
		memcpy(group, d->name, g);
		group[g] = 0;
		put(&p, "%s\n{\"name\": ", i ? "," : "");
		put_str(&p, d->name);
		put(&p, ", \"type\": \"Float\", \"shortDesc\": ");
		put_str(&p, d->desc);
		put(&p, ", \"units\": ");
		put_str(&p, d->unit);
		put(&p, ", \"default\": %s, \"min\": %s, \"max\": %s, \"group\": ", def, min, max);
		put_str(&p, group);
		put(&p, "}");
	}
	put(&p, "\n]}\n");
	f->param_len = p.full ? 0 : (uint32_t)p.len;
	f->param_crc = crc32_of(f->param_json, f->param_len);

	struct out g = {f->general, sizeof f->general, 0, false};
	put(&g, "{\"version\": 1, \"vendorName\": \"Octo-SIL\", \"modelName\": \"octo-fw\", "
		"\"metadataTypes\": [{\"type\": %d, \"uri\": \"" URI_PREFIX PARAM_PATH "\", \"fileCrc\": %lu}]}\n",
	    COMP_METADATA_TYPE_PARAMETER, (unsigned long)f->param_crc);
	f->general_len = g.full || p.full ? 0 : (uint32_t)g.len;
	f->general_crc = crc32_of(f->general, f->general_len);
	f->session_open = false;
	f->session_file = -1;
	return f->general_len > 0;
}

const char *mav_ftp_file(const struct mav_ftp *f, const char *path, uint32_t *len, uint32_t *crc)
{
	while (*path == '/')
		path++;
	if (!strcmp(path, GENERAL_PATH) && f->general_len) {
		*len = f->general_len;
		*crc = f->general_crc;
		return f->general;
	}
	if (!strcmp(path, PARAM_PATH) && f->param_len) {
		*len = f->param_len;
		*crc = f->param_crc;
		return f->param_json;
	}
	return NULL;
}

static uint32_t get32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void set32(uint8_t *p, uint32_t v)
{
	for (int k = 0; k < 4; k++)
		p[k] = (uint8_t)(v >> (8 * k));
}

static void reply(const struct mav_ftp_link *l, const uint8_t *req, uint16_t seq, uint8_t *rsp,
		  mav_ftp_send_fn send)
{
	rsp[P_SEQ] = (uint8_t)seq;
	rsp[P_SEQ + 1] = (uint8_t)(seq >> 8);
	rsp[P_SESSION] = req[P_SESSION];
	rsp[P_REQ_OPCODE] = req[P_OPCODE];
	mavlink_message_t msg;
	mavlink_msg_file_transfer_protocol_pack_chan(l->sysid, l->compid, l->chan, &msg, 0, l->to_sysid,
						     l->to_compid, rsp);
	send(l->ctx, &msg);
}

static void nak(const struct mav_ftp_link *l, const uint8_t *req, uint16_t seq, uint8_t err,
		mav_ftp_send_fn send)
{
	uint8_t rsp[MAVLINK_MSG_FILE_TRANSFER_PROTOCOL_FIELD_PAYLOAD_LEN];
	memset(rsp, 0, sizeof rsp);
	rsp[P_OPCODE] = OP_NAK;
	rsp[P_SIZE] = 1;
	rsp[P_DATA] = err;
	reply(l, req, seq, rsp, send);
}

static const char *session_data(const struct mav_ftp *f, uint32_t *len)
{
	uint32_t crc;
	return mav_ftp_file(f, f->session_file == 0 ? GENERAL_PATH : PARAM_PATH, len, &crc);
}

/* One ACK carrying the file's bytes from `offset`; returns how many. */
static uint32_t send_chunk(const struct mav_ftp *f, const struct mav_ftp_link *l, const uint8_t *req, uint16_t seq, uint32_t offset,
			   uint32_t want, bool burst, mav_ftp_send_fn send)
{
	uint32_t len = 0;
	const char *data = session_data(f, &len);
	uint32_t n = len - offset < want ? len - offset : want;
	uint8_t rsp[MAVLINK_MSG_FILE_TRANSFER_PROTOCOL_FIELD_PAYLOAD_LEN];
	memset(rsp, 0, sizeof rsp);
	rsp[P_OPCODE] = OP_ACK;
	rsp[P_SIZE] = (uint8_t)n;
	rsp[P_BURST_COMPLETE] = burst && offset + n >= len ? 1 : 0;
	set32(rsp + P_OFFSET, offset);
	memcpy(rsp + P_DATA, data + offset, n);
	reply(l, req, seq, rsp, send);
	return n;
}

void mav_ftp_handle(struct mav_ftp *f, const struct mav_ftp_link *l, const uint8_t *req, mav_ftp_send_fn send)
{
	const uint16_t seq = (uint16_t)((req[P_SEQ] | req[P_SEQ + 1] << 8) + 1);
	const uint8_t op = req[P_OPCODE];
	uint8_t rsp[MAVLINK_MSG_FILE_TRANSFER_PROTOCOL_FIELD_PAYLOAD_LEN];
	memset(rsp, 0, sizeof rsp);
	switch (op) {
	case OP_OPEN_RO: {
		char path[FTP_DATA_MAX + 1];
		size_t n = req[P_SIZE] < FTP_DATA_MAX ? req[P_SIZE] : FTP_DATA_MAX;
		memcpy(path, req + P_DATA, n);
		path[n] = 0;
		uint32_t len, crc;
		const char *file = mav_ftp_file(f, path, &len, &crc);
		if (!file) {
			nak(l, req, seq, ERR_FILE_NOT_FOUND, send);
			return;
		}
		/* one session: a new open replaces it (a ground station that lost the
		 * previous answer opens again) */
		f->session_open = true;
		while (*path == '/')
			memmove(path, path + 1, strlen(path));
		f->session_file = !strcmp(path, GENERAL_PATH) ? 0 : 1;
		rsp[P_OPCODE] = OP_ACK;
		rsp[P_SIZE] = 4;
		set32(rsp + P_DATA, len);
		uint8_t r2[sizeof rsp];
		memcpy(r2, req, sizeof r2);
		r2[P_SESSION] = 0;
		reply(l, r2, seq, rsp, send);
		return;
	}
	case OP_READ:
	case OP_BURST_READ: {
		if (!f->session_open || req[P_SESSION] != 0) {
			nak(l, req, seq, ERR_INVALID_SESSION, send);
			return;
		}
		uint32_t len = 0;
		(void)session_data(f, &len);
		uint32_t offset = get32(req + P_OFFSET);
		if (offset >= len) {
			nak(l, req, seq, ERR_EOF, send);
			return;
		}
		if (op == OP_READ) {
			uint32_t want = req[P_SIZE] && req[P_SIZE] < FTP_DATA_MAX ? req[P_SIZE] : FTP_DATA_MAX;
			send_chunk(f, l, req, seq, offset, want, false, send);
			return;
		}
		uint16_t s = seq;
		while (offset < len)
			offset += send_chunk(f, l, req, s++, offset, FTP_DATA_MAX, true, send);
		return;
	}
	case OP_CRC32: {
		char path[FTP_DATA_MAX + 1];
		size_t n = req[P_SIZE] < FTP_DATA_MAX ? req[P_SIZE] : FTP_DATA_MAX;
		memcpy(path, req + P_DATA, n);
		path[n] = 0;
		uint32_t len, crc;
		if (!mav_ftp_file(f, path, &len, &crc)) {
			nak(l, req, seq, ERR_FILE_NOT_FOUND, send);
			return;
		}
		rsp[P_OPCODE] = OP_ACK;
		rsp[P_SIZE] = 4;
		set32(rsp + P_DATA, crc);
		reply(l, req, seq, rsp, send);
		return;
	}
	case OP_TERMINATE:
	case OP_RESET:
		if (op == OP_TERMINATE && (!f->session_open || req[P_SESSION] != 0)) {
			nak(l, req, seq, ERR_INVALID_SESSION, send);
			return;
		}
		f->session_open = false;
		f->session_file = -1;
		rsp[P_OPCODE] = OP_ACK;
		reply(l, req, seq, rsp, send);
		return;
	case 3:    /* ListDirectory: nothing to list but the two files' folder */
	case 6:    /* CreateFile */
	case 7:    /* WriteFile */
	case 8:    /* RemoveFile */
	case 9:    /* CreateDirectory */
	case 10:   /* RemoveDirectory */
	case 11:   /* OpenFileWO */
	case 12:   /* TruncateFile */
	case 13:   /* Rename */
		nak(l, req, seq, ERR_FILE_NOT_FOUND, send);   /* read-only: nothing else exists */
		return;
	default:
		nak(l, req, seq, ERR_UNKNOWN_COMMAND, send);
		return;
	}
}

bool mav_ftp_is_metadata_msg(const struct mav_ftp *f, uint32_t msgid)
{
	return (msgid == MAVLINK_MSG_ID_COMPONENT_METADATA || msgid == MAVLINK_MSG_ID_COMPONENT_INFORMATION) &&
	       f->general_len > 0;
}

void mav_ftp_send_metadata_msg(const struct mav_ftp *f, const struct mav_ftp_link *l, uint32_t msgid,
			       mav_ftp_send_fn send)
{
	char uri[MAVLINK_MSG_COMPONENT_METADATA_FIELD_URI_LEN];   /* zero-filled, full size */
	memset(uri, 0, sizeof uri);
	snprintf(uri, sizeof uri, "%s", URI_PREFIX GENERAL_PATH);
	mavlink_message_t msg;
	if (msgid == MAVLINK_MSG_ID_COMPONENT_METADATA) {
		mavlink_msg_component_metadata_pack_chan(l->sysid, l->compid, l->chan, &msg, l->time_boot_ms,
							 f->general_crc, uri);
	} else {
		char none[MAVLINK_MSG_COMPONENT_INFORMATION_FIELD_PERIPHERALS_METADATA_URI_LEN];
		memset(none, 0, sizeof none);
		mavlink_msg_component_information_pack_chan(l->sysid, l->compid, l->chan, &msg, l->time_boot_ms,
							    f->general_crc, uri, 0, none);
	}
	send(l->ctx, &msg);
}
