/*
 * fuzz_sha256.h - the SHA-256 of MAVLink signing for the MAVLink fuzz harnesses, in place of
 * the library's (mavlink_sha256.h leaves its own out when HAVE_MAVLINK_SHA256 is defined).
 * fuzz.mk includes this header first in every file of those harnesses, so that the endpoint
 * and the harness's sender both sign and check with it.
 *
 * Same interface and results as the library's; the compression runs on the CPU's SHA
 * instructions where there are some (x86 SHA extensions), otherwise in portable C. Signing
 * hashes every message in and out: the library's rounds were the largest single cost of a
 * signed input. fuzz_sha256_selftest() checks both compressions against known digests.
 */
#ifndef OCTO_FUZZ_SHA256_H
#define OCTO_FUZZ_SHA256_H

#include <stdint.h>

#define HAVE_MAVLINK_SHA256 1

typedef struct {
	uint8_t block[64]; /* the bytes of the block being filled */
	uint32_t h[8];     /* the chaining state */
	uint32_t sz;       /* bytes hashed so far */
} mavlink_sha256_ctx;

void mavlink_sha256_init(mavlink_sha256_ctx *m);
void mavlink_sha256_update(mavlink_sha256_ctx *m, const void *v, uint32_t len);
/* the first 48 bits of the digest (MAVLink's signature) */
void mavlink_sha256_final_48(mavlink_sha256_ctx *m, uint8_t result[6]);

/* Aborts unless both compressions (the SHA instructions', when the CPU has them, and the
 * portable one) give the digests of FIPS 180-2's examples and agree on other inputs. */
void fuzz_sha256_selftest(void);

#endif
