/*
 * fuzz_mavlink.c - libFuzzer harness of octo-fw's MAVLink receive path:
 * mav_receive (framing, CRC, signing) -> dispatch ->
 * parameter and command handlers -> app (modes, experiments, storage).
 *
 * So that the fuzzer gets past the checksum, the input is a sequence of
 * records and the harness frames messages itself with valid CRCs (and valid
 * signatures when signing is on):
 *   byte 0       bit 0: signing on (the firmware and the harness share a key)
 *   then records [kind][len][len bytes]
 *     kind % 16 < 10: one message of the table below, payload = the bytes
 *                     (a MAVLink 2 payload: shorter ones are zero-extended),
 *                     sender sysid/compid from kind's high bits;
 *                     kind bit 7 set: the framed bytes are cut or extended
 *                     with garbage before delivery (truncated / oversized)
 *     10..11: the bytes as a raw datagram (no framing)
 *     12..13: a sensor frame (hovering vehicle, the bytes perturb it)
 *     14..15: app_tick and mav_tick after a wall-clock step
 * Every input starts from the state just after start-up (copied back, see start_state), or
 * resumes from a checkpoint of an earlier input with the same first records (ckpt_find).
 * Checks: parameters stay finite and inside their ranges.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app.h"
#include "fuzz_cov.h"
#include "fuzz_sha256.h"
#include "mav.h"
#include "mav_lib.h" /* the endpoint's one channel: its status and receive buffer */
#include "stub_hal.h"

/* fuzz.mk starts every automatic variable from a pattern (-ftrivial-auto-var-init); the
 * harness's own buffers that it fills before reading opt out of that extra fill. */
#define FUZZ_FILLED_BEFORE_USE __attribute__((uninitialized))

static const uint32_t ids[10] = {
	MAVLINK_MSG_ID_PARAM_SET,
	MAVLINK_MSG_ID_COMMAND_LONG,
	MAVLINK_MSG_ID_COMMAND_INT,
	MAVLINK_MSG_ID_PARAM_REQUEST_READ,
	MAVLINK_MSG_ID_PARAM_REQUEST_LIST,
	MAVLINK_MSG_ID_HEARTBEAT,
	MAVLINK_MSG_ID_MISSION_REQUEST_LIST,
	MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL,
	MAVLINK_MSG_ID_RADIO_STATUS,
	MAVLINK_MSG_ID_STATUSTEXT,
};

static struct app app;
static struct mav mav; /* the platform's MAVLink endpoint, bound to app */
static struct stub_hal hal;
/* The sender's MAVLink state (sequence numbers, signing), apart from the endpoint's channel. */
static mavlink_status_t tx_status;
static mavlink_signing_t tx_signing;
static double t_plant;

/* A sensor frame of a hovering vehicle whose floats from q_ib on are overwritten by b
 * (no coverage: coverage-ignore-mavlink.txt; the app's handling of it has). */
__attribute__((noinline)) static void sensor_frame(struct hal_sensor_frame *f, const uint8_t *b, size_t n)
{
	memset(f, 0, sizeof *f);
	t_plant += 1.0 / 90.0;
	hal_frame_time(f, (uint64_t)llround(t_plant * 90.0), (uint64_t)llround(t_plant * 1e6));
	f->seq = app.fr.seq + 1;
	f->valid = HAL_FRAME_NEEDED | HAL_FRAME_THRUST | HAL_FRAME_TORQUE;
	f->q_ib[0] = 1.0f;
	f->pos_i_m[2] = app.mode == APP_DISARMED || app.mode == APP_IDLE ? 0.0f : sc_to_float(app.guid.z_target_m);
	for (int j = 0; j < HAL_ROTORS; j++)
		f->rotor_thrust_n[j] = 2.6f;
	size_t off = offsetof(struct hal_sensor_frame, q_ib);
	size_t room = sizeof *f - off;
	memcpy((uint8_t *)f + off, b, n < room ? n : room);
}

