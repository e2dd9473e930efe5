/* slip.c - SLIP frames with a CRC-32 (see slip.h). */
#include "slip.h"

/* CRC-32, reflected polynomial 0xEDB88320, four bits at a time (a 64-byte table). */
uint32_t slip_crc32(uint32_t crc, const uint8_t *p, size_t n)
{
	static const uint32_t tab[16] = {0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u,
					 0x4DB26158u, 0x5005713Cu, 0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
					 0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
	crc = ~crc;
	for (size_t i = 0; i < n; i++) {
		crc ^= p[i];
		crc = (crc >> 4) ^ tab[crc & 0xFu];
		crc = (crc >> 4) ^ tab[crc & 0xFu];
	}
	return ~crc;
}

static void put_escaped(struct slip_tx *t, uint8_t b)
{
	if (b == SLIP_END) {
		t->put(t->ctx, SLIP_ESC);
		t->put(t->ctx, SLIP_ESC_END);
	} else if (b == SLIP_ESC) {
		t->put(t->ctx, SLIP_ESC);
		t->put(t->ctx, SLIP_ESC_ESC);
	} else {
		t->put(t->ctx, b);
	}
}

void slip_tx_begin(struct slip_tx *t) { t->crc = 0; }

void slip_tx_add(struct slip_tx *t, const void *p, size_t n)
{
	const uint8_t *b = p;
	t->crc = slip_crc32(t->crc, b, n);
	for (size_t i = 0; i < n; i++)
		put_escaped(t, b[i]);
}

void slip_tx_end(struct slip_tx *t)
{
	for (int i = 0; i < 4; i++)
		put_escaped(t, (uint8_t)(t->crc >> (8 * i)));
	t->put(t->ctx, SLIP_END);
}

size_t slip_rx_byte(struct slip_rx *r, uint8_t b)
{
	if (b == SLIP_END) {
		size_t n = r->n;
		bool bad = r->bad || r->esc;
		r->n = 0;
		r->esc = r->bad = false;
		if (n == 0 && !bad)
			return 0; /* an END between frames (or the first one) */
		if (bad || n < 5) {
			r->dropped++;
			return 0;
		}
		uint32_t got = (uint32_t)r->buf[n - 4] | (uint32_t)r->buf[n - 3] << 8 | (uint32_t)r->buf[n - 2] << 16 |
			       (uint32_t)r->buf[n - 1] << 24;
		if (slip_crc32(0, r->buf, n - 4) != got) {
			r->dropped++;
			return 0;
		}
		r->frames++;
		return n - 4;
	}
	if (r->bad)
		return 0;
	if (r->esc) {
		r->esc = false;
		if (b == SLIP_ESC_END)
			b = SLIP_END;
		else if (b == SLIP_ESC_ESC)
			b = SLIP_ESC;
		else {
			r->bad = true;
			return 0;
		}
	} else if (b == SLIP_ESC) {
		r->esc = true;
		return 0;
	}
	if (r->n >= sizeof r->buf) {
		r->bad = true;
		return 0;
	}
	r->buf[r->n++] = b;
	return 0;
}
