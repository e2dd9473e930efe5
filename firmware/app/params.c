/* params.c - the parameter table as data (see params.h). */
#include "params.h"

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const struct param_def param_defs[] = {
#define PARAM(name, field, def, min, max, unit, desc) \
	{#name, offsetof(struct app_params, field), def, min, max, unit, desc, PARAM_FLAGS},
#include "params_table.h"
#undef PARAM
};
const size_t param_count = sizeof param_defs / sizeof param_defs[0];

/* Compile-time checks: names fit MAVLink's 16 characters, defaults are in range. */
#define PARAM(name, field, def, min, max, unit, desc)                                        \
	_Static_assert(sizeof(#name) - 1 <= PARAM_ID_LEN, #name " is longer than 16 chars"); \
	_Static_assert((def) >= (min) && (def) <= (max), #name " default out of range");
#include "params_table.h"
#undef PARAM

static float *slot(struct app_params *p, size_t i) { return (float *)(void *)((char *)p + param_defs[i].offset); }

void params_defaults(struct app_params *p)
{
	for (size_t i = 0; i < param_count; i++)
		*slot(p, i) = param_defs[i].def;
}

int params_find(const char *id, size_t id_len)
{
	size_t n = 0;
	while (n < id_len && n < PARAM_ID_LEN && id[n])
		n++;
	if (n == 0)
		return -1;
	/* character by character, most names rejected at their first: the app looks names up
	 * in its 90 Hz step (the tracker's KFT_* once a second), where a strlen per entry cost
	 * more than the rest of the step */
	for (size_t i = 0; i < param_count; i++) {
		const char *s = param_defs[i].name;
		size_t k = 0;
		while (k < n && s[k] == id[k])
			k++;
		if (k == n && s[n] == '\0')
			return (int)i;
	}
	return -1;
}

float params_get(const struct app_params *p, size_t index)
{
	if (index >= param_count)
		return NAN;
	return *(const float *)(const void *)((const char *)p + param_defs[index].offset);
}

enum param_set_result params_set(struct app_params *p, size_t index, float value)
{
	if (index >= param_count || !isfinite(value))
		return PARAM_NOT_FINITE;
	if (value < param_defs[index].min || value > param_defs[index].max)
		return PARAM_OUT_OF_RANGE;
	*slot(p, index) = value;
	return PARAM_OK;
}

const char *params_set_result_text(enum param_set_result r)
{
	switch (r) {
	case PARAM_OK: return "ok";
	case PARAM_NOT_FINITE: return "not a finite number";
	case PARAM_OUT_OF_RANGE: return "out of range";
	}
	return "?";
}

int params_fmt_float(char *buf, size_t cap, float v)
{
	int n = 0;
	for (int prec = 6; prec <= 9; prec++) {
		n = snprintf(buf, cap, "%.*g", prec, (double)v);
		if (n < 0 || (size_t)n >= cap || strtof(buf, NULL) == v)
			break;
	}
	return n;
}

size_t params_format(const struct app_params *p, char *buf, size_t cap)
{
	size_t len = 0;
	for (size_t i = 0; i < param_count; i++) {
		char num[32];
		params_fmt_float(num, sizeof num, params_get(p, i));
		int n = snprintf(buf + len, cap - len, "%-16s %s\n", param_defs[i].name, num);
		if (n < 0 || (size_t)n >= cap - len)
			return 0;
		len += (size_t)n;
	}
	return len;
}

unsigned params_parse(struct app_params *p, const char *text, size_t len, params_report_fn report, void *ctx)
{
	unsigned bad = 0, line_no = 0;
	size_t pos = 0;
	/* the table entry after the last line's: a file params_format wrote lists the table in
	 * order, so that each name is found at its first comparison, without a search */
	size_t next = 0;
	while (pos < len) {
		size_t end = pos;
		while (end < len && text[end] != '\n')
			end++;
		line_no++;
		char line[128];
		size_t ll = end - pos;
		const char *why = NULL;
		bool binary = false;
		for (size_t k = pos; k < end; k++) {
			unsigned char ch = (unsigned char)text[k];
			if ((ch < 32 && ch != '\t' && ch != '\r') || ch > 126)
				binary = true;
		}
		if (ll >= sizeof line) {
			why = "line too long";
		} else if (binary) {
			why = "not a text line";
		} else {
			memcpy(line, text + pos, ll);
			line[ll] = 0;
			char *hash = strchr(line, '#');
			if (hash)
				*hash = 0;
			for (char *c = line; *c; c++)
				if (*c == ',' || *c == '\t' || *c == '\r')
					*c = ' ';
			char name[PARAM_ID_LEN + 2] = {0}, rest[64] = {0};
			char *save = NULL, *tok = strtok_r(line, " ", &save);
			if (!tok)
				goto next; /* blank or comment */
			if (strlen(tok) > PARAM_ID_LEN) {
				why = "name longer than 16 characters";
				goto done;
			}
			memcpy(name, tok, strlen(tok));
			char *val = strtok_r(NULL, " ", &save);
			char *extra = strtok_r(NULL, " ", &save);
			int idx = next < param_count && !strcmp(param_defs[next].name, name)
					  ? (int)next
					  : params_find(name, sizeof name);
			if (idx >= 0)
				next = (size_t)idx + 1;
			if (idx < 0) {
				why = "unknown parameter";
			} else if (!val || extra) {
				why = "expected NAME VALUE";
			} else {
				snprintf(rest, sizeof rest, "%s", val);
				char *e = NULL;
				float v = strtof(rest, &e);
				if (e == rest || *e)
					why = "value is not a number";
				else if (params_set(p, (size_t)idx, v) != PARAM_OK)
					why = params_set_result_text(params_set(p, (size_t)idx, v));
			}
		}
	done:
		if (why) {
			bad++;
			if (report)
				report(ctx, line_no, why);
		}
	next:
		pos = end + 1;
	}
	return bad;
}
