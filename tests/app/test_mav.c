/*
 * test_mav.c - the MAVLink module (mav.c, mav_telem.c, mav_ftp.c) on the stub
 * HAL, its datagrams decoded as a ground station would: home position per
 * vehicle (the module's state is per struct app, so two vehicles in one
 * process keep their own), home refused before a position exists, and the
 * parameter metadata file read over FTP (the compressed bytes in flash, its CRC the
 * one the general metadata file announces).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <octo/mavlink.h>

#include "app.h"
#include "mav.h"
#include "params.h"
#include "stub_hal.h"
#include "unit.h"

#define GCS_SYSID 255
#define GCS_COMPID 190
#define GOT_CAP 512

struct mrig {
	struct stub_hal h; /* first: the hal's ctx points to the rig */
	struct app a;
	struct mav m;
	struct hal_sensor_frame f;
	mavlink_message_t got[GOT_CAP];
	int n_got;
};

static struct mrig RA, RB; /* large: kept off the stack */

/* The ground link of the rig: every datagram decoded (a whole packet each). */
static void capture(void *ctx, const uint8_t *buf, size_t len)
{
	struct mrig *r = ctx;
	mavlink_message_t m;
	mavlink_status_t st;
	for (size_t i = 0; i < len; i++)
		if (mavlink_parse_char(MAVLINK_COMM_1, buf[i], &m, &st) == MAVLINK_FRAMING_OK && r->n_got < GOT_CAP)
			r->got[r->n_got++] = m;
}

static void mrig_init(struct mrig *r)
{
	memset(r, 0, sizeof *r);
	stub_hal_init(&r->h);
	r->h.hal.ground_send = capture;
	app_init(&r->a, &r->h.hal);
	mav_init(&r->m, &r->a, &r->h.hal, r->h.now_us);
	r->f.q_ib[0] = 1.0f;
}

/* n frames on the ground at (lat, lon, alt), 90 Hz, each followed by a tick. */
static void frames(struct mrig *r, int n, double lat, double lon, float alt)
{
	for (int k = 0; k < n; k++) {
		r->h.now_us += 11111u;
		hal_frame_time(&r->f, r->f.frame_n + 1u, r->f.t_us + 11111u);
		r->f.seq++;
		r->f.valid = HAL_FRAME_NEEDED | HAL_FRAME_GLOBAL;
		r->f.lat_deg = lat;
		r->f.lon_deg = lon;
		r->f.alt_msl_m = alt;
		app_on_frame(&r->a, &r->f);
		app_tick(&r->a);
		mav_tick(&r->m, r->h.now_us);
	}
}

static void to_vehicle(struct mrig *r, const mavlink_message_t *m)
{
	uint8_t buf[MAVLINK_MAX_PACKET_LEN];
	uint16_t n = mavlink_msg_to_send_buffer(buf, m);
	mav_receive(&r->m, buf, n);
}

static void command(struct mrig *r, uint16_t cmd, float p1)
{
	mavlink_message_t m;
	mavlink_msg_command_long_pack_chan(GCS_SYSID, GCS_COMPID, MAVLINK_COMM_2, &m, MAV_SYSID, MAV_COMPID, cmd, 0, p1,
					   0, 0, 0, 0, 0, 0);
	to_vehicle(r, &m);
}

/* The last message with msgid received since index `from`, or NULL. */
static const mavlink_message_t *last_of(const struct mrig *r, int from, uint32_t msgid)
{
	const mavlink_message_t *m = NULL;
	for (int i = from; i < r->n_got; i++)
		if (r->got[i].msgid == msgid)
			m = &r->got[i];
	return m;
}

static uint8_t ack_of(const struct mrig *r, int from, uint16_t cmd)
{
	for (int i = r->n_got - 1; i >= from; i--) {
		if (r->got[i].msgid != MAVLINK_MSG_ID_COMMAND_ACK)
			continue;
		mavlink_command_ack_t a;
		mavlink_msg_command_ack_decode(&r->got[i], &a);
		if (a.command == cmd)
			return a.result;
	}
	return 255;
}

/* A reproducible spread of positions (not one value the code could be tuned on). */
static double pseudo(uint32_t *s, double lo, double hi)
{
	*s = *s * 1664525u + 1013904223u;
	return lo + (hi - lo) * (double)(*s >> 8) / 16777216.0;
}

