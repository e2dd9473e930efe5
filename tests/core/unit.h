/*
 * unit.h - the project's C unit-test harness (host and emulated Cortex-M).
 *
 *   UNIT_TEST(mixer_pinv_identity) { CHECK(x == 1); CHECK_NEAR(a, b, 1e-6); }
 *
 * Tests live in tests/core/test_<module>.c; build/gen/unit_list.h is generated
 * from the UNIT_TEST lines, so a new test needs no registration by hand. The
 * runner (unit.c) prints one line per failed test and the closing line
 * "N passed, M failed"; its exit status is the number of failed tests (capped).
 * `unit-tests NAME...` runs only tests whose name contains one of the NAMEs.
 *
 * Test code is not firmware: it may use double and libc freely.
 */
#ifndef OCTO_UNIT_H
#define OCTO_UNIT_H

#include <stdbool.h>

struct unit_ctx {
	const char *name;
	int failures;    /* failed checks in the current test */
	char first[256]; /* message of the first failed check */
};

#define UNIT_TEST(name) void unit_test_##name(struct unit_ctx *u)

void unit_fail(struct unit_ctx *u, const char *file, int line, const char *fmt, ...)
	__attribute__((format(printf, 4, 5)));
bool unit_near(double a, double b, double tol);

#define CHECK(cond)                                                           \
	do {                                                                  \
		if (!(cond))                                                  \
			unit_fail(u, __FILE__, __LINE__, "CHECK(%s)", #cond); \
	} while (0)

/* |a - b| <= tol (absolute) */
#define CHECK_NEAR(a, b, tol)                                                                                          \
	do {                                                                                                           \
		double a_ = (double)(a), b_ = (double)(b), t_ = (double)(tol);                                         \
		if (!unit_near(a_, b_, t_))                                                                            \
			unit_fail(u, __FILE__, __LINE__, "CHECK_NEAR(%s, %s): %.9g vs %.9g, tol %.3g", #a, #b, a_, b_, \
				  t_);                                                                                 \
	} while (0)

/* |a - b| <= rel * max(|a|, |b|, 1e-30) */
#define CHECK_REL(a, b, rel)                                                                                          \
	do {                                                                                                          \
		double a_ = (double)(a), b_ = (double)(b), r_ = (double)(rel);                                        \
		double m_ = (a_ < 0 ? -a_ : a_) > (b_ < 0 ? -b_ : b_) ? (a_ < 0 ? -a_ : a_) : (b_ < 0 ? -b_ : b_);    \
		if (!unit_near(a_, b_, r_ * (m_ > 1e-30 ? m_ : 1e-30)))                                               \
			unit_fail(u, __FILE__, __LINE__, "CHECK_REL(%s, %s): %.9g vs %.9g, rel %.3g", #a, #b, a_, b_, \
				  r_);                                                                                \
	} while (0)

/* Trials of a random-truth sweep: n on the host, 2 on emulated Cortex-M (make arm), where
 * each costs seconds. */
#if defined(__arm__)
#define TRIALS(n) 2
#else
#define TRIALS(n) (n)
#endif

/* Deterministic test randomness (xorshift64*), seeded per test by the runner. */
struct unit_rng {
	unsigned long long s;
};
double unit_rand_uniform(struct unit_rng *r, double lo, double hi);
double unit_rand_normal(struct unit_rng *r);

#endif