static void frame(const uint8_t *b, size_t n)
{
	struct hal_sensor_frame f FUZZ_FILLED_BEFORE_USE; /* sensor_frame clears it first */
	sensor_frame(&f, b, n);
	hal.now_us += 11111u;
	app_on_frame(&app, &f);
}

/* Frames one message for kind's record into buf, as the sender (no coverage:
 * coverage-ignore-mavlink.txt; the endpoint's parsing of it has). Returns its length. */
__attribute__((noinline)) static size_t frame_message(uint8_t kind, const uint8_t *b, size_t n,
						      uint8_t buf[MAVLINK_MAX_PACKET_LEN + 64])
{
	uint32_t id = ids[(kind & 15) % 10];
	const mavlink_msg_entry_t *e = mavlink_get_msg_entry(id);
	if (!e)
		abort();
	mavlink_message_t msg FUZZ_FILLED_BEFORE_USE;
	memset(&msg, 0, sizeof msg);
	msg.msgid = id;
	size_t len = n < e->max_msg_len ? n : e->max_msg_len;
	memcpy(_MAV_PAYLOAD_NON_CONST(&msg), b, len);
	/* sender: the ground station, another system, or our own id (an echo) */
	static const uint8_t sys[4] = {255, 1, 42, 0};
	uint8_t sysid = sys[(kind >> 4) & 3], compid = (kind & 0x40) ? 1 : 190;
	mavlink_finalize_message_buffer(&msg, sysid, compid, &tx_status, e->min_msg_len, (uint8_t)len, e->crc_extra);
	size_t k = mavlink_msg_to_send_buffer(buf, &msg);
	if (kind & 0x80) { /* truncated or oversized */
		size_t cut = n ? b[0] : 0;
		if (cut < k) {
			k = cut;
		} else {
			for (size_t i = 0; i < 64; i++)
				buf[k++] = (uint8_t)(i * 37u + cut);
		}
	}
	return k;
}

static void message(uint8_t kind, const uint8_t *b, size_t n)
{
	uint8_t buf[MAVLINK_MAX_PACKET_LEN + 64] FUZZ_FILLED_BEFORE_USE; /* its first k bytes */
	size_t k = frame_message(kind, b, n, buf);
	mav_receive(&mav, buf, k);
}

/* n bytes from src to dst: the harness's copies of whole objects (its globals, their
 * snapshot and checkpoints) and of the input (no coverage: coverage-ignore-mavlink.txt).
 * A struct assignment or memcpy goes through AddressSanitizer's memcpy, which first checks
 * both ranges' shadow: on these copies, which cannot reach past their objects, that check
 * costs about as much as the copy. On x86-64 the copy is the string move that libc's memcpy
 * uses for large sizes. */
__attribute__((noinline)) static void state_copy(void *dst, const void *src, size_t n)
{
#if defined(__x86_64__)
	__asm__ volatile("rep movsb" : "+D"(dst), "+S"(src), "+c"(n) : : "memory");
#else
	memcpy(dst, src, n);
#endif
}

/* The state an input starts from, one per signing mode: the platform, the app, its MAVLink
 * endpoint and the endpoint's channel (parser state, sequence numbers, signing streams and
 * the pointer to the endpoint's signing state), just initialised. app_init and mav_init run
 * once per mode, before the first input (LLVMFuzzerInitialize, so that their coverage is
 * no input's); before each input the snapshot is copied back, so that every input starts
 * from the same state whatever ran before it. */
struct snapshot {
	struct stub_hal hal;
	struct app app;
	struct mav mav;
	mavlink_status_t status;
	mavlink_message_t rx;
};
static struct snapshot snap[2];
/* The endpoint's channel (mav.c's), found once: the harness's own calls of mav.c's functions
 * would count in an input's coverage. */
static mavlink_status_t *ch_status;
static mavlink_message_t *ch_rx;

