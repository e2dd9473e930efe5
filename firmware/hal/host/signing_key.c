/* signing_key.c - the --signing-key file rule, shared with octo-gcs and MAVProxy. */
#include "host.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <common/mavlink.h>

static int hexval(int c)
{
	if (c >= '0' && c <= '9')
		return c - '0';
	if (c >= 'a' && c <= 'f')
		return c - 'a' + 10;
	if (c >= 'A' && c <= 'F')
		return c - 'A' + 10;
	return -1;
}

/* --signing-key FILE, the rule of octo-gcs (and MAVProxy's passphrase): the
 * file's text with surrounding white space stripped (as Python's bytes.strip:
 * space, \t \n \v \f \r); exactly 64 hex digits are the key itself, anything
 * else is a passphrase and the key is its sha256. An empty file is an error. */
static bool key_space(uint8_t c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

int signing_key_load(const char *path, uint8_t key[32])
{
	FILE *f = fopen(path, "rb");
	if (!f) {
		fprintf(stderr, "octo-fw: --signing-key: cannot open %s: %s\n", path, strerror(errno));
		return -1;
	}
	enum { KEY_FILE_MAX = 65536 };
	uint8_t *buf = malloc(KEY_FILE_MAX);
	if (!buf) {
		fclose(f);
		fprintf(stderr, "octo-fw: --signing-key: out of memory\n");
		return -1;
	}
	size_t n = fread(buf, 1, KEY_FILE_MAX, f);
	bool more = fgetc(f) != EOF;
	fclose(f);
	if (more) {
		fprintf(stderr, "octo-fw: --signing-key: %s is longer than %d bytes\n", path, KEY_FILE_MAX);
		free(buf);
		return -1;
	}
	size_t a = 0, b = n;
	while (a < b && key_space(buf[a]))
		a++;
	while (b > a && key_space(buf[b - 1]))
		b--;
	if (a == b) {
		fprintf(stderr, "octo-fw: --signing-key: %s is empty\n", path);
		free(buf);
		return -1;
	}
	bool hex = b - a == 64;
	for (size_t i = a; i < b && hex; i++)
		hex = hexval(buf[i]) >= 0;
	if (hex) {
		for (size_t i = 0; i < 32; i++)
			key[i] = (uint8_t)(hexval(buf[a + 2 * i]) << 4 | hexval(buf[a + 2 * i + 1]));
	} else {
		/* sha256 with MAVLink's own implementation: after final_48 the whole
		 * digest is in the counters (big-endian words) */
		mavlink_sha256_ctx ctx;
		uint8_t first6[6];
		mavlink_sha256_init(&ctx);
		mavlink_sha256_update(&ctx, buf + a, (uint32_t)(b - a));
		mavlink_sha256_final_48(&ctx, first6);
		for (int w = 0; w < 8; w++)
			for (int k = 0; k < 4; k++)
				key[4 * w + k] = (uint8_t)(ctx.counter[w] >> (24 - 8 * k));
	}
	free(buf);
	return 0;
}
