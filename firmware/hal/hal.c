/* hal.c - the helpers of hal.h that are not plain forwards: a formatted report, a RAM parameter store. */
#include "hal.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

void hal_reportf(const struct hal *h, const char *fmt, ...)
{
	char line[256];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(line, sizeof line, fmt, ap);
	va_end(ap);
	h->report(h->ctx, line);
}

int hal_ram_param_put(char *buf, size_t cap, long *len, const char *text, size_t n)
{
	if (n >= cap)
		return -1;
	memcpy(buf, text, n);
	buf[n] = 0;
	*len = (long)n;
	return 0;
}

long hal_ram_param_get(const char *buf, long len, char *out, size_t out_cap)
{
	if (len < 0 || out_cap == 0)
		return -1;
	size_t n = (size_t)len < out_cap - 1 ? (size_t)len : out_cap - 1;
	memcpy(out, buf, n);
	out[n] = 0;
	return (long)n;
}
