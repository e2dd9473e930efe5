/*
 * quat.h - attitude quaternions: what the firmware does with them (the attitude error,
 * set points from Euler angles, the tilt and the heading).
 *
 * Convention (binding for the whole core):
 *   - q = [w, x, y, z] = the paper's [q1, q2, q3, q4], scalar first, Hamilton product.
 *   - Frames are the paper's: S_I inertial with Z up, S_B body with X forward,
 *     Y left, Z up (thrust along +Z_B).
 *   - An attitude is q_b2i: it maps body vectors to inertial ones,
 *         v_i = q_b2i (x) [0, v_b] (x) conj(q_b2i)
 *     and its kinematics with the body rate omega_b (rad/s) is eq. (4):
 *         q_dot = 1/2 q (x) [0, omega_b] = Omega(omega_b) q.
 *   - Euler angles (rad) are Z-Y-X: q_b2i = Rz(yaw) Ry(pitch) Rx(roll), right-handed
 *     rotations about the paper's axes. So roll > 0 lowers the right side,
 *     pitch > 0 lowers the nose (Y points left), yaw > 0 turns the nose left
 *     (counter-clockwise seen from above). Relative to aerospace NED/FRD angles
 *     with S_I = North-West-Up: roll = roll_ned, pitch = -pitch_ned, yaw = -yaw_ned.
 *
 * Fixed-point build: components in Q16.16 (resolution 1.5e-5); every function that
 * produces an attitude renormalises or documents that it does not.
 * Only what the firmware calls is here (the tests build other attitudes themselves).
 */
#ifndef OCTO_QUAT_H
#define OCTO_QUAT_H

#include "scalar.h"
#include "vec3.h"

struct quat {
	scalar_t w, x, y, z;
};

/* a (x) b (Hamilton product; rotation b first, then a) */
struct quat quat_mul(struct quat a, struct quat b);

/* |q|^2 */
scalar_t quat_norm2(struct quat q);

/* q / |q|; a quaternion with |q|^2 below 1e-6 (or 0) gives the identity */
struct quat quat_normalize(struct quat q);

/* Z component (inertial, up) of the body Z axis: R33 = cos(tilt) = 1 - 2(x^2 + y^2) */
scalar_t quat_body_z_up(struct quat q_b2i);

/* cos and sin of half a yaw: a set point's yaw changes rarely, so its trigonometry is
 * kept between steps (quat_from_euler_yh); uses trig */
struct quat_yaw_half {
	scalar_t c, s;
};
struct quat_yaw_half quat_yaw_half(scalar_t yaw);

/* Euler Z-Y-X (roll, pitch, yaw in rad, see above) -> q_b2i, renormalised, with
 * yh = quat_yaw_half(yaw); uses trig */
struct quat quat_from_euler_yh(scalar_t roll, scalar_t pitch, struct quat_yaw_half yh);

/* the yaw of q_b2i's Euler Z-Y-X angles, in [-pi, pi]; uses trig */
scalar_t quat_yaw(struct quat q_b2i);

/* Shortest rotation from q_b2i to q_sp_b2i expressed in body axes, as the vector
 * 2 sign(w_e) [x_e, y_e, z_e] of q_e = conj(q_b2i) (x) q_sp_b2i, i.e.
 * 2 sin(angle / 2) times the unit axis (equal to angle * axis for small angles,
 * angle <= pi, never the long way round). Units: rad (small-angle). */
struct vec3 quat_error_b(struct quat q_sp_b2i, struct quat q_b2i);

#endif /* OCTO_QUAT_H */
