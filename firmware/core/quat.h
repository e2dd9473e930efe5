/*
 * quat.h - attitude quaternions and their kinematics, eqs. (1)-(4) of the paper.
 *
 * Convention (binding for the whole core):
 *   - q = [w, x, y, z] = the paper's [q1, q2, q3, q4], scalar first, Hamilton product.
 *   - Frames are the paper's: S_I inertial with Z up, S_B body with X forward,
 *     Y left, Z up (thrust along +Z_B).
 *   - An attitude is q_b2i: it maps body vectors to inertial ones,
 *         v_i = q_b2i (x) [0, v_b] (x) conj(q_b2i)        (quat_rotate)
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
 * Hot path functions use only add, mul, div, sqrt; Euler conversions use trig
 * (setpoints and telemetry only, see scalar.h).
 */
#ifndef OCTO_QUAT_H
#define OCTO_QUAT_H

#include "scalar.h"
#include "vec3.h"

struct quat {
	scalar_t w, x, y, z;
};

/* [1, 0, 0, 0] */
struct quat quat_identity(void);

/* a (x) b (Hamilton product; rotation b first, then a) */
struct quat quat_mul(struct quat a, struct quat b);

/* [w, -x, -y, -z]: the inverse of a unit quaternion */
struct quat quat_conj(struct quat q);

/* |q|^2 */
scalar_t quat_norm2(struct quat q);

/* q / |q|; a quaternion with |q|^2 below 1e-6 (or 0) gives the identity */
struct quat quat_normalize(struct quat q);

/* q (x) [0, v] (x) conj(q) for unit q, i.e. v_b -> v_i for q = q_b2i */
struct vec3 quat_rotate(struct quat q, struct vec3 v);

/* conj(q) (x) [0, v] (x) q for unit q, i.e. v_i -> v_b for q = q_b2i */
struct vec3 quat_rotate_inv(struct quat q, struct vec3 v);

/* Z component (inertial, up) of the body Z axis: R33 = cos(tilt) = 1 - 2(x^2 + y^2) */
scalar_t quat_body_z_up(struct quat q_b2i);

/* Eq. (4): q_dot = Omega(omega_b) q = 1/2 q (x) [0, omega_b] (not normalised) */
struct quat quat_derivative(struct quat q, struct vec3 omega_b);

/* One step of eq. (1) for omega_b constant over dt: q (x) exp([0, omega_b dt / 2]),
 * exact up to a 9th-order series of the half angle (error < 1e-7 for |omega| dt <= 1 rad),
 * then renormalised. Use for |omega_b| dt below about 1.5 rad. */
struct quat quat_integrate(struct quat q_b2i, struct vec3 omega_b_rps, scalar_t dt_s);

/* Rotation of angle |rotvec| (rad) about rotvec / |rotvec| (series like quat_integrate,
 * accurate for |rotvec| <= 3 rad; renormalised) */
struct quat quat_from_rotvec(struct vec3 rotvec);

/* Euler Z-Y-X (roll, pitch, yaw in rad, see above) -> q_b2i; uses trig */
struct quat quat_from_euler(scalar_t roll, scalar_t pitch, scalar_t yaw);

/* cos and sin of half a yaw: a set point's yaw changes rarely, so its trigonometry can be
 * kept between steps (quat_from_euler_yh) */
struct quat_yaw_half {
	scalar_t c, s;
};
struct quat_yaw_half quat_yaw_half(scalar_t yaw);

/* quat_from_euler(roll, pitch, yaw) with yh = quat_yaw_half(yaw): the same quaternion */
struct quat quat_from_euler_yh(scalar_t roll, scalar_t pitch, struct quat_yaw_half yh);

/* q_b2i -> Euler Z-Y-X: e.x = roll in [-pi, pi], e.y = pitch in [-pi/2, pi/2],
 * e.z = yaw in [-pi, pi]; the asin argument is clamped to [-1, 1]; uses trig */
struct vec3 quat_to_euler(struct quat q_b2i);
/* quat_to_euler's yaw alone (the same expression, so the same value) */
scalar_t quat_yaw(struct quat q_b2i);

/* Shortest rotation from q_b2i to q_sp_b2i expressed in body axes, as the vector
 * 2 sign(w_e) [x_e, y_e, z_e] of q_e = conj(q_b2i) (x) q_sp_b2i, i.e.
 * 2 sin(angle / 2) times the unit axis (equal to angle * axis for small angles,
 * angle <= pi, never the long way round). Units: rad (small-angle). */
struct vec3 quat_error_b(struct quat q_sp_b2i, struct quat q_b2i);

#endif /* OCTO_QUAT_H */
