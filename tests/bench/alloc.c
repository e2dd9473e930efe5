/*
 * alloc.c - allocation quality of the core's mixer, for `make bench`.
 *
 *   bench-alloc [N [SEED]]      (default 20000 demands, seed 1)
 *
 * Mixer: mixer_default_params() (the paper's vehicle: l 0.35 m, k_f 28.0269 N,
 * k_tau 0.3869 N m, throttle [0, 1], eight rotors), once with MIXER_MODE_PRIORITY (the
 * box-constrained allocator) and once with MIXER_MODE_CLIP (pseudo-inverse plus clipping,
 * the baseline), on the same seeded demands around hover:
 *   f     = m g (1 + 0.6 u0)                     (8.4 ... 33.4 N; hover 20.9 N)
 *   tau_x = 2.0 u1,  tau_y = 2.0 u2 (N m)         (full authority at hover ~ 5.9 N m)
 *   tau_z = 0.25 u3 (N m)                          (full yaw at hover ~ 0.29 N m)
 * with u uniform in [-1, 1] (xorshift64*). Attainable: inside the attainable set
 * Gamma [f_lo, f_hi]^8 with a margin (mixer_attainable, tol -1e-4 in scaled units);
 * unattainable: outside with the same margin (tol +1e-4); the thin band between is counted
 * apart. "Exact": |achieved - demanded| <= 1e-3 N on thrust, 1e-3 N m on roll and pitch,
 * 1e-4 N m on yaw (the header's documented float accuracy is 2e-4 N, 1e-4, 3e-5 N m).
 * For unattainable demands: mean and max |achieved - demanded| per axis, for both modes.
 * Output: one JSON object on stdout.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "mixer.h"

static uint64_t rs;
static double urand(void) /* [-1, 1) */
{
	rs ^= rs >> 12;
	rs ^= rs << 25;
	rs ^= rs >> 27;
	return (double)((rs * 2685821657736338717ull) >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

static const double tol_exact[MIXER_N_AXES] = {1e-3, 1e-3, 1e-3, 1e-4};
static const char *const axis_name[MIXER_N_AXES] = {"f_n", "tau_x_nm", "tau_y_nm", "tau_z_nm"};

struct stats {
	long exact_att;               /* attainable and reproduced exactly */
	double err_sum[MIXER_N_AXES]; /* unattainable: sum |error| */
	double err_max[MIXER_N_AXES];
	double att_err_max[MIXER_N_AXES]; /* attainable: max |error| */
	long unatt;
};

static void account(struct stats *s, int attainable, const struct mixer_output *o)
{
	int exact = 1;
	for (int i = 0; i < MIXER_N_AXES; i++) {
		double e = fabs((double)sc_to_float(o->achieved[i]) - (double)sc_to_float(o->demanded[i]));
		if (e > tol_exact[i])
			exact = 0;
		if (attainable > 0 && e > s->att_err_max[i])
			s->att_err_max[i] = e;
		if (attainable < 0) {
			s->err_sum[i] += e;
			if (e > s->err_max[i])
				s->err_max[i] = e;
		}
	}
	if (attainable > 0 && exact)
		s->exact_att++;
	if (attainable < 0)
		s->unatt++;
}

static void print_stats(const char *name, const struct stats *s, long n_att, int last)
{
	printf("  \"%s\": {\"exact_attainable\": %ld, \"exact_attainable_pct\": %.3f,\n", name, s->exact_att,
	       n_att ? 100.0 * (double)s->exact_att / (double)n_att : 0.0);
	printf("    \"attainable_err_max\": {");
	for (int i = 0; i < MIXER_N_AXES; i++)
		printf("\"%s\": %.3g%s", axis_name[i], s->att_err_max[i], i + 1 < MIXER_N_AXES ? ", " : "");
	printf("},\n    \"unattainable_err_mean\": {");
	for (int i = 0; i < MIXER_N_AXES; i++)
		printf("\"%s\": %.4g%s", axis_name[i], s->unatt ? s->err_sum[i] / (double)s->unatt : 0.0,
		       i + 1 < MIXER_N_AXES ? ", " : "");
	printf("},\n    \"unattainable_err_max\": {");
	for (int i = 0; i < MIXER_N_AXES; i++)
		printf("\"%s\": %.4g%s", axis_name[i], s->err_max[i], i + 1 < MIXER_N_AXES ? ", " : "");
	printf("}}%s\n", last ? "" : ",");
}

int main(int argc, char **argv)
{
	long n = argc > 1 ? atol(argv[1]) : 20000;
	uint64_t seed = argc > 2 ? (uint64_t)atoll(argv[2]) : 1u;
	rs = seed * 0x9E3779B97F4A7C15ull + 0x1234567ull;

	struct mixer_params p;
	mixer_default_params(&p);
	static struct mixer prio, clip;
	p.mode = MIXER_MODE_PRIORITY;
	if (!mixer_init(&prio, &p) || !prio.alloc_ok) {
		printf("{\"error\": \"mixer_init failed or allocator unavailable\"}\n");
		return 1;
	}
	p.mode = MIXER_MODE_CLIP;
	mixer_init(&clip, &p);

	const double hover = 2.132 * 9.796;
	long n_att = 0, n_unatt = 0, n_band = 0, max_steps = 0;
	struct stats sp = {0}, sc = {0};
	for (long k = 0; k < n; k++) {
		scalar_t d[MIXER_N_AXES] = {
			sc_from_float((float)(hover * (1.0 + 0.6 * urand()))),
			sc_from_float((float)(2.0 * urand())),
			sc_from_float((float)(2.0 * urand())),
			sc_from_float((float)(0.25 * urand())),
		};
		int att;
		if (mixer_attainable(&prio, d, sc_from_float(-1e-4f)))
			att = 1, n_att++;
		else if (!mixer_attainable(&prio, d, sc_from_float(1e-4f)))
			att = -1, n_unatt++;
		else
			att = 0, n_band++;
		struct mixer_output o;
		mixer_update(&prio, d, &o);
		if (o.steps > max_steps)
			max_steps = o.steps;
		account(&sp, att, &o);
		mixer_update(&clip, d, &o);
		account(&sc, att, &o);
	}
	printf("{\n  \"demands\": %ld, \"seed\": %llu, \"attainable\": %ld, \"unattainable\": %ld, "
	       "\"boundary_band\": %ld,\n",
	       n, (unsigned long long)seed, n_att, n_unatt, n_band);
	printf("  \"priority_max_steps\": %ld, \"step_bound\": %d,\n", max_steps,
	       2 * MIXER_ALPHA_ITERS + (prio.n_active - 4) + MIXER_QP_ITERS);
	print_stats("priority", &sp, n_att, 0);
	print_stats("clip", &sc, n_att, 1);
	printf("}\n");
	return 0;
}
