/* fuzz_sha256.c - SHA-256 (FIPS 180-2) for the MAVLink fuzz harnesses: see fuzz_sha256.h. */
#include "fuzz_sha256.h"

#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#include <immintrin.h>
#define FUZZ_SHA_X86 1
#endif

static const uint32_t K[64] = {
	0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
	0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
	0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
	0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
	0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
	0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
	0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
	0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2,
};

static uint32_t rotr(uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }

static void compress_c(uint32_t h[8], const uint8_t b[64])
{
	uint32_t w[64];
	for (int i = 0; i < 16; i++)
		w[i] = (uint32_t)b[4 * i] << 24 | (uint32_t)b[4 * i + 1] << 16 | (uint32_t)b[4 * i + 2] << 8 |
		       (uint32_t)b[4 * i + 3];
	for (int i = 16; i < 64; i++) {
		uint32_t s0 = rotr(w[i - 15], 7) ^ rotr(w[i - 15], 18) ^ (w[i - 15] >> 3);
		uint32_t s1 = rotr(w[i - 2], 17) ^ rotr(w[i - 2], 19) ^ (w[i - 2] >> 10);
		w[i] = w[i - 16] + s0 + w[i - 7] + s1;
	}
	uint32_t a = h[0], bb = h[1], c = h[2], d = h[3], e = h[4], f = h[5], g = h[6], hh = h[7];
	for (int i = 0; i < 64; i++) {
		uint32_t t1 = hh + (rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25)) + ((e & f) ^ (~e & g)) + K[i] + w[i];
		uint32_t t2 = (rotr(a, 2) ^ rotr(a, 13) ^ rotr(a, 22)) + ((a & bb) ^ (a & c) ^ (bb & c));
		hh = g;
		g = f;
		f = e;
		e = d + t1;
		d = c;
		c = bb;
		bb = a;
		a = t1 + t2;
	}
	h[0] += a;
	h[1] += bb;
	h[2] += c;
	h[3] += d;
	h[4] += e;
	h[5] += f;
	h[6] += g;
	h[7] += hh;
}

#ifdef FUZZ_SHA_X86
/* The SHA extensions keep the state as ABEF and CDGH and take four schedule words (plus
 * their constants) per pair of sha256rnds2; the schedule is a ring of four vectors. */
#define FUZZ_SHA_ROUNDS(g, w)                                                                               \
	do {                                                                                                \
		__m128i m_ = _mm_add_epi32(w, _mm_loadu_si128((const __m128i *)(const void *)&K[4 * (g)])); \
		st1 = _mm_sha256rnds2_epu32(st1, st0, m_);                                                  \
		st0 = _mm_sha256rnds2_epu32(st0, st1, _mm_shuffle_epi32(m_, 0x0E));                         \
	} while (0)
/* w0 <- the next four schedule words from the last sixteen (w0, w1, w2, w3 oldest first) */
#define FUZZ_SHA_NEXT(w0, w1, w2, w3) \
	w0 = _mm_sha256msg2_epu32(_mm_add_epi32(_mm_sha256msg1_epu32(w0, w1), _mm_alignr_epi8(w3, w2, 4)), w3)

__attribute__((target("sha,ssse3,sse4.1"))) static void compress_ni(uint32_t h[8], const uint8_t b[64])
{
	const __m128i bswap = _mm_set_epi64x(0x0c0d0e0f08090a0bll, 0x0405060700010203ll);
	__m128i tmp = _mm_shuffle_epi32(_mm_loadu_si128((const __m128i *)(const void *)&h[0]), 0xB1); /* CDAB */
	__m128i st1 = _mm_shuffle_epi32(_mm_loadu_si128((const __m128i *)(const void *)&h[4]), 0x1B); /* EFGH */
	__m128i st0 = _mm_alignr_epi8(tmp, st1, 8);                                                   /* ABEF */
	st1 = _mm_blend_epi16(st1, tmp, 0xF0);                                                        /* CDGH */
	const __m128i abef = st0, cdgh = st1;
	__m128i w0 = _mm_shuffle_epi8(_mm_loadu_si128((const __m128i *)(const void *)(b + 0)), bswap);
	__m128i w1 = _mm_shuffle_epi8(_mm_loadu_si128((const __m128i *)(const void *)(b + 16)), bswap);
	__m128i w2 = _mm_shuffle_epi8(_mm_loadu_si128((const __m128i *)(const void *)(b + 32)), bswap);
	__m128i w3 = _mm_shuffle_epi8(_mm_loadu_si128((const __m128i *)(const void *)(b + 48)), bswap);
	FUZZ_SHA_ROUNDS(0, w0);
	FUZZ_SHA_ROUNDS(1, w1);
	FUZZ_SHA_ROUNDS(2, w2);
	FUZZ_SHA_ROUNDS(3, w3);
	for (int g = 4; g < 16; g += 4) {
		FUZZ_SHA_NEXT(w0, w1, w2, w3);
		FUZZ_SHA_ROUNDS(g, w0);
		FUZZ_SHA_NEXT(w1, w2, w3, w0);
		FUZZ_SHA_ROUNDS(g + 1, w1);
		FUZZ_SHA_NEXT(w2, w3, w0, w1);
		FUZZ_SHA_ROUNDS(g + 2, w2);
		FUZZ_SHA_NEXT(w3, w0, w1, w2);
		FUZZ_SHA_ROUNDS(g + 3, w3);
	}
	st0 = _mm_add_epi32(st0, abef);
	st1 = _mm_add_epi32(st1, cdgh);
	tmp = _mm_shuffle_epi32(st0, 0x1B);    /* FEBA */
	st1 = _mm_shuffle_epi32(st1, 0xB1);    /* DCHG */
	st0 = _mm_blend_epi16(tmp, st1, 0xF0); /* DCBA */
	st1 = _mm_alignr_epi8(st1, tmp, 8);    /* HGFE */
	_mm_storeu_si128((__m128i *)(void *)&h[0], st0);
	_mm_storeu_si128((__m128i *)(void *)&h[4], st1);
}

