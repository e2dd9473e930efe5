/*
 * line.h - a status line kept as its format and arguments, to be formatted later. The 90 Hz
 * step records what it has to say (no formatting: vsnprintf with %f costs more than a step on
 * a microcontroller) and the work between frames formats it: the experiment's queued lines
 * (experiment.h), a take-off's or landing's time limit (env_limits.h) and the app's own
 * lines of the step (app.h, struct app_said).
 */
#ifndef OCTO_APP_LINE_H
#define OCTO_APP_LINE_H

#include <stdarg.h>
#include <stddef.h>

#define LINE_ARGS 5
struct line {
	const char *fmt;          /* a literal: it outlives the line; NULL: no line */
	int sev;                  /* enum app_severity */
	char kind[LINE_ARGS + 1]; /* 'd' int, 's' string, 'f' double per argument */
	union {
		int i;
		const char *s; /* a literal, or text that outlives the line */
		double f;
	} arg[LINE_ARGS];
};

/* Records fmt and its arguments by fmt's conversions: %d, %s, %f %g %e (flags, width and
 * precision allowed); no others. */
void line_set(struct line *l, int sev, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
void line_vset(struct line *l, int sev, const char *fmt, va_list ap);
/* The line's text into out (cap bytes, cut there). */
void line_format(const struct line *l, char *out, size_t cap);

#endif /* OCTO_APP_LINE_H */