/* snap[key]: the globals app, mav and hal as after a fresh start in signing mode `key`. They
 * are initialised in place (the structs point at each other and the channel at mav's
 * signing state) and then copied, so the copies restored into the same globals keep valid
 * pointers. */
static void take_snapshot(int key)
{
	struct snapshot *s = &snap[key];
	mavlink_status_t *st = ch_status = mavlink_get_channel_status(MAVLINK_COMM_0);
	mavlink_message_t *rx = ch_rx = mavlink_get_channel_buffer(MAVLINK_COMM_0);
	stub_hal_init(&hal);
	hal.have_key = key != 0;
	for (int i = 0; i < 32; i++)
		hal.key[i] = (uint8_t)(i * 7 + 1);
	memset(st, 0, sizeof *st);
	memset(rx, 0, sizeof *rx);
	app_init(&app, &hal.hal);
	mav_init(&mav, &app, &hal.hal, hal.now_us);
	s->hal = hal;
	s->app = app;
	s->mav = mav;
	s->status = *st;
	s->rx = *rx;
}

/* The globals as snap[key] holds them, and the sender's state from zero (no coverage:
 * coverage-ignore-mavlink.txt). */
__attribute__((noinline)) static void start_state(int key)
{
	const struct snapshot *s = &snap[key];
	state_copy(&hal, &s->hal, sizeof hal);
	state_copy(&app, &s->app, sizeof app);
	mav = s->mav;
	*ch_status = s->status;
	*ch_rx = s->rx;
	/* the sender: numbering from 0, signing with the shared key */
	memset(&tx_status, 0, sizeof tx_status);
	memset(&tx_signing, 0, sizeof tx_signing);
	if (key) {
		memcpy(tx_signing.secret_key, hal.key, 32);
		tx_signing.flags = MAVLINK_SIGNING_FLAG_SIGN_OUTGOING;
		tx_signing.link_id = 3;
		tx_signing.timestamp = (hal_unix_us(&hal.hal) - 1420070400ull * 1000000ull) / 10u + 1000u;
		tx_status.signing = &tx_signing;
	}
}

/* Parameters stay finite and inside their ranges (no coverage: coverage-ignore-mavlink.txt);
 * those of the start state are. */
__attribute__((noinline)) static void check_params(const struct app_params *start)
{
	if (!memcmp(&app.p, start, sizeof *start))
		return;
	for (size_t i = 0; i < param_count; i++) {
		float v = params_get(&app.p, i);
		if (!isfinite(v) || v < param_defs[i].min || v > param_defs[i].max)
			abort();
	}
}

/* FNV-1a of n bytes from h */
static uint64_t fnv(uint64_t h, const void *p, size_t n)
{
	const uint8_t *b = p;
	for (size_t i = 0; i < n; i++)
		h = (h ^ b[i]) * 0x100000001b3ull;
	return h;
}

/* A hash of the state an input leaves (platform, app, endpoint, channel, sender). The bytes
 * of an event's text after its NUL are left out: the app copies whole text buffers whose
 * tails are whatever its stack held, and nothing reads them. Not coverage-traced
 * (coverage-ignore-mavlink.txt). */
__attribute__((noinline)) static uint64_t state_hash(void)
{
	static struct app a;
	a = app;
	for (size_t i = 0; i < APP_OUTBOX_LEN; i++) {
		struct app_event *e = &a.outbox.ev[i];
		size_t used = e->kind == APP_EV_ID_RESULT ? sizeof e->id : strnlen(e->text, sizeof e->text);
		memset((char *)e->text + used, 0, sizeof e->text - used);
	}
	uint64_t h = 0xcbf29ce484222325ull;
	h = fnv(h, &hal, sizeof hal);
	h = fnv(h, &a, sizeof a);
	h = fnv(h, &mav, sizeof mav);
	h = fnv(h, ch_status, sizeof *ch_status);
	h = fnv(h, ch_rx, sizeof *ch_rx);
	h = fnv(h, &tx_status, sizeof tx_status);
	h = fnv(h, &tx_signing, sizeof tx_signing);
	return fnv(h, &t_plant, sizeof t_plant);
}

