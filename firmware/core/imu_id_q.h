/*
 * imu_id_q.h - imu_id's per-frame number types (the fields of struct imu_id, imu_id.h) and
 * their conversions to and from the float of its between-frames work (the solve, the grid's
 * refinement; the conversions are for imu_id.c only). Float build: float and identities.
 * Fixed build: Q1.30, Q6.25, Q4.27, block floating point and int64 sums (qfmt.h).
 */
#ifndef OCTO_IMU_ID_Q_H
#define OCTO_IMU_ID_Q_H

#include <stdint.h>

#include "qfmt.h"
#include "scalar.h"

/* ---------------------------------------------------------------- number formats
 * The per-frame part (imu_id_process: the lag filters, smoothers, regressors and sums) is
 * written once against these types; the float build keeps float (throttles, forces in N,
 * torques in N m), the fixed build (OCTO_FIXED) integers (docs/number-formats.md):
 *   imu_id_u_t    Q1.30 (QF_UNIT_FRAC) int32: throttles, the lag filters' states (each
 *                 rotor's output times the square root of its scale), the square roots of
 *                 the scales, a lag's 1 - a (the float build keeps a); range [-2, 2),
 *                 resolution 9.3e-10; saturates.
 *   imu_id_x_t    Q6.25 (QF_IMUX_FRAC) int32: the scaled throttles' sums x1 = sum s_j y_j and
 *                 x2 = sum s_j y_j^2 and their smoothers, the centred regressors and their
 *                 lag sensitivities, the patterns' responses, and the force and torque
 *                 normalised by 2^kexp and 2^texp (the powers of two that bring the
 *                 reference's k_f and k_tau into [0.5, 1)): a force is then about k_f0 x,
 *                 in the regressors' range; range [-64, 64) (four times the sum of 8 scales
 *                 of 2), resolution 3.0e-8; saturates.
 *   imu_id_c_t    Q4.27 (QF_IMUC_FRAC) int32: coefficients: the scales, the patterns, the
 *                 centring's slopes, the reference's k_f 2^-kexp, k_tau 2^-texp and its
 *                 regressor's slopes, 1 / (2 h) of the grid's step h; range [-16, 16),
 *                 resolution 7.5e-9; computed between frames in float, stored rounded.
 *   imu_id_sum_t  block floating point, int32 mantissa m with an exponent e shared by the
 *                 sums of one kind (a member of the bank's, the blocks' or the scales'
 *                 check's records): value = m 2^(e - QF_MSUM_FRAC) in the normalised units.
 *                 Each term is rounded to the current exponent; a term or a sum of 2^29 or
 *                 more first shifts the whole kind right (rounded) and raises e until both
 *                 are below, so their sum stays below 2^30: no overflow or wrap however long
 *                 the run. e starts at IMU_ID_E0 at each restart.
 *   imu_id_acc_t  int64: sums of one term a frame, exact: the force and torque sums of each
 *                 delay and the still force's (Q6.25), the calibration's vertical force
 *                 (scalar_t's Q16.16), the still frames' throttle (Q1.30); the force's sums
 *                 of squares rounded to Q12.25 (|f| < 64: 2^26 frames, 8 days at 90 Hz,
 *                 before they would saturate).
 * Counts are integers in both builds. */
#if OCTO_FIXED
typedef int32_t imu_id_u_t;
typedef int32_t imu_id_x_t;
typedef int32_t imu_id_c_t;
typedef int32_t imu_id_sum_t;
typedef int64_t imu_id_acc_t;
#else
typedef float imu_id_u_t;
typedef float imu_id_x_t;
typedef float imu_id_c_t;
typedef float imu_id_sum_t;
typedef float imu_id_acc_t;
#endif
/* every kind starts at this exponent (2^-41 in normalised units): its first terms raise it */
#define IMU_ID_E0 (-16)

#if OCTO_FIXED
static inline float iid_u_to_float(imu_id_u_t v) { return (float)v * sc_pow2f(-QF_UNIT_FRAC); }
static inline imu_id_u_t iid_u_of_float(float x) { return sc_q_of_float(x, QF_UNIT_FRAC); }
/* an x value (sh: its unit's power of two, kexp for a force) to and from float */
static inline float iid_x_to_float(imu_id_x_t v, int sh) { return (float)v * sc_pow2f(sh - QF_IMUX_FRAC); }
static inline imu_id_x_t iid_x_of_float(float x, int sh) { return sc_q_of_float(x, QF_IMUX_FRAC - sh); }
static inline imu_id_c_t iid_c_of_float(float x) { return sc_q_of_float(x, QF_IMUC_FRAC); }
/* a sum of exponent e to float; sh: its unit's power of two (kexp, 2 kexp, ...) */
static inline float iid_sum_to_float(imu_id_sum_t v, int e, int sh)
{
	return (float)v * sc_pow2f(e - QF_MSUM_FRAC + sh);
}
/* an int64 sum of fractional bits frac to float, times 2^sh */
static inline float iid_acc_to_float(imu_id_acc_t v, int frac, int sh) { return (float)v * sc_pow2f(sh - frac); }
#else
static inline float iid_u_to_float(imu_id_u_t v) { return v; }
static inline imu_id_u_t iid_u_of_float(float x) { return x; }
static inline float iid_x_to_float(imu_id_x_t v, int sh)
{
	(void)sh;
	return v;
}
static inline imu_id_x_t iid_x_of_float(float x, int sh)
{
	(void)sh;
	return x;
}
static inline imu_id_c_t iid_c_of_float(float x) { return x; }
static inline float iid_sum_to_float(imu_id_sum_t v, int e, int sh)
{
	(void)e;
	(void)sh;
	return v;
}
static inline float iid_acc_to_float(imu_id_acc_t v, int frac, int sh)
{
	(void)frac;
	(void)sh;
	return v;
}
#endif

#endif /* OCTO_IMU_ID_Q_H */
