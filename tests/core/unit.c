/* unit.c - runner for the C unit tests; see unit.h. */
#include "unit.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#define UNIT_ENTRY(name) void unit_test_##name(struct unit_ctx *u);
#include "unit_list.h"
#undef UNIT_ENTRY

struct unit_entry {
	const char *name;
	void (*fn)(struct unit_ctx *);
};

static const struct unit_entry unit_entries[] = {
#define UNIT_ENTRY(name) {#name, unit_test_##name},
#include "unit_list.h"
#undef UNIT_ENTRY
	{NULL, NULL}};

void unit_fail(struct unit_ctx *u, const char *file, int line, const char *fmt, ...)
{
	if (u->failures++ == 0) {
		int n = snprintf(u->first, sizeof u->first, "%s:%d: ", file, line);
		if (n < 0 || (size_t)n >= sizeof u->first)
			n = 0;
		va_list ap;
		va_start(ap, fmt);
		vsnprintf(u->first + n, sizeof u->first - (size_t)n, fmt, ap);
		va_end(ap);
	}
}

bool unit_near(double a, double b, double tol)
{
	if (isnan(a) || isnan(b))
		return false;
	return fabs(a - b) <= tol;
}

double unit_rand_uniform(struct unit_rng *r, double lo, double hi)
{
	r->s ^= r->s >> 12;
	r->s ^= r->s << 25;
	r->s ^= r->s >> 27;
	unsigned long long x = r->s * 2685821657736338717ULL;
	return lo + (hi - lo) * (double)(x >> 11) * (1.0 / 9007199254740992.0);
}

double unit_rand_normal(struct unit_rng *r)
{
	double u1 = unit_rand_uniform(r, 1e-300, 1.0), u2 = unit_rand_uniform(r, 0.0, 1.0);
	return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

static int selected(const char *name, int argc, char **argv)
{
	if (argc <= 1)
		return 1;
	for (int i = 1; i < argc; i++)
		if (strstr(name, argv[i]))
			return 1;
	return 0;
}

int main(int argc, char **argv)
{
	int passed = 0, failed = 0;
	for (const struct unit_entry *e = unit_entries; e->name; e++) {
		if (!selected(e->name, argc, argv))
			continue;
		struct unit_ctx u = {.name = e->name, .failures = 0, .first = ""};
		e->fn(&u);
		if (u.failures) {
			failed++;
			printf("FAIL %s: %s (%d failed checks)\n", e->name, u.first, u.failures);
		} else {
			passed++;
		}
	}
	printf("%d passed, %d failed\n", passed, failed);
	fflush(stdout);
	return failed > 100 ? 100 : failed;
}