UNIT_TEST(mav_home_refused_before_a_position)
{
	mrig_init(&RA);
	int from = RA.n_got;
	command(&RA, MAV_CMD_GET_HOME_POSITION, 0.0f);
	CHECK(ack_of(&RA, from, MAV_CMD_GET_HOME_POSITION) == MAV_RESULT_TEMPORARILY_REJECTED);
	CHECK(last_of(&RA, from, MAVLINK_MSG_ID_HOME_POSITION) == NULL);
}

UNIT_TEST(mav_two_vehicles_keep_their_own_home)
{
	uint32_t seed = 0x5eed1234u;
	for (int trial = 0; trial < 5; trial++) {
		const double lat_a = pseudo(&seed, -60.0, 60.0), lon_a = pseudo(&seed, -179.0, 179.0);
		const double lat_b = pseudo(&seed, -60.0, 60.0), lon_b = pseudo(&seed, -179.0, 179.0);
		const float alt_a = (float)pseudo(&seed, 0.0, 3000.0), alt_b = (float)pseudo(&seed, 0.0, 3000.0);
		mrig_init(&RA);
		mrig_init(&RB);
		/* interleaved, as two vehicles in one process would run */
		for (int k = 0; k < 30; k++) {
			frames(&RA, 1, lat_a, lon_a, alt_a);
			frames(&RB, 1, lat_b, lon_b, alt_b);
		}
		struct mrig *rigs[2] = {&RA, &RB};
		const double lat[2] = {lat_a, lat_b}, lon[2] = {lon_a, lon_b};
		const float alt[2] = {alt_a, alt_b};
		for (int v = 0; v < 2; v++) {
			struct mrig *r = rigs[v];
			int from = r->n_got;
			command(r, MAV_CMD_GET_HOME_POSITION, 0.0f);
			CHECK(ack_of(r, from, MAV_CMD_GET_HOME_POSITION) == MAV_RESULT_ACCEPTED);
			const mavlink_message_t *m = last_of(r, from, MAVLINK_MSG_ID_HOME_POSITION);
			CHECK(m != NULL);
			if (!m)
				continue;
			mavlink_home_position_t hp;
			mavlink_msg_home_position_decode(m, &hp);
			CHECK(labs((long)hp.latitude - lround(lat[v] * 1e7)) <= 1);
			CHECK(labs((long)hp.longitude - lround(lon[v] * 1e7)) <= 1);
			CHECK(labs((long)hp.altitude - lround((double)alt[v] * 1000.0)) <= 1);
			/* and its global position is where it stands */
			const mavlink_message_t *g = last_of(r, 0, MAVLINK_MSG_ID_GLOBAL_POSITION_INT);
			CHECK(g != NULL);
			if (g) {
				mavlink_global_position_int_t gp;
				mavlink_msg_global_position_int_decode(g, &gp);
				CHECK(labs((long)gp.lat - lround(lat[v] * 1e7)) <= 1);
				CHECK(labs((long)gp.lon - lround(lon[v] * 1e7)) <= 1);
			}
		}
	}
}

/* ---- FTP */

static void ftp(struct mrig *r, uint16_t seq, uint8_t op, uint32_t offset, const char *path)
{
	uint8_t p[MAVLINK_MSG_FILE_TRANSFER_PROTOCOL_FIELD_PAYLOAD_LEN];
	memset(p, 0, sizeof p);
	p[0] = (uint8_t)seq;
	p[1] = (uint8_t)(seq >> 8);
	p[3] = op;
	for (int k = 0; k < 4; k++)
		p[8 + k] = (uint8_t)(offset >> (8 * k));
	if (path) {
		size_t n = strlen(path);
		p[4] = (uint8_t)n;
		memcpy(p + 12, path, n);
	}
	mavlink_message_t m;
	mavlink_msg_file_transfer_protocol_pack_chan(GCS_SYSID, GCS_COMPID, MAVLINK_COMM_2, &m, 0, MAV_SYSID,
						     MAV_COMPID, p);
	to_vehicle(r, &m);
}

