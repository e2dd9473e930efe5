/*
 * boundary.h - where the app's floats (the platform's frame, throttles, parameters, log)
 * meet the core's scalars. In the float build scalar_t is float and nothing is converted:
 * the frame itself is read as scalars and struct boundary holds nothing. In the fixed build
 * (OCTO_FIXED, Q16.16) the frame's inputs are converted once per step, the throttles sent
 * are kept as scalars too, and values that mostly stay from step to step (a set point held,
 * the step's dt) are converted only when they change.
 */
#ifndef OCTO_BOUNDARY_H
#define OCTO_BOUNDARY_H

#include <stdint.h>

#include "hal.h"
#include "scalar.h"

/* The frame's inputs as scalars, fields named as in struct hal_sensor_frame so that either
 * serves (bnd_in). */
struct bnd_frame {
	scalar_t q_ib[4], rate_b_rps[3], pos_i_m[3], vel_i_mps[3];
	scalar_t rotor_thrust_n[HAL_ROTORS], rotor_torque_nm[HAL_ROTORS];
};

#if OCTO_FIXED
typedef struct bnd_frame bnd_frame_t;
/* a value and its conversion, redone only when the value changed */
struct bnd_kept {
	scalar_t v;
	float f;
};
struct boundary {
	struct bnd_frame fs;         /* the frame's inputs as scalars */
	scalar_t thr_sc[HAL_ROTORS]; /* the throttles sent, as scalars */
	struct bnd_kept log_sp[4];   /* the logged set points (bnd_log_sp) */
	struct bnd_kept dt;          /* the step's dt (bnd_dt) */
};
#else
typedef struct hal_sensor_frame bnd_frame_t;
struct boundary {
	uint8_t none;
};
#endif

/* This step's frame as scalars: bnd_frame_in converts it (fixed build) once per step. */
void bnd_frame_in(struct boundary *b, const struct hal_sensor_frame *f);
/* The rotor torques too (only the experiments read them). */
void bnd_torque_in(struct boundary *b, const struct hal_sensor_frame *f);

#if OCTO_FIXED
/* The zeroed pair is right: 0 converts to +0.0f and +0.0f to 0. The float is compared by
 * its bits: one float converts to one scalar. */
static inline float bnd_kept_to_float(struct bnd_kept *k, scalar_t v)
{
	if (v != k->v) {
		k->v = v;
		k->f = sc_to_float(v);
	}
	return k->f;
}

static inline scalar_t bnd_kept_from_float(struct bnd_kept *k, float f)
{
	union {
		float f;
		uint32_t u;
	} x = {f}, y = {k->f};
	if (x.u != y.u) {
		k->f = f;
		k->v = sc_from_float(f);
	}
	return k->v;
}

static inline const bnd_frame_t *bnd_in(const struct boundary *b, const struct hal_sensor_frame *f)
{
	(void)f;
	return &b->fs;
}
/* The throttles sent as scalars, and storing them (thr: the floats sent). */
static inline const scalar_t *bnd_thr(const struct boundary *b, const float *thr)
{
	(void)thr;
	return b->thr_sc;
}
static inline void bnd_thr_store(struct boundary *b, int j, scalar_t t) { b->thr_sc[j] = t; }
static inline void bnd_thr_all(struct boundary *b, float t)
{
	scalar_t ts = sc_from_float(t);
	for (int j = 0; j < HAL_ROTORS; j++)
		b->thr_sc[j] = ts;
}
/* set point i (0..3) of the log as a float; the step's dt as a scalar */
static inline float bnd_log_sp(struct boundary *b, int i, scalar_t v) { return bnd_kept_to_float(&b->log_sp[i], v); }
static inline scalar_t bnd_dt(struct boundary *b, float dt) { return bnd_kept_from_float(&b->dt, dt); }
#else
static inline const bnd_frame_t *bnd_in(const struct boundary *b, const struct hal_sensor_frame *f)
{
	(void)b;
	return f;
}
static inline const scalar_t *bnd_thr(const struct boundary *b, const float *thr)
{
	(void)b;
	return thr;
}
static inline void bnd_thr_store(struct boundary *b, int j, scalar_t t)
{
	(void)b;
	(void)j;
	(void)t;
}
static inline void bnd_thr_all(struct boundary *b, float t)
{
	(void)b;
	(void)t;
}
static inline float bnd_log_sp(struct boundary *b, int i, scalar_t v)
{
	(void)b;
	(void)i;
	return v;
}
static inline scalar_t bnd_dt(struct boundary *b, float dt)
{
	(void)b;
	return dt;
}
#endif

/* The excitation's throttles as floats (for the log). A dither gives the rotors a few values and their negations (the rotor experiment: two
 * magnitudes per step), and a Q16.16 value and its negation convert to floats of opposite
 * sign: each magnitude is converted once (the last two kept). */
static inline void bnd_excitation_to_float(float out[HAL_ROTORS], const scalar_t d[HAL_ROTORS])
{
#if OCTO_FIXED
	uint32_t m0 = 0u, m1 = 0u;
	float f0 = 0.0f, f1 = 0.0f;
	for (int j = 0; j < HAL_ROTORS; j++) {
		scalar_t v = d[j];
		uint32_t m = v < 0 ? 0u - (uint32_t)v : (uint32_t)v;
		float f;
		if (m == m0) {
			f = f0;
		} else if (m == m1) {
			f = f1;
		} else if (m > (uint32_t)INT32_MAX) { /* INT32_MIN: no positive twin */
			out[j] = sc_to_float(v);
			continue;
		} else {
			f = sc_to_float((scalar_t)m);
			m1 = m0;
			f1 = f0;
			m0 = m;
			f0 = f;
		}
		out[j] = v < 0 ? -f : f;
	}
#else
	for (int j = 0; j < HAL_ROTORS; j++)
		out[j] = d[j];
#endif
}

#endif /* OCTO_BOUNDARY_H */