/* With OCTO_FUZZ_DIGEST in the environment, state_hash goes to stderr after each input:
 * reset_check.sh replays inputs in two orders in one process and compares, so that an
 * input's outcome cannot depend on the inputs before it (neither through the reset nor
 * through the prefix checkpoints below). */
static void digest(void)
{
	static int on = -1;
	if (on < 0)
		on = getenv("OCTO_FUZZ_DIGEST") != NULL;
	if (on)
		fprintf(stderr, "digest %016llx\n", (unsigned long long)state_hash());
}

/* Prefix checkpoints. libFuzzer mutates an input a few times in a row, each time at one
 * place, so consecutive inputs often share their first records. While an input runs, the
 * harness copies the whole state (as start_state's snapshot, plus the sender, the plant
 * clock and libFuzzer's coverage counters) at record boundaries, every CKPT_WORK of work;
 * the next input that begins with the same bytes up to a checkpoint resumes from it instead
 * of running those records again. The counters are restored with the state, so that
 * libFuzzer sees the coverage and hit counts of the whole input, as if it had run from the
 * start. A checkpoint is taken only after a record that was not cut by the input's end:
 * any input with the same bytes up to there holds the same whole records. OCTO_FUZZ_VERIFY
 * in the environment runs every resumed input a second time, from the start, and aborts
 * unless the state and the counters agree (verify_resumed). */
#define CKPT_N 32
#define CKPT_COV_CAP 16384
#define CKPT_WORK 12 /* records between checkpoints, a frame counting 2 and a signed message 2 */
#define CKPT_INPUT_CAP 4096
struct ckpt {
	size_t pos; /* the input's bytes [0, pos) ran */
	double t_plant;
	struct snapshot s;
	mavlink_status_t tx_status;
	mavlink_signing_t tx_signing;
	uint8_t cov[CKPT_COV_CAP];
};
static struct ckpt ckpt[CKPT_N];
static size_t n_ckpt;
static bool verify;                  /* OCTO_FUZZ_VERIFY */
static uint8_t prev[CKPT_INPUT_CAP]; /* the last input that ran with checkpoints */
static size_t prev_len;

static uint8_t *cov; /* libFuzzer's coverage counters */
static size_t cov_n;

__attribute__((noinline)) static void ckpt_save(struct ckpt *c, size_t pos)
{
	c->pos = pos;
	c->t_plant = t_plant;
	state_copy(&c->s.hal, &hal, sizeof hal);
	state_copy(&c->s.app, &app, sizeof app);
	c->s.mav = mav;
	c->s.status = *ch_status;
	c->s.rx = *ch_rx;
	c->tx_status = tx_status;
	c->tx_signing = tx_signing;
	state_copy(c->cov, cov, cov_n);
}

__attribute__((noinline)) static void ckpt_restore(const struct ckpt *c)
{
	t_plant = c->t_plant;
	state_copy(&hal, &c->s.hal, sizeof hal);
	state_copy(&app, &c->s.app, sizeof app);
	mav = c->s.mav;
	*ch_status = c->s.status;
	*ch_rx = c->s.rx;
	tx_status = c->tx_status;
	tx_signing = c->tx_signing;
	state_copy(cov, c->cov, cov_n);
}

/* The checkpoint to resume the input from (its bytes up to there as the last input's), or
 * NULL; the checkpoints past it are dropped. */
static const struct ckpt *ckpt_find(const uint8_t *data, size_t size)
{
	size_t same = 0, n = size < prev_len ? size : prev_len;
	while (same < n && data[same] == prev[same])
		same++;
	while (n_ckpt > 0 && ckpt[n_ckpt - 1].pos > same)
		n_ckpt--;
	return n_ckpt > 0 ? &ckpt[n_ckpt - 1] : NULL;
}