/* The payload of the last FTP reply since `from`, or NULL. */
static const uint8_t *ftp_reply(const struct mrig *r, int from, uint8_t out[251])
{
	const mavlink_message_t *m = last_of(r, from, MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL);
	if (!m)
		return NULL;
	mavlink_file_transfer_protocol_t t;
	mavlink_msg_file_transfer_protocol_decode(m, &t);
	memcpy(out, t.payload, sizeof t.payload);
	return out;
}

/* Reads a whole file with OpenFileRO / ReadFile; its length, or -1. */
static long ftp_read(struct mrig *r, const char *path, char *buf, size_t cap)
{
	uint8_t rsp[251];
	int from = r->n_got;
	ftp(r, 1, 4, 0, path);
	if (!ftp_reply(r, from, rsp) || rsp[3] != 128)
		return -1;
	size_t len = 0;
	for (uint16_t seq = 2; seq < 2000; seq++) {
		from = r->n_got;
		ftp(r, seq, 5, (uint32_t)len, NULL);
		if (!ftp_reply(r, from, rsp))
			return -1;
		if (rsp[3] == 129) /* NAK: EOF ends the file */
			return rsp[12] == 6 ? (long)len : -1;
		uint32_t off =
			(uint32_t)rsp[8] | (uint32_t)rsp[9] << 8 | (uint32_t)rsp[10] << 16 | (uint32_t)rsp[11] << 24;
		if (off != len || rsp[4] == 0 || len + rsp[4] >= cap)
			return -1;
		memcpy(buf + len, rsp + 12, rsp[4]);
		len += rsp[4];
	}
	return -1;
}

static uint32_t zlib_crc32(const char *p, size_t n)
{
	uint32_t c = 0xFFFFFFFFu;
	for (size_t i = 0; i < n; i++) {
		c ^= (uint8_t)p[i];
		for (int k = 0; k < 8; k++)
			c = (c & 1u) ? (c >> 1) ^ 0xEDB88320u : c >> 1;
	}
	return ~c;
}

static char file_buf[65536];
static char general_buf[4096];

UNIT_TEST(mav_ftp_serves_the_parameter_metadata)
{
	mrig_init(&RA);
	long gl = ftp_read(&RA, "octo/general.json", general_buf, sizeof general_buf);
	CHECK(gl > 0);
	long pl = ftp_read(&RA, "octo/param.json.xz", file_buf, sizeof file_buf);
	CHECK(pl > 0);
	if (gl <= 0 || pl <= 0)
		return;
	general_buf[gl] = 0;
	/* the bytes in flash, an xz stream (its magic), with the CRC the general file announces
	 * (tests/py/test_client_metadata.py decompresses it against the parameter table) */
	const struct mav_ftp_file *pf = &mav_ftp_files[MAV_FTP_PARAM];
	CHECK((uint32_t)pl == pf->len && !memcmp(file_buf, pf->data, pf->len));
	CHECK(!memcmp(file_buf,
		      "\xfd"
		      "7zXZ",
		      6));
	char crc[48];
	snprintf(crc, sizeof crc, "\"fileCrc\": %lu", (unsigned long)zlib_crc32(file_buf, (size_t)pl));
	CHECK(strstr(general_buf, crc) != NULL);
	CHECK(strstr(general_buf, "\"mftp://octo/param.json.xz\"") != NULL);
	CHECK(zlib_crc32(general_buf, (size_t)gl) == mav_ftp_files[MAV_FTP_GENERAL].crc);
	/* anything else does not exist, the uncompressed name included */
	uint8_t rsp[251];
	int from = RA.n_got;
	ftp(&RA, 9, 4, 0, "etc/passwd");
	CHECK(ftp_reply(&RA, from, rsp) != NULL && rsp[3] == 129 && rsp[12] == 10);
	from = RA.n_got;
	ftp(&RA, 10, 4, 0, "octo/param.json");
	CHECK(ftp_reply(&RA, from, rsp) != NULL && rsp[3] == 129 && rsp[12] == 10);
}

/* PARAM_SET / PARAM_REQUEST_READ names: every parameter found by its own name, with or
 * without the NUL (a 16-character id fills the field), and no prefix, extension or empty
 * name taken for one */
