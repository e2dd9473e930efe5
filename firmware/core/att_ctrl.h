/*
 * att_ctrl.h - quaternion attitude controller: body torque from attitude and rate.
 *
 * Law (per body axis a in {x, y, z}; I = diagonal inertia passed on every call):
 *   e_b      = quat_error_b(q_sp_b2i, q_b2i)             shortest rotation, rad
 *   rate_cmd = clamp(wn^2 / (2 zeta wn) * e_b, +/-rate_max) + rate_ff_b
 *   r        = rate_cmd - rate_b                          rate error, rad/s
 *   tau_b    = I * 2 zeta wn * (r + ki * integral(r dt))  PI on the rate error
 *              + rate_b x (I rate_b)                      gyroscopic compensation
 *   tau_b    = clamp(tau_b, +/-tau_max)
 * Unsaturated, this is tau = I (wn^2 e - 2 zeta wn omega) + omega x I omega: with the
 * correct inertia each axis is the second-order system s^2 + 2 zeta wn s + wn^2 with no
 * zero (the damping acts on the measured rate, so a setpoint step does not overshoot
 * for zeta >= 1). A wrong inertia I_nom = c I_true scales wn by sqrt(c) and zeta by
 * sqrt(c). The rate limit turns large steps into ramps without overshoot.
 * The integral acts on the rate error, so over a setpoint step it returns to about zero
 * (its slow pole near -ki nearly cancels its zero at -ki: little overshoot) while a
 * constant disturbance torque is removed with time constant ~1/ki. It accumulates only
 * while |e| < int_err_max, or while the axis turns slower than ATT_CTRL_STUCK_RPS (a
 * large error the rate loop does not close: a disturbance beyond the integral's reach
 * otherwise pins the attitude away from its set point for good), and the axis is not
 * saturated; its torque is clamped to
 * +/-int_tau_max. Anti-windup from the allocator (as PX4's rate controller takes its
 * allocator's saturation): an axis whose torque the allocation could not deliver in one
 * direction on the previous step (alloc_short_pos / _neg, e.g. from mixer_shortfall) does
 * not integrate further in that direction; it may unwind.
 *
 * Units: rad, rad/s, kg m^2, N m, s. Frames: q_*_b2i map body to inertial (quat.h);
 * rates and torques in body axes (X forward, Y left, Z up).
 * Q16.16: inputs in range for a multirotor (rates < 100 rad/s, I < 10 kg m^2, torques
 * < 1000 N m) keep every intermediate in range.
 */
#ifndef OCTO_ATT_CTRL_H
#define OCTO_ATT_CTRL_H

#include "quat.h"
#include "scalar.h"
#include "vec3.h"

#include <stdint.h>

/* flags (att_ctrl.flags and the return value of att_ctrl_update) */
#define ATT_CTRL_SAT_X (1u << 0) /* tau_b.x clamped to tau_max.x */
#define ATT_CTRL_SAT_Y (1u << 1)
#define ATT_CTRL_SAT_Z (1u << 2)
#define ATT_CTRL_RATE_LIM_X (1u << 3) /* attitude part of rate_cmd.x clamped to rate_max.x */
#define ATT_CTRL_RATE_LIM_Y (1u << 4)
#define ATT_CTRL_RATE_LIM_Z (1u << 5)
#define ATT_CTRL_BAD_INPUT (1u << 6) /* a non-finite input (float build): tau = 0, state kept */

struct att_ctrl_params {
	struct vec3 wn_rps;         /* closed-loop natural frequency per axis, rad/s (> 0) */
	struct vec3 zeta;           /* damping ratio per axis (> 0) */
	struct vec3 ki_rps;         /* integral pole per axis, 1/s (0 = no integral) */
	struct vec3 rate_max_rps;   /* limit of the attitude part of the rate command, rad/s */
	struct vec3 tau_max_nm;     /* torque limit per axis, N m (>= 0) */
	struct vec3 int_tau_max_nm; /* limit of the integral torque per axis, N m */
	scalar_t int_err_max_rad;   /* integrate only while |e_axis| < this */
	bool gyro_comp;             /* add rate_b x (I rate_b) */
};

