/* param_meta.c - prints the parameter metadata file (the JSON QGroundControl reads,
 * parameter.schema.json: per row name, type, shortDesc, units, default, min, max and
 * group) for the parameter table linked with it (firmware/app/params.c).
 *
 * A build tool, run on the host: gen_param_metadata.py compresses its output into
 * the constant data that mav_ftp.c serves. Numbers are params_fmt_float's shortest
 * text, the same as octo-fw --dump-params gives. */
#include <stdio.h>
#include <string.h>

#include "params.h"

static void put_str(const char *s)
{
	putchar('"');
	for (; *s; s++) {
		unsigned char c = (unsigned char)*s;
		if (c == '"' || c == '\\')
			printf("\\%c", c);
		else if (c < 0x20)
			printf("\\u%04x", c);
		else
			putchar(c);
	}
	putchar('"');
}

int main(void)
{
	printf("{\"version\": 1, \"parameters\": [");
	for (size_t i = 0; i < param_count; i++) {
		const struct param_def *d = &param_defs[i];
		char def[32], min[32], max[32], group[PARAM_ID_LEN + 1];
		params_fmt_float(def, sizeof def, d->def);
		params_fmt_float(min, sizeof min, d->min);
		params_fmt_float(max, sizeof max, d->max);
		/* the group is the name's prefix, as in VEH_KF -> VEH */
		size_t g = strcspn(d->name, "_");
		if (g > PARAM_ID_LEN)
			g = PARAM_ID_LEN;
		memcpy(group, d->name, g);
		group[g] = 0;
		printf("%s\n{\"name\": ", i ? "," : "");
		put_str(d->name);
		printf(", \"type\": \"Float\", \"shortDesc\": ");
		put_str(d->desc);
		printf(", \"units\": ");
		put_str(d->unit);
		printf(", \"default\": %s, \"min\": %s, \"max\": %s, \"group\": ", def, min, max);
		put_str(group);
		printf("}");
	}
	printf("\n]}\n");
	return ferror(stdout) ? 1 : 0;
}
