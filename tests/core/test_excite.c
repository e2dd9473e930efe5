/* Tests of firmware/core/excite.h in whichever build this is: bounds, determinism,
 * PRBS period and balance, multisine peak and period, and the same sequences as a
 * double reference of each generator (uniform and PRBS to the last bit of the A
 * scaling, multisine within 1.5e-4 A). */
#include "unit_scalar.h"
#include "excite.h"
#include "mixer.h"
#include "unit.h"

#include <math.h>
#ifdef TEST_VERBOSE
#include <stdio.h>
#endif

#define PI 3.14159265358979323846

#if OCTO_FIXED
#define LSB (1.0 / 65536.0)
#else
#define LSB 1e-7
#endif

static struct excite_params params(enum excite_kind kind, double A)
{
	struct excite_params p = excite_params_default();
	p.kind = kind;
	p.amplitude = sc_from_float((float)A);
	return p;
}

UNIT_TEST(excite_bounds_all_kinds)
{
	const enum excite_kind kinds[3] = {EXCITE_UNIFORM, EXCITE_PRBS, EXCITE_MULTISINE};
	for (int j = 0; j < 3; j++) {
		struct excite_params p = params(kinds[j], 0.05);
		p.seed = 1234u + (uint32_t)j;
		struct excite e;
		excite_init(&e, &p);
		scalar_t a = e.p.amplitude;
		for (int k = 0; k < 5000; k++) {
			scalar_t y = excite_update(&e);
			CHECK(y <= a && y >= sc_neg(a));
		}
	}
	struct excite_params p = params(EXCITE_OFF, 0.05);
	struct excite e;
	excite_init(&e, &p);
	CHECK(excite_update(&e) == SC_ZERO);
	CHECK(excite_period_frames(&e) == 0);
	/* negative amplitude is taken as 0 */
	p = params(EXCITE_UNIFORM, -1);
	excite_init(&e, &p);
	CHECK(excite_update(&e) == SC_ZERO);
}

UNIT_TEST(excite_deterministic)
{
	const enum excite_kind kinds[3] = {EXCITE_UNIFORM, EXCITE_PRBS, EXCITE_MULTISINE};
	for (int j = 0; j < 3; j++) {
		struct excite_params p = params(kinds[j], 0.1);
		p.seed = 77;
		p.clock_div = 3;
		struct excite a, b, c;
		excite_init(&a, &p);
		excite_init(&b, &p);
		p.seed = 78;
		excite_init(&c, &p);
		int same = 1, differ = 0;
		for (int k = 0; k < 2000; k++) {
			scalar_t ya = excite_update(&a), yb = excite_update(&b), yc = excite_update(&c);
			same &= ya == yb;
			differ |= ya != yc;
		}
		CHECK(same);
		if (kinds[j] != EXCITE_MULTISINE) /* the multisine does not use the seed */
			CHECK(differ);
	}
}

/* excite_prepare between samples (as exp_pump runs it between frames, sometimes not at all,
 * sometimes twice) leaves every kind's sequence as it is, bit for bit, across the
 * multisine's restarts */
UNIT_TEST(excite_prepare_same_sequence)
{
	const enum excite_kind kinds[3] = {EXCITE_UNIFORM, EXCITE_PRBS, EXCITE_MULTISINE};
	for (int j = 0; j < 3; j++) {
		struct excite_params p = params(kinds[j], 0.1);
		p.ms_period_frames = 37;
		p.ms_count = 5;
		struct excite a, b;
		excite_init(&a, &p);
		excite_init(&b, &p);
		int same = 1;
		for (int k = 0; k < 500; k++) {
			if (k % 7 != 3)
				excite_prepare(&b);
			if (k % 5 == 1)
				excite_prepare(&b);
			same &= excite_update(&a) == excite_update(&b);
		}
		CHECK(same);
	}
}

/* The paper's delta_1: uniform in [-A, A], held for clock_div frames; against the
 * double reference (same xorshift32) within 1 LSB of the scaling; mean ~ 0 and
 * variance ~ A^2 / 3 (20000 draws: 5 sigma bounds). */
