/* line.c - see line.h. */
#include "line.h"

#include <stdio.h>
#include <string.h>

void line_vset(struct line *l, int sev, const char *fmt, va_list ap)
{
	l->fmt = fmt;
	l->sev = sev;
	unsigned n = 0;
	for (const char *c = strchr(fmt, '%'); c && n < LINE_ARGS; c = strchr(c, '%')) {
		c++; /* the conversion's flags, width, precision and letter */
		while (*c == '+' || *c == '-' || *c == ' ' || *c == '#' || *c == '.' || (*c >= '0' && *c <= '9'))
			c++;
		if (*c == 'd') {
			l->kind[n] = 'd';
			l->arg[n++].i = va_arg(ap, int);
		} else if (*c == 's') {
			l->kind[n] = 's';
			l->arg[n++].s = va_arg(ap, const char *);
		} else if (*c == 'f' || *c == 'g' || *c == 'e') { /* doubles, formatted by fmt */
			l->kind[n] = 'f';
			l->arg[n++].f = va_arg(ap, double);
		} else if (!*c) {
			break;
		}
		c++;
	}
	l->kind[n] = 0;
}

void line_set(struct line *l, int sev, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	line_vset(l, sev, fmt, ap);
	va_end(ap);
}

#define ARG_D(k) (l->arg[k].i)
#define ARG_S(k) (l->arg[k].s)
#define ARG_F(k) (l->arg[k].f)

/* one case per argument pattern of the lines recorded */
void line_format(const struct line *l, char *out, size_t cap)
{
	const char *k = l->kind;
	if (!l->fmt) {
		if (cap)
			out[0] = 0;
		return;
	}
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
	if (!strcmp(k, ""))
		snprintf(out, cap, "%s", l->fmt);
	else if (!strcmp(k, "dds"))
		snprintf(out, cap, l->fmt, ARG_D(0), ARG_D(1), ARG_S(2));
	else if (!strcmp(k, "ffss"))
		snprintf(out, cap, l->fmt, ARG_F(0), ARG_F(1), ARG_S(2), ARG_S(3));
	else if (!strcmp(k, "ff"))
		snprintf(out, cap, l->fmt, ARG_F(0), ARG_F(1));
	else if (!strcmp(k, "ffs"))
		snprintf(out, cap, l->fmt, ARG_F(0), ARG_F(1), ARG_S(2));
	else if (!strcmp(k, "fsf"))
		snprintf(out, cap, l->fmt, ARG_F(0), ARG_S(1), ARG_F(2));
	else if (!strcmp(k, "sffss"))
		snprintf(out, cap, l->fmt, ARG_S(0), ARG_F(1), ARG_F(2), ARG_S(3), ARG_S(4));
	else if (!strcmp(k, "sff"))
		snprintf(out, cap, l->fmt, ARG_S(0), ARG_F(1), ARG_F(2));
	else if (!strcmp(k, "ffd"))
		snprintf(out, cap, l->fmt, ARG_F(0), ARG_F(1), ARG_D(2));
	else if (!strcmp(k, "d"))
		snprintf(out, cap, l->fmt, ARG_D(0));
	else if (!strcmp(k, "dd"))
		snprintf(out, cap, l->fmt, ARG_D(0), ARG_D(1));
	else if (!strcmp(k, "f"))
		snprintf(out, cap, l->fmt, ARG_F(0));
	else if (!strcmp(k, "s"))
		snprintf(out, cap, l->fmt, ARG_S(0));
	else if (!strcmp(k, "ss"))
		snprintf(out, cap, l->fmt, ARG_S(0), ARG_S(1));
	else if (!strcmp(k, "df"))
		snprintf(out, cap, l->fmt, ARG_D(0), ARG_F(1));
	else if (!strcmp(k, "ddf"))
		snprintf(out, cap, l->fmt, ARG_D(0), ARG_D(1), ARG_F(2));
	else if (!strcmp(k, "ssf"))
		snprintf(out, cap, l->fmt, ARG_S(0), ARG_S(1), ARG_F(2));
	else if (!strcmp(k, "sfff"))
		snprintf(out, cap, l->fmt, ARG_S(0), ARG_F(1), ARG_F(2), ARG_F(3));
	else if (!strcmp(k, "sffff"))
		snprintf(out, cap, l->fmt, ARG_S(0), ARG_F(1), ARG_F(2), ARG_F(3), ARG_F(4));
	else if (!strcmp(k, "fff"))
		snprintf(out, cap, l->fmt, ARG_F(0), ARG_F(1), ARG_F(2));
	else if (!strcmp(k, "ffff"))
		snprintf(out, cap, l->fmt, ARG_F(0), ARG_F(1), ARG_F(2), ARG_F(3));
	else
		snprintf(out, cap, "line with arguments %s", k); /* a new pattern: add a case */
#pragma GCC diagnostic pop
}