/* Runs the input's records from pos and, with checkpoints on, takes them as it goes (no
 * coverage: coverage-ignore-mavlink.txt). */
__attribute__((noinline)) static void run_records(const uint8_t *data, size_t size, size_t pos, bool checkpoints)
{
	unsigned work = 0;
	while (pos + 2 <= size) {
		uint8_t kind = data[pos], n = data[pos + 1];
		pos += 2;
		size_t len = n < size - pos ? n : size - pos;
		const uint8_t *b = data + pos;
		pos += len;
		switch (kind & 15) {
		case 10:
		case 11:
			mav_receive(&mav, b, len);
			work += 1;
			break;
		case 12:
		case 13:
			frame(b, len);
			work += 2;
			break;
		case 14:
		case 15:
			hal.now_us += (uint64_t)(len ? b[0] : 1) * 10000u;
			app_tick(&app);
			mav_tick(&mav, hal.now_us);
			work += 1;
			break;
		default:
			message(kind, b, len);
			work += 1u + (data[0] & 1);
			break;
		}
		if (checkpoints && work >= CKPT_WORK && len == n && n_ckpt < CKPT_N) {
			ckpt_save(&ckpt[n_ckpt++], pos);
			work = 0;
		}
	}
}

/* AddressSanitizer's defaults in this harness (ASAN_OPTIONS still overrides them). The
 * firmware and the harness allocate nothing, so the quarantine of freed blocks (which finds
 * a use after free) holds only libFuzzer's own allocations of each input: kept small, they
 * are reused, instead of each input's landing in memory not touched yet. */
const char *__asan_default_options(void);
const char *__asan_default_options(void) { return "quarantine_size_mb=16"; }

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
	(void)argc;
	(void)argv;
	fuzz_sha256_selftest();
	take_snapshot(0);
	take_snapshot(1);
	cov = fuzz_cov_counters(&cov_n);
	if (cov_n > CKPT_COV_CAP)
		abort(); /* raise CKPT_COV_CAP */
	verify = getenv("OCTO_FUZZ_VERIFY") != NULL;
	return 0;
}

/* OCTO_FUZZ_VERIFY: the input that was resumed at byte pos runs again from the start; the
 * state it leaves and the coverage counters must be the same (no coverage:
 * coverage-ignore-mavlink.txt). */
__attribute__((noinline)) static void verify_resumed(const uint8_t *data, size_t size, size_t pos)
{
	static uint8_t resumed[CKPT_COV_CAP];
	uint64_t h = state_hash();
	memcpy(resumed, cov, cov_n);
	memset(cov, 0, cov_n);
	start_state(data[0] & 1);
	t_plant = 0.0;
	run_records(data, size, 1, false);
	check_params(&snap[data[0] & 1].app.p);
	bool same = state_hash() == h;
	for (size_t i = 0; i < cov_n; i++)
		if (resumed[i] != cov[i]) {
			fprintf(stderr, "fuzz_mavlink: coverage counter %zu: %u resumed, %u run whole\n", i, resumed[i],
				cov[i]);
			same = false;
		}
	if (!same) {
		fprintf(stderr, "fuzz_mavlink: the input resumed at byte %zu differs from it run whole\n", pos);
		abort();
	}
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (size < 1)
		return 0;
	bool checkpoints = size <= CKPT_INPUT_CAP && cov_n > 0;
	const struct ckpt *c = checkpoints ? ckpt_find(data, size) : NULL;
	if (c) {
		ckpt_restore(c);
		run_records(data, size, c->pos, true);
	} else {
		n_ckpt = 0;
		start_state(data[0] & 1);
		t_plant = 0.0;
		run_records(data, size, 1, checkpoints);
	}
	if (checkpoints) {
		state_copy(prev, data, size);
		prev_len = size;
	}
	check_params(&snap[data[0] & 1].app.p);
	digest();
	if (verify && c)
		verify_resumed(data, size, c->pos);
	return 0;
}
