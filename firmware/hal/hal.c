/* hal.c - the one helper of hal.h that is not a plain forward: formatted report. */
#include "hal.h"

#include <stdarg.h>
#include <stdio.h>

void hal_reportf(const struct hal *h, const char *fmt, ...)
{
	char line[256];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(line, sizeof line, fmt, ap);
	va_end(ap);
	h->report(h->ctx, line);
}
