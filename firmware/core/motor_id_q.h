/*
 * motor_id_q.h - conversions between motor_id's per-frame number types (motor_id.h) and the
 * float of its between-frames work (motor_id_solve.c); private to motor_id*.c.
 * Float build: identities. Fixed build: Q1.30, Q2.29 and block floating point (qfmt.h).
 */
#ifndef OCTO_MOTOR_ID_Q_H
#define OCTO_MOTOR_ID_Q_H

#include "motor_id.h"
#include "qfmt.h"

#if OCTO_FIXED
/* float to int32 v 2^frac, rounded, saturating (no libm) */
static inline int32_t mid_q_of_float(float x, int frac)
{
	float v = x * sc_pow2f(frac);
	if (!(v < 2147483520.0f))   /* the largest float below 2^31; NaN too */
		return v < 0.0f ? -INT32_MAX : INT32_MAX;
	if (v <= -2147483520.0f)
		return -INT32_MAX;
	return (int32_t)(v >= 0.0f ? v + 0.5f : v - 0.5f);
}
static inline float mid_u_to_float(motor_id_u_t v) { return (float)v * sc_pow2f(-QF_UNIT_FRAC); }
static inline motor_id_u_t mid_u_of_float(float x) { return mid_q_of_float(x, QF_UNIT_FRAC); }
/* a thrust-like value (N) into the normalised Q2.29 */
static inline motor_id_f_t mid_f_of_float(float x, int kexp) { return mid_q_of_float(x, QF_MOTN_FRAC - kexp); }
/* a sum of kind e (exponent ev) to float; p: the power of thrust in its terms (0, 1, 2) */
static inline float mid_sum_to_float(motor_id_sum_t v, int ev, int p, int kexp)
{
	return (float)v * sc_pow2f(ev - QF_MSUM_FRAC + p * kexp);
}
#else
static inline float mid_u_to_float(motor_id_u_t v) { return v; }
static inline motor_id_u_t mid_u_of_float(float x) { return x; }
static inline motor_id_f_t mid_f_of_float(float x, int kexp) { (void)kexp; return x; }
static inline float mid_sum_to_float(motor_id_sum_t v, int ev, int p, int kexp)
{
	(void)ev;
	(void)p;
	(void)kexp;
	return v;
}
#endif

#endif /* OCTO_MOTOR_ID_Q_H */
