/*
 * fuzz_params.c - libFuzzer harness of params_parse (the parameter-file parser).
 *
 * Input: the text of a parameter file. Checks beyond "no crash, no UB":
 *   - every parameter stays finite and inside its [min, max];
 *   - the result formats (params_format) and parses back to the same values
 *     with no damaged line.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "params.h"

static unsigned reports;
static void report(void *ctx, unsigned line, const char *why)
{
	(void)ctx;
	(void)line;
	(void)strlen(why);
	reports++;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct app_params p, q;
	params_defaults(&p);
	/* the parser is handed the buffer without a terminating NUL */
	char *text = malloc(size ? size : 1);
	if (!text)
		return 0;
	memcpy(text, data, size);
	reports = 0;
	unsigned bad = params_parse(&p, text, size, report, NULL);
	free(text);
	if (bad != reports)
		abort();
	for (size_t i = 0; i < param_count; i++) {
		float v = params_get(&p, i);
		if (!isfinite(v) || v < param_defs[i].min || v > param_defs[i].max)
			abort();
	}
	static char buf[8192];
	size_t n = params_format(&p, buf, sizeof buf);
	if (!n)
		abort();
	params_defaults(&q);
	if (params_parse(&q, buf, n, NULL, NULL) != 0)
		abort();
	for (size_t i = 0; i < param_count; i++)
		if (params_get(&p, i) != params_get(&q, i))
			abort();
	return 0;
}
