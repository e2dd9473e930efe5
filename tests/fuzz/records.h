/*
 * records.h - the framing the X-Plane fuzz harnesses share: the input is a sequence of
 * records [ctrl:1][len:2 LE][bytes:len], the last one cut to what is left. ctrl carries
 * each harness's own choices (sender, port, time step, emit or not).
 */
#ifndef OCTO_FUZZ_RECORDS_H
#define OCTO_FUZZ_RECORDS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* The record at *pos: its control byte, its bytes and their length; *pos moves past it.
 * False when fewer than 3 bytes are left. */
static inline bool fuzz_next_record(const uint8_t *data, size_t size, size_t *pos, uint8_t *ctrl, const uint8_t **bytes,
				    size_t *len)
{
	if (*pos + 3 > size)
		return false;
	*ctrl = data[*pos];
	size_t n = (size_t)data[*pos + 1] | (size_t)data[*pos + 2] << 8;
	*pos += 3;
	if (n > size - *pos)
		n = size - *pos;
	*bytes = data + *pos;
	*len = n;
	*pos += n;
	return true;
}

#endif
