/* mav_ftp.c - component metadata and the read-only MAVLink FTP server (see mav_ftp.h). */
#include "mav_ftp.h"

#include <stdio.h>
#include <string.h>

#include "mav_lib.h"

/* MAVLink FTP payload layout and codes (MAVLink's FTP protocol) */
enum {
	P_SEQ = 0,
	P_SESSION = 2,
	P_OPCODE = 3,
	P_SIZE = 4,
	P_REQ_OPCODE = 5,
	P_BURST_COMPLETE = 6,
	P_OFFSET = 8,
	P_DATA = 12
};
#define FTP_DATA_MAX 239
enum {
	OP_TERMINATE = 1,
	OP_RESET = 2,
	OP_OPEN_RO = 4,
	OP_READ = 5,
	OP_CRC32 = 14,
	OP_BURST_READ = 15,
	OP_ACK = 128,
	OP_NAK = 129
};
enum { ERR_FAIL = 1, ERR_INVALID_SESSION = 4, ERR_EOF = 6, ERR_UNKNOWN_COMMAND = 7, ERR_FILE_NOT_FOUND = 10 };

#define URI_PREFIX "mftp://"

bool mav_ftp_init(struct mav_ftp *f)
{
	f->session_open = false;
	f->session_file = -1;
	return mav_ftp_files[MAV_FTP_GENERAL].len > 0 && mav_ftp_files[MAV_FTP_PARAM].len > 0;
}

const struct mav_ftp_file *mav_ftp_find(const char *path)
{
	while (*path == '/')
		path++;
	for (int i = 0; i < MAV_FTP_N_FILES; i++)
		if (!strcmp(path, mav_ftp_files[i].path))
			return &mav_ftp_files[i];
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

static void reply(const struct mav_ftp_link *l, const uint8_t *req, uint16_t seq, uint8_t *rsp, mav_ftp_send_fn send)
{
	rsp[P_SEQ] = (uint8_t)seq;
	rsp[P_SEQ + 1] = (uint8_t)(seq >> 8);
	rsp[P_SESSION] = req[P_SESSION];
	rsp[P_REQ_OPCODE] = req[P_OPCODE];
	mavlink_message_t msg;
	mavlink_msg_file_transfer_protocol_pack_chan(l->sysid, l->compid, l->chan, &msg, 0, l->to_sysid, l->to_compid,
						     rsp);
	send(l->ctx, &msg);
}

static void nak(const struct mav_ftp_link *l, const uint8_t *req, uint16_t seq, uint8_t err, mav_ftp_send_fn send)
{
	uint8_t rsp[MAVLINK_MSG_FILE_TRANSFER_PROTOCOL_FIELD_PAYLOAD_LEN];
	memset(rsp, 0, sizeof rsp);
	rsp[P_OPCODE] = OP_NAK;
	rsp[P_SIZE] = 1;
	rsp[P_DATA] = err;
	reply(l, req, seq, rsp, send);
}

static const struct mav_ftp_file *session_file(const struct mav_ftp *f) { return &mav_ftp_files[f->session_file]; }

/* One ACK carrying the file's bytes from `offset`; returns how many. */
static uint32_t send_chunk(const struct mav_ftp *f, const struct mav_ftp_link *l, const uint8_t *req, uint16_t seq,
			   uint32_t offset, uint32_t want, bool burst, mav_ftp_send_fn send)
{
	const uint8_t *data = session_file(f)->data;
	const uint32_t len = session_file(f)->len;
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
		const struct mav_ftp_file *file = mav_ftp_find(path);
		if (!file) {
			nak(l, req, seq, ERR_FILE_NOT_FOUND, send);
			return;
		}
		/* one session: a new open replaces it (a ground station that lost the
		 * previous answer opens again) */
		f->session_open = true;
		f->session_file = (int8_t)(file - mav_ftp_files);
		rsp[P_OPCODE] = OP_ACK;
		rsp[P_SIZE] = 4;
		set32(rsp + P_DATA, file->len);
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
		const uint32_t len = session_file(f)->len;
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
		const struct mav_ftp_file *file = mav_ftp_find(path);
		if (!file) {
			nak(l, req, seq, ERR_FILE_NOT_FOUND, send);
			return;
		}
		rsp[P_OPCODE] = OP_ACK;
		rsp[P_SIZE] = 4;
		set32(rsp + P_DATA, file->crc);
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
	case 3:  /* ListDirectory: nothing to list but the two files' folder */
	case 6:  /* CreateFile */
	case 7:  /* WriteFile */
	case 8:  /* RemoveFile */
	case 9:  /* CreateDirectory */
	case 10: /* RemoveDirectory */
	case 11: /* OpenFileWO */
	case 12: /* TruncateFile */
	case 13: /* Rename */
		nak(l, req, seq, ERR_FILE_NOT_FOUND, send); /* read-only: nothing else exists */
		return;
	default: nak(l, req, seq, ERR_UNKNOWN_COMMAND, send); return;
	}
}

bool mav_ftp_is_metadata_msg(const struct mav_ftp *f, uint32_t msgid)
{
	(void)f;
	return (msgid == MAVLINK_MSG_ID_COMPONENT_METADATA || msgid == MAVLINK_MSG_ID_COMPONENT_INFORMATION) &&
	       mav_ftp_files[MAV_FTP_GENERAL].len > 0;
}

void mav_ftp_send_metadata_msg(const struct mav_ftp *f, const struct mav_ftp_link *l, uint32_t msgid,
			       mav_ftp_send_fn send)
{
	(void)f;
	char uri[MAVLINK_MSG_COMPONENT_METADATA_FIELD_URI_LEN]; /* zero-filled, full size */
	memset(uri, 0, sizeof uri);
	snprintf(uri, sizeof uri, "%s%s", URI_PREFIX, mav_ftp_files[MAV_FTP_GENERAL].path);
	mavlink_message_t msg;
	if (msgid == MAVLINK_MSG_ID_COMPONENT_METADATA) {
		mavlink_msg_component_metadata_pack_chan(l->sysid, l->compid, l->chan, &msg, l->time_boot_ms,
							 mav_ftp_files[MAV_FTP_GENERAL].crc, uri);
	} else {
		char none[MAVLINK_MSG_COMPONENT_INFORMATION_FIELD_PERIPHERALS_METADATA_URI_LEN];
		memset(none, 0, sizeof none);
		mavlink_msg_component_information_pack_chan(l->sysid, l->compid, l->chan, &msg, l->time_boot_ms,
							    mav_ftp_files[MAV_FTP_GENERAL].crc, uri, 0, none);
	}
	send(l->ctx, &msg);
}