struct att_ctrl_input {
	struct quat q_sp_b2i;     /* attitude setpoint (unit) */
	struct vec3 rate_ff_b;    /* body-rate feedforward, rad/s (zero if unused) */
	struct quat q_b2i;        /* estimated attitude (unit) */
	struct vec3 rate_b_rps;   /* measured body rate, rad/s */
	struct vec3 inertia_kgm2; /* current Ixx, Iyy, Izz, kg m^2 (> 0) */
	scalar_t dt_s;            /* time since the last update, s (for the integral) */
	uint8_t alloc_short_pos;  /* bit i (0 x, 1 y, 2 z): the allocation delivered less torque
				   * than demanded on the previous step (0 if unknown) */
	uint8_t alloc_short_neg;  /* bit i: it delivered more (less negative) than demanded */
};

struct att_ctrl {
	/* the parameters as the update uses them, per axis (0 x, 1 y, 2 z), prepared by
	 * att_ctrl_set_params: no division and no product of parameters in the update */
	scalar_t kp[3]; /* wn^2 / (2 zeta wn), 1/s */
	scalar_t kd[3]; /* 2 zeta wn, 1/s */
	scalar_t ki[3]; /* integral pole, 1/s */
	scalar_t rate_max[3], tau_max[3], int_tau_max[3];
	scalar_t int_err_max_rad;
	bool gyro_comp;
	struct vec3 int_r_rad; /* integral of the rate error, rad */
	uint32_t flags;        /* ATT_CTRL_* of the last update */
	/* per axis, what depends on the inertia input m_ii as well (0: none yet), recomputed
	 * when it changes: the same values as computing them on every step */
	scalar_t m_ii[3];
	scalar_t m_ikd[3]; /* I 2 zeta wn, N m / (rad/s) */
	scalar_t m_lim[3]; /* int_tau_max / kint, kint = I 2 zeta wn ki (when kint > 0) */
};

/* Default gains, the ones octo-fw flies: its parameter table (ATT_WN_RP, ATT_WN_YAW,
 * ATT_ZETA, ATT_KI) takes its defaults from these. */
#define ATT_CTRL_DEFAULT_WN_RP_RPS 7.0f  /* roll and pitch natural frequency, rad/s */
#define ATT_CTRL_DEFAULT_WN_YAW_RPS 3.5f /* yaw natural frequency, rad/s */
#define ATT_CTRL_DEFAULT_ZETA 1.0f       /* damping ratio, every axis */
#define ATT_CTRL_STUCK_RPS 0.25f         /* beyond int_err_max, integrate while the axis turns slower */
#define ATT_CTRL_DEFAULT_KI_RPS 0.3f     /* integral pole, every axis, 1/s */

/* Defaults for the paper's octocopter at 90 Hz with a one-frame delay and a 30 ms
 * motor lag: the gains above, rate_max 3 / 3 / 1.5 rad/s, tau_max 3 / 3 / 0.4 N m,
 * int_tau_max 0.5 / 0.5 / 0.1 N m, int_err_max 0.2 rad, gyro_comp on.
 * tests/core/test_att_ctrl.c measures these limits with wn 7 / 7 / 5 rad/s, zeta 1.0 /
 * 1.0 / 1.1, ki 0.5 1/s (0.2 rad steps): correct inertia 0 % overshoot, 5 % settling
 * 0.67 s roll/pitch, 1.34 s yaw (0.3 rad, torque-limited); nominal inertia 0.05 on every
 * axis (before identification) <= 3 % overshoot, <= 0.8 s; inertia overestimated x2 with
 * 50 ms lag + 2 frames: 9 % overshoot, stable. */
struct att_ctrl_params att_ctrl_params_default(void);

/* Takes params (att_ctrl_set_params), zeroes the integral and flags. */
void att_ctrl_init(struct att_ctrl *s, const struct att_ctrl_params *params);

/* Prepares params (their products and quotients, above); keeps the integral. Parameters
 * change only through this or att_ctrl_init. */
void att_ctrl_set_params(struct att_ctrl *s, const struct att_ctrl_params *params);

/* Zeroes the integral (e.g. on the ground, or after a mode change). */
void att_ctrl_reset(struct att_ctrl *s);

/* Adds tau_nm to the integral's torque (for the inertia given: the next update's), within
 * its limit: a torque the allocation stops leaving out (a rotor's effectiveness identified)
 * which the integral had taken, handed back so that the torque sent stays the same. */
void att_ctrl_shift_integral(struct att_ctrl *s, struct vec3 tau_nm, struct vec3 inertia_kgm2);

/* One control step (law above): writes tau_b_nm, returns (and stores) the flags. */
uint32_t att_ctrl_update(struct att_ctrl *s, const struct att_ctrl_input *in, struct vec3 *tau_b_nm);

#endif /* OCTO_ATT_CTRL_H */
