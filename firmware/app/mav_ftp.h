/* mav_ftp.h - component metadata for ground stations, and the read-only MAVLink
 * FTP server that hands it out.
 *
 * At start-up two JSON files are built from the parameter table: the general
 * metadata file (COMP_METADATA_TYPE_GENERAL, MAVLink's general.schema.json) that
 * points to the parameter metadata file (COMP_METADATA_TYPE_PARAMETER, the
 * parameter.schema.json QGroundControl reads: units, ranges, defaults,
 * descriptions). COMPONENT_METADATA (and COMPONENT_INFORMATION for older
 * readers) announce the general file's mftp:// URI and CRC32.
 *
 * FTP serves exactly these two files read-only (OpenFileRO, ReadFile,
 * BurstReadFile, CalcFileCRC32, TerminateSession, ResetSessions); any other
 * path is FileNotFound and any other operation is NAKed, so that a ground
 * station that looks for files the vehicle does not have (MAVProxy's parameter
 * download, for one) falls back at once.
 */
#ifndef OCTO_MAV_FTP_H
#define OCTO_MAV_FTP_H

#include <stdbool.h>
#include <stdint.h>

/* The generated headers' message type, declared without them (see mav_telem.h). */
typedef struct __mavlink_message mavlink_message_t;

/* Sends one message; ctx is mav_ftp_link.ctx. */
typedef void (*mav_ftp_send_fn)(const void *ctx, const mavlink_message_t *msg);

/* Where replies come from and go to. */
struct mav_ftp_link {
	uint8_t sysid, compid, chan;
	uint8_t to_sysid, to_compid;
	uint32_t time_boot_ms;
	const void *ctx;   /* handed back to the send callback */
};

/* The two files (built once from the parameter table) and the one session.
 * A member of struct mav; the parameter file holds every row's name, unit,
 * range, default and description. */
struct mav_ftp {
	char general[1024];
	char param_json[24576];
	uint32_t general_len, param_len, general_crc, param_crc;
	bool session_open;
	int session_file;   /* 0 general, 1 parameters, -1 none */
};

/* Builds the metadata files; false (with the files empty) if they do not fit. */
bool mav_ftp_init(struct mav_ftp *f);

/* One FILE_TRANSFER_PROTOCOL payload (addressed to this component). */
void mav_ftp_handle(struct mav_ftp *f, const struct mav_ftp_link *l, const uint8_t *payload,
		    mav_ftp_send_fn send);

/* MAV_CMD_REQUEST_MESSAGE for COMPONENT_METADATA or COMPONENT_INFORMATION:
 * true when msgid is one of them (and the files exist); then
 * mav_ftp_send_metadata_msg sends it. */
bool mav_ftp_is_metadata_msg(const struct mav_ftp *f, uint32_t msgid);
void mav_ftp_send_metadata_msg(const struct mav_ftp *f, const struct mav_ftp_link *l, uint32_t msgid,
			       mav_ftp_send_fn send);

/* The files, for tests and tools: path ("octo/general.json", "octo/param.json"). */
const char *mav_ftp_file(const struct mav_ftp *f, const char *path, uint32_t *len, uint32_t *crc);

#endif