UNIT_TEST(excite_uniform_sequence)
{
	const double A = 0.05;
	struct excite_params p = params(EXCITE_UNIFORM, A);
	p.seed = 0xC0FFEEu;
	p.clock_div = 4;
	struct excite e;
	excite_init(&e, &p);
	uint32_t x = p.seed;
	double Aq = d(p.amplitude), sum = 0, sum2 = 0, ref = 0;
	const int n = 20000;
	for (int k = 0; k < 4 * n; k++) {
		if (k % 4 == 0) {
			x ^= x << 13;
			x ^= x >> 17;
			x ^= x << 5;
			int v = (int)(x >> 17);
			ref = Aq * (2.0 * v - 32767.0) / 32767.0;
			sum += ref, sum2 += ref * ref;
		}
		CHECK_NEAR(d(excite_update(&e)), ref, OCTO_FIXED ? 2 * LSB : 1e-7);
	}
	double mean = sum / n, var = sum2 / n - mean * mean;
	CHECK_NEAR(mean, 0, 5 * A / sqrt(3.0 * n));
	CHECK_NEAR(var, A * A / 3, 5 * A * A * sqrt(4.0 / 45.0 / n));
}

/* PRBS: period (2^n - 1) clock_div exactly, 2^(n-1) ones and 2^(n-1) - 1 zeros per period,
 * values exactly +/-A. */
UNIT_TEST(excite_prbs_period_and_balance)
{
	for (uint32_t order = 2; order <= 16; order++) {
		struct excite_params p = params(EXCITE_PRBS, 0.05);
		p.prbs_order = order;
		p.seed = 99;
		p.clock_div = order <= 10 ? 3 : 1;
		struct excite e;
		excite_init(&e, &p);
		uint32_t period = excite_period_frames(&e), bits = (1u << order) - 1u;
		CHECK(period == bits * p.clock_div);
		uint32_t start = e.lfsr, plus = 0, minus = 0, first_return = 0;
		for (uint32_t k = 0; k < period; k++) {
			scalar_t y = excite_update(&e);
			CHECK(y == p.amplitude || y == sc_neg(p.amplitude));
			if ((k + 1) % p.clock_div == 0) {
				if (y > 0)
					plus++;
				else
					minus++;
				if (!first_return && e.lfsr == start)
					first_return = (k + 1) / p.clock_div;
			}
		}
		CHECK(first_return == bits); /* the state returns only after the full period */
		CHECK(plus == (bits + 1) / 2 && minus == (bits - 1) / 2);
		/* and the sequence repeats */
		struct excite e2;
		excite_init(&e2, &p);
		int same = 1;
		for (uint32_t k = 0; k < 50; k++)
			same &= excite_update(&e) == excite_update(&e2);
		CHECK(same);
	}
}

/* double reference multisine: Schroeder phases, harmonics k_first..k_first+N-1 of
 * 1 / P cycles per frame, peak-normalised over one period */
static double ms_ref_raw(int n, int k_first, int P, int frame)
{
	double sum = 0;
	for (int k = 1; k <= n; k++) {
		double ph = -PI * k * (k - 1) / n;
		sum += sin(2 * PI * (k_first + k - 1) * frame / (double)P + ph);
	}
	return sum / n;
}

