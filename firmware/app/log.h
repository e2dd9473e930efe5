/*
 * log.h - the per-frame record of the autopilot's internal state.
 *
 * APP_LOG_FIELDS is the one list of its fields, in the order and with the
 * types of the LCM message octo.fw_frame_t (firmware/lcm/octo_fw_frame_t.lcm,
 * whose fields after utime must match it: tests/py/test_contracts.py checks).
 * It produces struct app_log_frame here and the field-by-field copy into the
 * LCM message in the host platform (hal/host/lcm_log.c). log_fill (log.c) fills
 * one record per received frame from the app's parts; the app hands it to the HAL's
 * log_frame. The step writes q_sp and rotor_f itself; log_fill sets every other field.
 *
 *   ONE(c_type, lcm_type, name)          a scalar
 *   ARR(c_type, lcm_type, name, count)   a fixed-size array
 */
#ifndef OCTO_APP_LOG_H
#define OCTO_APP_LOG_H

#include <stdbool.h>
#include <stdint.h>

#include "scalar.h"

#define APP_LOG_FIELDS(ONE, ARR)           \
	ONE(int64_t, int64_t, seq)         \
	ONE(double, double, t)             \
	ONE(float, float, dt)              \
	ONE(bool, boolean, stepped)        \
	ONE(int8_t, int8_t, mode)          \
	ONE(bool, boolean, armed)          \
	ONE(bool, boolean, link_ok)        \
	ONE(int32_t, int32_t, valid)       \
	ARR(float, float, q, 4)            \
	ARR(float, float, rate_b, 3)       \
	ARR(float, float, pos_i, 3)        \
	ARR(float, float, vel_i, 3)        \
	ARR(float, float, rotor_thrust, 8) \
	ARR(float, float, rotor_torque, 8) \
	ARR(float, float, accel_b, 3)      \
	ARR(float, float, rotor_speed, 8)  \
	ARR(float, float, q_sp, 4)         \
	ONE(float, float, z_sp)            \
	ONE(float, float, vz_ff)           \
	ARR(float, float, pos_sp, 2)       \
	ONE(float, float, f_dem)           \
	ARR(float, float, tau_dem, 3)      \
	ONE(float, float, f_alloc)         \
	ARR(float, float, tau_alloc, 3)    \
	ARR(float, float, rotor_f, 8)      \
	ARR(float, float, excitation, 8)   \
	ARR(float, float, throttle, 8)     \
	ONE(int32_t, int32_t, att_flags)   \
	ONE(int32_t, int32_t, alt_flags)   \
	ONE(int32_t, int32_t, mix_flags)   \
	ONE(int32_t, int32_t, thr_clamped) \
	ONE(int8_t, int8_t, exp_id)        \
	ONE(int8_t, int8_t, exp_phase)     \
	ONE(float, float, exp_progress)    \
	ARR(float, float, est, 8)          \
	ARR(float, float, est_sd, 8)       \
	ONE(float, float, kf)              \
	ONE(float, float, ktau)            \
	ARR(float, float, inertia, 3)      \
	ONE(float, float, mass)            \
	ONE(float, float, kft)             \
	ONE(float, float, kft_sd)

struct app_log_frame {
#define APP_LOG_ONE(c_type, lcm_type, name) c_type name;
#define APP_LOG_ARR(c_type, lcm_type, name, n) c_type name[n];
	APP_LOG_FIELDS(APP_LOG_ONE, APP_LOG_ARR)
#undef APP_LOG_ONE
#undef APP_LOG_ARR
};

struct hal_sensor_frame;
struct guid;
struct mixer_output;
struct experiment;
struct app_params;
struct env_kf;
struct boundary;

/* What one record is filled from. */
struct log_src {
	const struct hal_sensor_frame *fr; /* the frame received */
	bool stepped;                      /* the app stepped on it, with dt */
	float dt;
	int8_t mode;                        /* enum app_mode */
	bool armed, link_ok, experiment;    /* experiment: in mode EXPERIMENT */
	const struct guid *guid;            /* set points */
	const float *wrench_dem;            /* [f, tau] demanded */
	const struct mixer_output *mix_out; /* allocated */
	const scalar_t *excitation;         /* HAL_ROTORS throttles of the experiment */
	const float *thr;                   /* HAL_ROTORS throttles sent */
	uint32_t att_flags, alt_flags, thr_clamped;
	const struct experiment *exp;
	const struct app_params *p; /* VEH_* */
	const struct env_kf *kf;    /* k_f tracked */
	struct boundary *bnd;       /* the set points' conversions (fixed build) */
};

void log_fill(struct app_log_frame *l, const struct log_src *s);

#endif /* OCTO_APP_LOG_H */
