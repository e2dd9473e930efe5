/*
 * slip.h - the framing of the plant and log links: each message travels as a SLIP frame
 * (RFC 1055: END 0xC0 after the frame, ESC 0xDB; END and ESC inside as ESC 0xDC, ESC 0xDD)
 * of the message followed by its CRC-32 (IEEE 802.3, as zlib's crc32) in little-endian
 * order. A lost, changed or added byte spoils only the frame it falls in: its CRC fails
 * (or an escape is invalid) and it is dropped; the next END starts a clean frame.
 */
#ifndef OCTO_MPS2_SLIP_H
#define OCTO_MPS2_SLIP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define SLIP_END 0xC0u
#define SLIP_ESC 0xDBu
#define SLIP_ESC_END 0xDCu
#define SLIP_ESC_ESC 0xDDu

uint32_t slip_crc32(uint32_t crc, const uint8_t *p, size_t n);

/* Encoder: bytes go to put(ctx, byte). begin, add (any number of times), end. */
struct slip_tx {
	void (*put)(void *ctx, uint8_t b);
	void *ctx;
	uint32_t crc;
};
void slip_tx_begin(struct slip_tx *t);
void slip_tx_add(struct slip_tx *t, const void *p, size_t n);
void slip_tx_end(struct slip_tx *t);

/* Decoder: one byte at a time; a complete frame whose CRC holds is left in buf[0..len). */
#define SLIP_RX_CAP 2100
struct slip_rx {
	uint8_t buf[SLIP_RX_CAP];
	size_t n;
	bool esc, bad;
	uint32_t frames, dropped; /* frames accepted; frames dropped (CRC, escape, length) */
};
/* Takes one byte; returns the message length (CRC removed) when it completed a good frame, else 0. */
size_t slip_rx_byte(struct slip_rx *r, uint8_t b);

#endif /* OCTO_MPS2_SLIP_H */