UNIT_TEST(excite_multisine_peak_period_reference)
{
	const int cases[3][3] = {{8, 1, 180}, {5, 2, 90}, {EXCITE_MS_MAX, 1, 360}}; /* N, k_first, P */
	for (int j = 0; j < 3; j++) {
		struct excite_params p = params(EXCITE_MULTISINE, 1.0);
		p.ms_count = (uint32_t)cases[j][0];
		p.ms_k_first = (uint32_t)cases[j][1];
		p.ms_period_frames = (uint32_t)cases[j][2];
		struct excite e;
		excite_init(&e, &p);
		int P = cases[j][2];
		CHECK(excite_period_frames(&e) == (uint32_t)P);
		double peak_ref = 0;
		for (int k = 0; k < P; k++)
			peak_ref = fmax(peak_ref, fabs(ms_ref_raw(cases[j][0], cases[j][1], P, k)));
		double peak = 0, sum = 0, sum2 = 0, first[8], worst = 0;
		for (int k = 0; k < 2 * P; k++) {
			double y = d(excite_update(&e));
			if (k < P) {
				peak = fmax(peak, fabs(y));
				sum += y, sum2 += y * y;
			}
			if (k < 8)
				first[k] = y;
			if (k >= P && k < P + 8) /* exactly periodic */
				CHECK(y == first[k - P]);
			worst = fmax(worst, fabs(y - ms_ref_raw(cases[j][0], cases[j][1], P, k) / peak_ref));
		}
		/* the peak over one period is A (the scale was found on the same samples) */
		CHECK_NEAR(peak, 1.0, OCTO_FIXED ? 8 * LSB : 1e-6);
		/* zero mean; Schroeder phases keep the crest factor low: rms > A / 2 */
		CHECK_NEAR(sum / P, 0, 1e-3);
		CHECK(sqrt(sum2 / P) > 0.5);
		/* same sequence as the double reference: polynomial sine (4e-6), 15-bit phase
		 * (5e-5 per sine), Q16.16 rounding (~N LSB) */
		CHECK_NEAR(worst, 0, 1.5e-4); /* measured <= 7e-5 */
#ifdef TEST_VERBOSE
		printf("multisine N %d k1 %d P %d: worst vs double %.2e A, peak %.7f\n", cases[j][0], cases[j][1], P,
		       worst, peak);
#endif
	}
}

/* Every null-space pattern is in the null space of the mixer's Gamma_o (random arm, k_f,
 * k_tau: the patterns hold for any vehicle of this layout), patterns 0 and 1 together move
 * every rotor, and pattern 2 is their sum */
UNIT_TEST(excite_null_patterns_in_gamma_null_space)
{
	struct unit_rng g = {0x9a77e2ULL};
	for (int v = 0; v < 5; v++) {
		struct mixer_params p = {
			.arm_l_m = sc_from_float((float)unit_rand_uniform(&g, 0.2, 0.6)),
			.k_f_n = sc_from_float((float)unit_rand_uniform(&g, 15.0, 40.0)),
			.k_tau_nm = sc_from_float((float)unit_rand_uniform(&g, 0.2, 0.6)),
			.t_min = SC(0.0),
			.t_max = SC(1.0),
			.rotor_mask = 0xFF,
			.mode = MIXER_MODE_PRIORITY,
		};
		struct mixer mix; /* on the stack (M0 RAM) */
		struct mixer_design des;
		CHECK(mixer_init_design(&mix, &p, &des));
		for (unsigned k = 0; k < EXCITE_NULL_PATTERNS; k++) {
			scalar_t pat[EXCITE_ROTORS];
			excite_null_pattern(k, pat);
			for (int i = 0; i < 4; i++) {
				double w = 0.0, scale = 0.0;
				for (int j = 0; j < EXCITE_ROTORS; j++) {
					w += (double)des.gamma_f[i][j] * d(pat[j]);
					scale += fabs((double)des.gamma_f[i][j]);
				}
				CHECK(fabs(w) <= 1e-6 * scale);
			}
		}
	}
	scalar_t p0[EXCITE_ROTORS], p1[EXCITE_ROTORS], p2[EXCITE_ROTORS], p9[EXCITE_ROTORS];
	excite_null_pattern(0, p0);
	excite_null_pattern(1, p1);
	excite_null_pattern(2, p2);
	excite_null_pattern(9, p9);
	for (int j = 0; j < EXCITE_ROTORS; j++) {
		CHECK((p0[j] != SC_ZERO) != (p1[j] != SC_ZERO));
		CHECK(p2[j] == sc_add(p0[j], p1[j]));
		CHECK(p9[j] == SC_ZERO);
	}
	/* the offset cycle: +1, 0, -1, 0 by blocks */
	CHECK(excite_offset_level(0, 45) == SC(1.0));
	CHECK(excite_offset_level(44, 45) == SC(1.0));
	CHECK(excite_offset_level(45, 45) == SC(0.0));
	CHECK(excite_offset_level(90, 45) == SC(-1.0));
	CHECK(excite_offset_level(179, 45) == SC(0.0));
	CHECK(excite_offset_level(180, 45) == SC(1.0));
	CHECK(excite_offset_level(6, 0) == SC(-1.0)); /* seg 0 is taken as 1 */
}
