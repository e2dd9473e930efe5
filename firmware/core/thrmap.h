/*
 * thrmap.h - throttle map, eqs. (16)-(17): rotor thrust f_j (N) <-> throttle T_j in [0, 1].
 *
 * Model: f = k_f * ((1 - a) T + a T^2), a in [0, 1) (a = 0 is the paper's f = k_f T).
 * Inverse (closed form, no division by a): with u = f / k_f,
 *   T = 2 u / ((1 - a) + sqrt((1 - a)^2 + 4 a u)),   clamped to [0, 1].
 * Eq. (17), the reaction torque tau_j = k_tau T_j, is not mapped here: the mixer works
 * in thrust with k = k_tau / k_f (with a curve, tau_j = k f_j still holds).
 * Q16.16: k_f in (0, 1000] N; T has resolution 1.5e-5 (4e-4 N at k_f = 28 N).
 */
#ifndef OCTO_THRMAP_H
#define OCTO_THRMAP_H

#include "sc_recip.h"
#include "scalar_ops.h"

#include <stdint.h>

#define THRMAP_ROTORS 8

/* The thrust curve's range. a < 0 (thrust concave in throttle) is kept: a linear rotor's
 * estimate scatters on both sides of 0, and cutting it at 0 would bias k_f high. Within the
 * range, (1 - a) + 2 a T > 0 on [0, 1]: the map stays monotonic and invertible. */
#define THRMAP_CURVE_MIN (-0.5f)
#define THRMAP_CURVE_MAX 0.99f

struct thrmap_params {
	scalar_t k_f_n;  /* thrust at full throttle, N (> 0; smaller values are raised to 1e-3) */
	scalar_t curve; /* a in [THRMAP_CURVE_MIN, THRMAP_CURVE_MAX] (clamped) */
	/* per-rotor effectiveness (MOT_SCALEj): rotor j gives scale[j] times a nominal rotor's
	 * thrust, so thrmap_update maps f_j / scale[j]; 0 (not given) is taken as 1, other
	 * values are clamped to [0.1, 4] */
	scalar_t scale[THRMAP_ROTORS];
};

struct thrmap {
	struct thrmap_params p;
	scalar_t one_minus_a; /* 1 - a */
	struct sc_gain g[THRMAP_ROTORS]; /* 1 / (scale k_f): thrmap_update's f -> u, one product */
	struct sc_recip r_kf; /* 1 / k_f_n (the same quotients as sc_div) */
};

/* Copies and clamps params (k_f >= 1e-3 N, 0 <= a <= 0.99). */
void thrmap_init(struct thrmap *m, const struct thrmap_params *params);

/* T = inverse map of f_n, clamped to [0, 1]; *clamped (may be NULL) set when it was
 * (a NaN thrust in the float build gives T = 0, clamped). */
scalar_t thrmap_throttle(const struct thrmap *m, scalar_t f_n, bool *clamped);

/* f = k_f ((1 - a) T + a T^2) with T first clamped to [0, 1] */
scalar_t thrmap_thrust(const struct thrmap *m, scalar_t throttle);

/* n rotors: throttle_out[j] = thrmap_throttle(f_n[j] / scale[j]) (rotors beyond
 * THRMAP_ROTORS: scale 1), with u = f_n[j] / (scale[j] k_f) from one product by a factor
 * prepared by thrmap_init (scalar_ops.h: rounded once, within 0.5 LSB of u + 2^-26 relative
 * in the fixed build); returns a bit mask of the rotors j (bit j, j < 32) whose throttle was
 * clamped. */
uint32_t thrmap_update(const struct thrmap *m, const scalar_t *f_n, scalar_t *throttle_out, size_t n);

#endif /* OCTO_THRMAP_H */