static int have_ni(void)
{
	static int have = -1;
	if (have < 0) {
		unsigned a, b, c, d;
		/* leaf 1: SSSE3 (ecx 9) and SSE4.1 (ecx 19); leaf 7: SHA (ebx 29) */
		have = __get_cpuid(1, &a, &b, &c, &d) && (c >> 9 & 1) && (c >> 19 & 1) &&
		       __get_cpuid_count(7, 0, &a, &b, &c, &d) && (b >> 29 & 1);
	}
	return have;
}
#endif

/* 0: the SHA instructions when the CPU has them, 1: portable C (the self-test's choice) */
static int force_c;

static void compress(uint32_t h[8], const uint8_t b[64])
{
#ifdef FUZZ_SHA_X86
	if (!force_c && have_ni()) {
		compress_ni(h, b);
		return;
	}
#endif
	compress_c(h, b);
}

void mavlink_sha256_init(mavlink_sha256_ctx *m)
{
	static const uint32_t h0[8] = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
				       0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
	memcpy(m->h, h0, sizeof h0);
	m->sz = 0;
}

void mavlink_sha256_update(mavlink_sha256_ctx *m, const void *v, uint32_t len)
{
	const uint8_t *p = v;
	uint32_t off = m->sz % 64;
	m->sz += len;
	while (len > 0) {
		uint32_t l = 64 - off < len ? 64 - off : len;
		for (uint32_t i = 0; i < l; i++)
			m->block[off + i] = p[i];
		off += l;
		p += l;
		len -= l;
		if (off == 64) {
			compress(m->h, m->block);
			off = 0;
		}
	}
}

static void final(mavlink_sha256_ctx *m)
{
	uint32_t off = m->sz % 64;
	uint64_t bits = (uint64_t)m->sz * 8u;
	m->block[off++] = 0x80;
	if (off > 56) {
		memset(m->block + off, 0, 64 - off);
		compress(m->h, m->block);
		off = 0;
	}
	memset(m->block + off, 0, 56 - off);
	for (int i = 0; i < 8; i++)
		m->block[56 + i] = (uint8_t)(bits >> (56 - 8 * i));
	compress(m->h, m->block);
}

void mavlink_sha256_final_48(mavlink_sha256_ctx *m, uint8_t result[6])
{
	final(m);
	for (int i = 0; i < 6; i++)
		result[i] = (uint8_t)(m->h[i / 4] >> (24 - 8 * (i % 4)));
}

static void digest(const void *p, uint32_t n, uint32_t h[8])
{
	mavlink_sha256_ctx c;
	mavlink_sha256_init(&c);
	mavlink_sha256_update(&c, p, n);
	final(&c);
	memcpy(h, c.h, sizeof c.h);
}

void fuzz_sha256_selftest(void)
{
	static const uint32_t abc[8] = {0xba7816bf, 0x8f01cfea, 0x414140de, 0x5dae2223,
					0xb00361a3, 0x96177a9c, 0xb410ff61, 0xf20015ad};
	static const uint32_t two[8] = {0x248d6a61, 0xd20638b8, 0xe5c02693, 0x0c3e6039,
					0xa33ce459, 0x64ff2167, 0xf6ecedd4, 0x19db06c1};
	static const char two_text[] = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
	uint8_t buf[300];
	for (size_t i = 0; i < sizeof buf; i++)
		buf[i] = (uint8_t)(i * 131u + 7u);
	uint32_t h[8], ref[8];
	for (int mode = 1; mode >= 0; mode--) {
		force_c = mode;
		digest("abc", 3, h);
		if (memcmp(h, abc, sizeof h))
			abort();
		digest(two_text, sizeof two_text - 1, h);
		if (memcmp(h, two, sizeof h))
			abort();
	}
	/* every length across the block and padding boundaries, both compressions alike */
	for (uint32_t n = 0; n <= sizeof buf; n++) {
		force_c = 1;
		digest(buf, n, ref);
		force_c = 0;
		digest(buf, n, h);
		if (memcmp(h, ref, sizeof h))
			abort();
	}
}
