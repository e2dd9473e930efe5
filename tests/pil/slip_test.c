/*
 * slip_test.c - the board's SLIP decoder (firmware/hal/mps2/slip.c) on the host, against lost,
 * changed and added bytes: a good frame is delivered whole, a spoilt one is dropped and counted,
 * and the next END starts a clean frame. Built and run by tests/py/test_pil.py; exit status 0
 * when every check holds, else 1 with the failed checks on stderr.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "slip.h"

static int failures;

#define CHECK(c)                                                                       \
	do {                                                                           \
		if (!(c)) {                                                            \
			fprintf(stderr, "slip_test.c:%d: failed: %s\n", __LINE__, #c); \
			failures++;                                                    \
		}                                                                      \
	} while (0)

struct wire {
	uint8_t b[1 << 16];
	size_t n;
};

static void put(void *ctx, uint8_t c)
{
	struct wire *w = ctx;
	if (w->n < sizeof w->b)
		w->b[w->n++] = c;
}

static void frame(struct wire *w, const uint8_t *msg, size_t len)
{
	struct slip_tx t = {.put = put, .ctx = w};
	slip_tx_begin(&t);
	slip_tx_add(&t, msg, len);
	slip_tx_end(&t);
}

/* Feeds the wire; writes the delivered messages' lengths into got (at most cap). */
static size_t feed(struct slip_rx *r, const uint8_t *p, size_t n, const uint8_t *const *msgs, const size_t *lens,
		   size_t nmsg, int *which, size_t cap)
{
	size_t k = 0;
	for (size_t i = 0; i < n; i++) {
		size_t len = slip_rx_byte(r, p[i]);
		if (!len)
			continue;
		int w = -1;
		for (size_t m = 0; m < nmsg; m++)
			if (len == lens[m] && memcmp(r->buf, msgs[m], len) == 0)
				w = (int)m;
		if (k < cap)
			which[k] = w; /* -1: a frame that is none of the messages sent */
		k++;
	}
	return k;
}

int main(void)
{
	static uint8_t m0[5], m1[300], m2[41];
	for (size_t i = 0; i < sizeof m1; i++)
		m1[i] = (uint8_t)i; /* holds END and ESC */
	memcpy(m0, "\xc0\xdb\xdc\xdd\x01", 5);
	memset(m2, SLIP_END, sizeof m2);
	const uint8_t *msgs[3] = {m0, m1, m2};
	const size_t lens[3] = {sizeof m0, sizeof m1, sizeof m2};
	static struct wire f[3], w;
	for (int i = 0; i < 3; i++)
		frame(&f[i], msgs[i], lens[i]);
	int got[64];
	struct slip_rx r;

	/* the CRC is zlib's CRC-32 */
	CHECK(slip_crc32(0, (const uint8_t *)"123456789", 9) == 0xCBF43926u);

	/* three frames, none spoilt */
	memset(&r, 0, sizeof r);
	w.n = 0;
	for (int i = 0; i < 3; i++) {
		memcpy(w.b + w.n, f[i].b, f[i].n);
		w.n += f[i].n;
	}
	CHECK(feed(&r, w.b, w.n, msgs, lens, 3, got, 64) == 3 && got[0] == 0 && got[1] == 1 && got[2] == 2);
	CHECK(r.frames == 3 && r.dropped == 0);

	/* a byte lost, a byte changed, a byte added inside the second frame: only it is dropped */
	for (int mode = 0; mode < 3; mode++) {
		memset(&r, 0, sizeof r);
		w.n = 0;
		memcpy(w.b, f[0].b, f[0].n);
		w.n = f[0].n;
		size_t at = 100;
		memcpy(w.b + w.n, f[1].b, at);
		w.n += at;
		if (mode == 1)
			w.b[w.n++] = (uint8_t)(f[1].b[at] ^ 0x10u);
		else if (mode == 2)
			w.b[w.n++] = 0x55;
		memcpy(w.b + w.n, f[1].b + at + (mode == 2 ? 0 : 1), f[1].n - at - (mode == 2 ? 0 : 1));
		w.n += f[1].n - at - (mode == 2 ? 0 : 1);
		memcpy(w.b + w.n, f[2].b, f[2].n);
		w.n += f[2].n;
		CHECK(feed(&r, w.b, w.n, msgs, lens, 3, got, 64) == 2 && got[0] == 0 && got[1] == 2);
		CHECK(r.dropped == 1);
	}

	/* a lost END merges two frames: one frame dropped, the next one whole */
	memset(&r, 0, sizeof r);
	memcpy(w.b, f[0].b, f[0].n - 1);
	w.n = f[0].n - 1;
	memcpy(w.b + w.n, f[1].b, f[1].n);
	w.n += f[1].n;
	memcpy(w.b + w.n, f[2].b, f[2].n);
	w.n += f[2].n;
	CHECK(feed(&r, w.b, w.n, msgs, lens, 3, got, 64) == 1 && got[0] == 2 && r.dropped == 1);

	/* an invalid escape, a frame too short for its CRC, a frame longer than the buffer */
	memset(&r, 0, sizeof r);
	w.n = 0;
	const uint8_t bad[] = {0x01, SLIP_ESC, 0x07, 0x02, SLIP_END, 0x01, 0x02, SLIP_END};
	memcpy(w.b, bad, sizeof bad);
	w.n = sizeof bad;
	memset(w.b + w.n, 0x11, SLIP_RX_CAP + 10);
	w.n += SLIP_RX_CAP + 10;
	w.b[w.n++] = SLIP_END;
	memcpy(w.b + w.n, f[1].b, f[1].n);
	w.n += f[1].n;
	CHECK(feed(&r, w.b, w.n, msgs, lens, 3, got, 64) == 1 && got[0] == 1 && r.dropped == 3);

	/* random loss on a long stream: no spoilt frame is ever delivered, and each frame that
	 * lost no byte (nor the END before it) is delivered */
	srand(1);
	for (int trial = 0; trial < 200; trial++) {
		memset(&r, 0, sizeof r);
		w.n = 0;
		size_t whole = 0;
		bool prev_end_ok = true;
		for (int i = 0; i < 30; i++) {
			const struct wire *fi = &f[(size_t)rand() % 3];
			bool lost = false, end_ok = true;
			for (size_t j = 0; j < fi->n; j++) {
				if (rand() % 400 == 0) {
					lost = true;
					end_ok = j != fi->n - 1;
					continue;
				}
				w.b[w.n++] = fi->b[j];
			}
			if (!lost && prev_end_ok)
				whole++;
			prev_end_ok = end_ok;
		}
		size_t k = feed(&r, w.b, w.n, msgs, lens, 3, got, 64);
		bool all_known = true;
		for (size_t i = 0; i < k && i < 64; i++)
			all_known = all_known && got[i] >= 0;
		CHECK(all_known);
		CHECK(k == whole);
		CHECK(r.frames == k);
	}

	if (failures)
		return 1;
	printf("slip_test: all checks hold\n");
	return 0;
}
