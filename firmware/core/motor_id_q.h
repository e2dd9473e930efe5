/*
 * motor_id_q.h - motor_id's per-frame number types (the fields of struct motor_id, motor_id.h)
 * and their conversions to and from the float of its between-frames work (motor_id_solve.c;
 * the conversions are for motor_id*.c only). Float build: float and identities. Fixed build:
 * Q1.30, Q2.29 and block floating point (qfmt.h).
 */
#ifndef OCTO_MOTOR_ID_Q_H
#define OCTO_MOTOR_ID_Q_H

#include <stdint.h>

#include "qfmt.h"
#include "scalar.h"

/* ---------------------------------------------------------------- number formats
 * The per-frame part (motor_id.c) is written once against these types; the float build keeps
 * float (the values in SI units), the fixed build (OCTO_FIXED) integers (qfmt.h, docs/number-formats.md):
 *   motor_id_u_t    Q1.30 (QF_UNIT_FRAC) int32: throttles, lag states s, regressors
 *                   x1 = s and x2 = s (s - 2 s_c) (in [-2, 1]), 1 - a of a lag, the curve
 *                   (c in [-0.5, 0.99], 1 - c); range [-2, 2), resolution 9.3e-10; saturates.
 *   motor_id_f_t    Q2.29 (QF_MOTN_FRAC) int32: thrusts and torques normalised by 2^kexp (the
 *                   power of two that brings the prior k_f into [0.5, 1)), residuals of the
 *                   reference model, prediction errors, the frozen model's changes of theta;
 *                   range [-4, 4) of the prior k_f (about 4 k_f0), resolution 1.9e-9 of it;
 *                   saturates (a thrust beyond 4 k_f0 is not a hovering rotor's).
 *   motor_id_sum_t  block floating point, int32 mantissa m with an exponent e shared by
 *                   every sum of one kind (motor_id_e_t): value = m 2^(e - QF_MSUM_FRAC) in
 *                   the normalised units. Each term is rounded to the current exponent; a
 *                   term of 2^29 or more first halves the whole kind (rounded) and raises e
 *                   until it fits, and a kind whose largest sum reached 2^29 is halved after
 *                   the frame, so sum and term stay below 2^29 and their sum below 2^30: no
 *                   overflow or wrap however long the run. e starts at MOTOR_ID_E0 at each
 *                   restart. Resolution 2^-28 to 2^-29 of the kind's largest sum.
 * Counts (frames, noise terms) are integers in both builds. */
#if OCTO_FIXED
typedef int32_t motor_id_u_t;
typedef int32_t motor_id_f_t;
typedef int32_t motor_id_sum_t;
#else
typedef float motor_id_u_t;
typedef float motor_id_f_t;
typedef float motor_id_sum_t;
#endif
typedef int8_t motor_id_e_t;
/* every kind starts at this exponent (fine resolution, 2^-41 in normalised units): its first
 * terms raise it as far as they need */
#define MOTOR_ID_E0 (-16)

/* the kinds of sums, each with its exponent */
enum {
	MID_E_G11,
	MID_E_G12,
	MID_E_G22,
	MID_E_B1,
	MID_E_B2,
	MID_E_RR, /* the bank */
	MID_E_FF,
	MID_E_TF,
	MID_E_TT, /* torque ratio */
	MID_E_NZ, /* noise from differences */
	MID_E_WSE,
	MID_E_WSEE, /* whiteness: sum e; sums e^2 and e_k e_(k-L) */
	MID_E_N
};

#if OCTO_FIXED
static inline float mid_u_to_float(motor_id_u_t v) { return (float)v * sc_pow2f(-QF_UNIT_FRAC); }
static inline motor_id_u_t mid_u_of_float(float x) { return sc_q_of_float(x, QF_UNIT_FRAC); }
/* a thrust-like value (N) into the normalised Q2.29 */
static inline motor_id_f_t mid_f_of_float(float x, int kexp) { return sc_q_of_float(x, QF_MOTN_FRAC - kexp); }
/* a sum of kind e (exponent ev) to float; p: the power of thrust in its terms (0, 1, 2) */
static inline float mid_sum_to_float(motor_id_sum_t v, int ev, int p, int kexp)
{
	return (float)v * sc_pow2f(ev - QF_MSUM_FRAC + p * kexp);
}
#else
static inline float mid_u_to_float(motor_id_u_t v) { return v; }
static inline motor_id_u_t mid_u_of_float(float x) { return x; }
static inline motor_id_f_t mid_f_of_float(float x, int kexp)
{
	(void)kexp;
	return x;
}
static inline float mid_sum_to_float(motor_id_sum_t v, int ev, int p, int kexp)
{
	(void)ev;
	(void)p;
	(void)kexp;
	return v;
}
#endif

#endif /* OCTO_MOTOR_ID_Q_H */
