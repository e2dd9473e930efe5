/*
 * params.h - the parameter table (params_table.h) as data: defaults, ranges,
 * get/set with checks, and the text format of the parameter file.
 */
#ifndef OCTO_PARAMS_H
#define OCTO_PARAMS_H

#include "alt_ctrl.h" /* ALT_CTRL_DEFAULT_*: defaults of the ALT_* rows */
#include "att_ctrl.h" /* ATT_CTRL_DEFAULT_*: defaults of the ATT_* rows */
#include "guidance.h" /* GUID_DEFAULT_*: defaults of NAV_TKO_VEL, NAV_LAND_VEL, NAV_TOUCH_DOWN_S */
#include "pos_ctrl.h" /* POS_CTRL_DEFAULT_*: defaults of POS_GAIN, POS_VEL_GAIN, ATT_TILT_MAX */
#include "thrmap.h"   /* THRMAP_CURVE_MIN/MAX: the range of MOT_CURVE */

#include <stddef.h>
#include <stdint.h>

#define PARAM_ID_LEN 16

struct app_params {
#define PARAM(name, field, def, min, max, unit, desc) float field;
#include "params_table.h"
#undef PARAM
};

/* Each parameter's index (the MAVLink index: the order of params_table.h), PX_<NAME>, for
 * the app's own reads and writes: resolved at compile time, never looked up by name in the
 * 90 Hz step. */
enum {
#define PARAM(name, field, def, min, max, unit, desc) PX_##name,
#include "params_table.h"
#undef PARAM
	PX_COUNT
};

/* Flags of a parameter (params_table.h sets them per group of rows). */
enum {
	PARAM_LOCKED = 1u << 0,   /* refused from outside while an experiment runs */
	PARAM_READONLY = 1u << 1, /* refused from outside always (identification results) */
};

struct param_def {
	const char *name;
	size_t offset;
	float def, min, max;
	const char *unit, *desc;
	unsigned flags; /* PARAM_LOCKED, PARAM_READONLY */
};

extern const struct param_def param_defs[];
extern const size_t param_count;

enum param_set_result { PARAM_OK = 0, PARAM_NOT_FINITE, PARAM_OUT_OF_RANGE };

void params_defaults(struct app_params *p);
/* Index of the parameter called `id` (at most 16 characters, NUL-terminated or
 * not, as in MAVLink's param_id), or -1. */
int params_find(const char *id, size_t id_len);
float params_get(const struct app_params *p, size_t index);
/* Writes the value if finite and within [min, max]; otherwise leaves it. */
enum param_set_result params_set(struct app_params *p, size_t index, float value);
const char *params_set_result_text(enum param_set_result r);

/* Shortest decimal text of v that reads back as exactly v (like "0.3"). */
int params_fmt_float(char *buf, size_t cap, float v);

/* The parameter file: one "NAME VALUE" line per parameter (MAVProxy's format;
 * '#' starts a comment). Returns the length written (without the NUL) or 0 if
 * cap is too small. */
size_t params_format(const struct app_params *p, char *buf, size_t cap);

/* Called for each damaged line: 1-based line number and the reason. */
typedef void (*params_report_fn)(void *ctx, unsigned line, const char *why);
/* Applies the lines of `text` to *p. A damaged line (unknown name, no number,
 * not finite, out of range, too long) is reported and changes nothing: the
 * value it meant keeps its previous (default) value. Returns the number of
 * damaged lines. */
unsigned params_parse(struct app_params *p, const char *text, size_t len, params_report_fn report, void *ctx);

#endif /* OCTO_PARAMS_H */
