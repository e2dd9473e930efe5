/*
 * thrmap.h - throttle map, eqs. (16)-(17): rotor thrust f_j (N) <-> throttle T_j in [0, 1].
 *
 * Model: f = k_f * ((1 - a) T + a T^2), a the curve (a = 0 is the paper's f = k_f T).
 * Inverse (closed form, no division by a): with u = f / k_f,
 *   T = 2 u / ((1 - a) + sqrt((1 - a)^2 + 4 a u)),   clamped to [0, 1].
 * Eq. (17), the reaction torque tau_j = k_tau T_j, is not mapped here: the mixer works
 * in thrust with k = k_tau / k_f (with a curve, tau_j = k f_j still holds).
 * Q16.16: k_f in (0, 1000] N; T has resolution 1.5e-5 (4e-4 N at k_f = 28 N).
 */
#ifndef OCTO_THRMAP_H
#define OCTO_THRMAP_H

#include "scalar_ops.h"

#include <stdint.h>

#define THRMAP_ROTORS 8

/* The thrust curve's range. a < 0 (thrust concave in throttle) is kept: a linear rotor's
 * estimate scatters on both sides of 0, and cutting it at 0 would bias k_f high. Within the
 * range, (1 - a) + 2 a T > 0 on [0, 1]: the map stays monotonic and invertible. */
#define THRMAP_CURVE_MIN (-0.5f)
#define THRMAP_CURVE_MAX 0.99f

struct thrmap_params {
	scalar_t k_f_n; /* thrust at full throttle, N (> 0; smaller values are raised to 1e-3) */
	scalar_t curve; /* a in [THRMAP_CURVE_MIN, THRMAP_CURVE_MAX] (clamped) */
	/* per-rotor effectiveness (MOT_SCALEj): rotor j gives scale[j] times a nominal rotor's
	 * thrust, so thrmap_update maps f_j / scale[j]; 0 (not given) is taken as 1, other
	 * values are clamped to [0.1, 4] */
	scalar_t scale[THRMAP_ROTORS];
};

struct thrmap {
	scalar_t k_f_n; /* params' k_f_n and curve, clamped */
	scalar_t curve;
	scalar_t one_minus_a; /* 1 - a */
			      /* 1 / (scale k_f) per rotor: thrmap_update's f -> u, one product (scalar_ops.h's
	 * sc_gain; in the fixed build its mantissa and shift in two arrays, smaller than a
	 * pair of words) */
#if OCTO_FIXED
	uint32_t g_y[THRMAP_ROTORS];
	uint8_t g_sh[THRMAP_ROTORS];
#else
	struct sc_gain g[THRMAP_ROTORS];
#endif
};

/* Copies and clamps params (k_f >= 1e-3 N, THRMAP_CURVE_MIN <= a <= THRMAP_CURVE_MAX,
 * scales as above) and prepares the per-rotor factors; keeps nothing else of params. */
void thrmap_init(struct thrmap *m, const struct thrmap_params *params);

/* n rotors: throttle_out[j] = T of f_n[j] / scale[j] (rotors beyond THRMAP_ROTORS:
 * scale 1) by the inverse map above, clamped to [0, 1] (a NaN thrust in the float build
 * gives T = 0, clamped), with u = f_n[j] / (scale[j] k_f) from one product by a factor
 * prepared by thrmap_init (scalar_ops.h: rounded once, within 0.5 LSB of u + 2^-26 relative
 * in the fixed build); returns a bit mask of the rotors j (bit j, j < 32) whose throttle was
 * clamped. */
uint32_t thrmap_update(const struct thrmap *m, const scalar_t *f_n, scalar_t *throttle_out, size_t n);

#endif /* OCTO_THRMAP_H */