UNIT_TEST(mav_param_names_found_exactly)
{
	for (size_t i = 0; i < param_count; i++) {
		const char *nm = param_defs[i].name;
		size_t n = strlen(nm);
		char id[PARAM_ID_LEN + 2];
		memset(id, 'X', sizeof id);
		memcpy(id, nm, n);
		CHECK(params_find(id, n) == (int)i); /* the field ends at n */
		id[n] = '\0';
		CHECK(params_find(id, PARAM_ID_LEN) == (int)i); /* NUL-terminated */
		if (n > 1)
			CHECK(params_find(id, n - 1) != (int)i); /* a prefix is another name */
		if (n < PARAM_ID_LEN) {
			id[n] = 'Z';
			id[n + 1] = '\0';
			CHECK(params_find(id, PARAM_ID_LEN) != (int)i); /* so is an extension */
		}
	}
	CHECK(params_find("", PARAM_ID_LEN) == -1);
	CHECK(params_find("VEH_KF", 0) == -1);
	CHECK(params_find("NO_SUCH_PARAM", PARAM_ID_LEN) == -1);
}

/* The STATUSTEXTs since `from` joined as a ground station joins them: id 0 alone, a nonzero id
 * chunk by chunk (chunk_seq 0, 1, ... all the same id) until the chunk that is not full.
 * -1 when a chunk is out of order or its id changes mid-line. */
static int statustexts(const struct mrig *r, int from, char out[][128], int cap, int *chunks)
{
	int n = 0;
	*chunks = 0;
	char line[128] = "";
	uint16_t id = 0;
	uint8_t next = 0;
	for (int i = from; i < r->n_got && n < cap; i++) {
		if (r->got[i].msgid != MAVLINK_MSG_ID_STATUSTEXT)
			continue;
		mavlink_statustext_t t;
		mavlink_msg_statustext_decode(&r->got[i], &t);
		char text[MAVLINK_MSG_STATUSTEXT_FIELD_TEXT_LEN + 1];
		memcpy(text, t.text, sizeof t.text);
		text[sizeof t.text] = 0;
		(*chunks)++;
		if (t.id == 0) {
			snprintf(out[n++], 128, "%s", text);
			continue;
		}
		if (t.chunk_seq == 0) {
			line[0] = 0;
			id = t.id;
			next = 0;
		}
		if (t.id != id || t.chunk_seq != next)
			return -1;
		next++;
		size_t k = strlen(line);
		snprintf(line + k, sizeof line - k, "%s", text);
		if (strlen(text) < sizeof t.text)
			snprintf(out[n++], 128, "%s", line);
	}
	return n;
}

UNIT_TEST(mav_long_statustext_goes_out_in_chunks)
{
	struct mrig *r = &RA;
	mrig_init(r);
	frames(r, 5, 45.0, 7.0, 300.0f);
	char want[3][APP_EVENT_TEXT];
	const size_t len[3] = {50, 51, APP_EVENT_TEXT - 1}; /* one message; two chunks; the longest line */
	for (int k = 0; k < 3; k++) {
		for (size_t i = 0; i < len[k]; i++)
			want[k][i] = (char)('a' + (i * 7u + (size_t)k) % 26u);
		want[k][len[k]] = 0;
	}
	int from = r->n_got;
	for (int k = 0; k < 3; k++)
		app_status(&r->a, APP_SEV_WARNING, "%s", want[k]);
	frames(r, 3, 45.0, 7.0, 300.0f);
	char got[8][128];
	int chunks;
	int n = statustexts(r, from, got, 8, &chunks);
	CHECK(n == 3);
	CHECK(chunks == 5);
	for (int k = 0; k < 3 && k < n; k++)
		CHECK(!strcmp(got[k], want[k]));
	/* two long lines carry different ids; the 50-character line is one message, id 0 */
	uint16_t ids[8];
	int m = 0;
	for (int i = from; i < r->n_got && m < 8; i++)
		if (r->got[i].msgid == MAVLINK_MSG_ID_STATUSTEXT) {
			mavlink_statustext_t t; /* decoded: the getters read the payload unaligned */
			mavlink_msg_statustext_decode(&r->got[i], &t);
			ids[m++] = t.id;
		}
	CHECK(m == 5 && ids[0] == 0 && ids[1] != 0 && ids[1] == ids[2] && ids[3] != 0 && ids[3] == ids[4] &&
	      ids[3] != ids[1]);
}
