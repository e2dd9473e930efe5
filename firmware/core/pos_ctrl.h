/*
 * pos_ctrl.h - horizontal position hold: roll and pitch set points from the horizontal
 * position and velocity errors (the outer loop around att_ctrl).
 *
 * Law (per horizontal axis of S_I: x north, y west; tilt angles in rad):
 *   v_cmd = clamp(k_p (p_sp - p), +/-vel_max)      velocity command, m/s
 *   a     = k_v (v_cmd - v)                        tilt wanted along that axis, rad
 *   [fwd, left] = the same vector in the heading frame (rotated by -yaw)
 *   pitch_sp = clamp(fwd, +/-tilt_max),  roll_sp = clamp(-left, +/-tilt_max)
 * A positive pitch (about Y_B, left) tips the thrust forward; a positive roll (about X_B)
 * tips it to the right. k_v is a tilt per m/s of velocity error; near hover a tilt of a
 * rad accelerates by g a, so the loop is s^2 + g k_v s + g k_v k_p (k_v 0.15 rad s/m,
 * k_p 0.3 1/s: zeta 1.1, wn 0.66 rad/s).
 * The heading comes from the attitude without trigonometry: (cos yaw, sin yaw) is the
 * horizontal part of the body X axis, normalised (yaw as quat_yaw gives it); a body whose
 * X axis is vertical has no heading and takes yaw 0.
 *
 * Units: m, m/s, rad, 1/s. Q16.16: positions and set points within +/-10000 m of each
 * other keep every intermediate in range. Stateless: the parameters and the input give
 * the output.
 */
#ifndef OCTO_POS_CTRL_H
#define OCTO_POS_CTRL_H

#include "quat.h"
#include "scalar.h"

#include <stdint.h>

#define POS_CTRL_VEL_LIM (1u << 0)   /* a velocity command clamped to vel_max */
#define POS_CTRL_TILT_LIM (1u << 1)  /* a tilt set point clamped to tilt_max */
#define POS_CTRL_BAD_INPUT (1u << 2) /* a non-finite input (float build): level set points */

struct pos_ctrl_params {
	scalar_t pos_gain_rps;     /* k_p: velocity per metre of position error, 1/s */
	scalar_t vel_gain_rad_mps; /* k_v: tilt per m/s of velocity error, rad s/m */
	scalar_t vel_max_mps;      /* limit of the velocity command, m/s (>= 0) */
	scalar_t tilt_max_rad;     /* limit of each tilt set point, rad (>= 0) */
};

struct pos_ctrl_input {
	scalar_t pos_sp_m[2]; /* horizontal set point (x, y of S_I), m */
	scalar_t pos_m[2];    /* measured horizontal position, m */
	scalar_t vel_mps[2];  /* measured horizontal velocity, m/s */
	struct quat q_b2i;    /* attitude, for the heading */
};

struct pos_ctrl_output {
	scalar_t roll_rad;  /* roll set point */
	scalar_t pitch_rad; /* pitch set point */
	uint32_t flags;     /* POS_CTRL_* */
};

/* Defaults of octo-fw: k_p 0.3 1/s, k_v 0.15 rad s/m, vel_max 2 m/s, tilt_max 20 deg. */
#define POS_CTRL_DEFAULT_POS_GAIN_RPS 0.3f
#define POS_CTRL_DEFAULT_VEL_GAIN_RAD_MPS 0.15f
#define POS_CTRL_DEFAULT_VEL_MAX_MPS 2.0f
#define POS_CTRL_DEFAULT_TILT_MAX_DEG 20.0f
struct pos_ctrl_params pos_ctrl_params_default(void);

/* One step of the law above. */
struct pos_ctrl_output pos_ctrl_update(const struct pos_ctrl_params *p, const struct pos_ctrl_input *in);

/* cos and sin of the heading of q_b2i (see above), into *c and *s. */
void pos_ctrl_heading(struct quat q_b2i, scalar_t *c, scalar_t *s);

#endif /* OCTO_POS_CTRL_H */
