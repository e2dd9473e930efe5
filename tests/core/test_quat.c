/* Tests of firmware/core/quat.h (and vec3.h) in whichever build this is.
 * References are computed in double; tolerances are stated per check:
 * float ~1e-6, Q16.16 a few LSB (1.5e-5) per operation, more where errors accumulate. */
#include "unit_scalar.h"
#include "quat.h"
#include "unit.h"
#include "unit_quat.h"

#include <math.h>

#define PI 3.14159265358979323846

#if OCTO_FIXED
#define LSB (1.0 / 65536.0)
#else
#define LSB 1e-7
#endif

static scalar_t s(double x) { return sc_from_float((float)x); }

/* rotation matrix of q_b2i (body -> inertial), double */
static void dq_to_R(const double q[4], double R[3][3])
{
	double w = q[0], x = q[1], y = q[2], z = q[3];
	R[0][0] = 1 - 2 * (y * y + z * z);
	R[0][1] = 2 * (x * y - w * z);
	R[0][2] = 2 * (x * z + w * y);
	R[1][0] = 2 * (x * y + w * z);
	R[1][1] = 1 - 2 * (x * x + z * z);
	R[1][2] = 2 * (y * z - w * x);
	R[2][0] = 2 * (x * z - w * y);
	R[2][1] = 2 * (y * z + w * x);
	R[2][2] = 1 - 2 * (x * x + y * y);
}

static struct quat random_quat(struct unit_rng *r)
{
	double q[4], n = 0;
	for (int i = 0; i < 4; i++) {
		q[i] = unit_rand_normal(r);
		n += q[i] * q[i];
	}
	n = sqrt(n);
	struct quat o = {s(q[0] / n), s(q[1] / n), s(q[2] / n), s(q[3] / n)};
	return o;
}

static void to_d(struct quat q, double o[4]) { o[0] = d(q.w), o[1] = d(q.x), o[2] = d(q.y), o[3] = d(q.z); }

/* sign-insensitive distance between two unit quaternions */
static double qdist(const double a[4], const double b[4])
{
	double p = 0, m = 0;
	for (int i = 0; i < 4; i++) {
		p += (a[i] - b[i]) * (a[i] - b[i]);
		m += (a[i] + b[i]) * (a[i] + b[i]);
	}
	return sqrt(p < m ? p : m);
}

UNIT_TEST(quat_product_conj_norm)
{
	struct unit_rng r = {0x9a7e1ULL};
	for (int i = 0; i < 200; i++) {
		struct quat a = random_quat(&r), b = random_quat(&r);
		double da[4], db[4], dr[4], got[4];
		to_d(a, da), to_d(b, db);
		dq_mul(da, db, dr);
		to_d(quat_mul(a, b), got);
		for (int k = 0; k < 4; k++)
			CHECK_NEAR(got[k], dr[k], OCTO_FIXED ? 4 * LSB : 1e-6); /* 4 products, rounded */
		/* q (x) conj(q) = identity */
		struct quat ca = {a.w, sc_neg(a.x), sc_neg(a.y), sc_neg(a.z)};
		to_d(quat_mul(a, ca), got);
		CHECK_NEAR(got[0], 1.0, OCTO_FIXED ? 8 * LSB : 1e-6);
		CHECK_NEAR(got[1], 0.0, OCTO_FIXED ? 4 * LSB : 1e-6);
		/* normalisation of a scaled quaternion */
		struct quat big = {sc_mul(a.w, SC(3.7)), sc_mul(a.x, SC(3.7)), sc_mul(a.y, SC(3.7)),
				   sc_mul(a.z, SC(3.7))};
		struct quat n = quat_normalize(big);
		CHECK_NEAR(d(quat_norm2(n)), 1.0, OCTO_FIXED ? 8 * LSB : 1e-6);
		to_d(n, got);
		CHECK_NEAR(qdist(got, da), 0.0, OCTO_FIXED ? 8 * LSB : 1e-6);
	}
	/* degenerate input gives the identity, not NaN */
	struct quat z = {SC_ZERO, SC_ZERO, SC_ZERO, SC_ZERO};
	struct quat n = quat_normalize(z);
	CHECK(n.w == SC(1) && n.x == SC_ZERO && n.y == SC_ZERO && n.z == SC_ZERO);
}

UNIT_TEST(quat_body_z_up_matches_matrix)
{
	struct unit_rng r = {0x5eedULL};
	for (int i = 0; i < 200; i++) {
		struct quat q = random_quat(&r);
		double dq[4], R[3][3];
		to_d(q, dq);
		dq_to_R(dq, R);
		/* body Z axis' vertical component */
		CHECK_NEAR(d(quat_body_z_up(q)), R[2][2], OCTO_FIXED ? 4 * LSB : 1e-6);
	}
}

/* column k of the rotation matrix of q: body axis k in S_I */
static void body_axis(struct quat q, int k, double v[3])
{
	double dq[4], R[3][3];
	to_d(q, dq);
	dq_to_R(dq, R);
	for (int i = 0; i < 3; i++)
		v[i] = R[i][k];
}

UNIT_TEST(quat_frames_and_euler_signs)
{
	/* yaw +90 deg: body X (forward) points to inertial +Y */
	double x[3], y[3];
	body_axis(tq_from_euler(SC_ZERO, SC_ZERO, s(PI / 2)), 0, x);
	double tol = OCTO_FIXED ? 10 * LSB : 1e-6;
	CHECK_NEAR(x[0], 0, tol);
	CHECK_NEAR(x[1], 1, tol);
	/* pitch +0.3 rad (about Y, which points left): the nose goes down */
	body_axis(tq_from_euler(SC_ZERO, SC(0.3), SC_ZERO), 0, x);
	CHECK_NEAR(x[2], -sin(0.3), tol);
	/* roll +0.3 rad: body Y (left) goes up */
	struct quat q = tq_from_euler(SC(0.3), SC_ZERO, SC_ZERO);
	body_axis(q, 1, y);
	CHECK_NEAR(y[2], sin(0.3), tol);
	CHECK_NEAR(d(quat_body_z_up(q)), cos(0.3), tol);
}

UNIT_TEST(quat_from_euler_and_yaw)
{
	struct unit_rng r = {0xe1e1ULL};
	for (int i = 0; i < 300; i++) {
		double e[3] = {unit_rand_uniform(&r, -3.1, 3.1), unit_rand_uniform(&r, -1.5, 1.5),
			       unit_rand_uniform(&r, -3.1, 3.1)};
		struct quat_yaw_half yh = quat_yaw_half(s(e[2]));
		CHECK_NEAR(d(yh.c), cos(e[2] / 2), OCTO_FIXED ? 2 * LSB : 1e-6);
		CHECK_NEAR(d(yh.s), sin(e[2] / 2), OCTO_FIXED ? 2 * LSB : 1e-6);
		struct quat q = quat_from_euler_yh(s(e[0]), s(e[1]), yh);
		/* against the double reference Rz Ry Rx */
		double cr = cos(e[0] / 2), sr = sin(e[0] / 2), cp = cos(e[1] / 2), sp = sin(e[1] / 2);
		double cy = cos(e[2] / 2), sy = sin(e[2] / 2);
		double qz[4] = {cy, 0, 0, sy}, qy[4] = {cp, 0, sp, 0}, qx[4] = {cr, sr, 0, 0}, ref[4], got[4];
		dq_mul(qz, qy, ref);
		dq_mul(ref, qx, ref);
		to_d(q, got);
		CHECK_NEAR(qdist(got, ref), 0, OCTO_FIXED ? 2e-4 : 2e-6); /* Q16.16: float trig + 16 products */
		/* the yaw back: near pitch +/-90 deg it is lost, the tolerance grows with 1/cos(pitch) */
		double tol = (OCTO_FIXED ? 2e-3 : 2e-5) / cos(e[1]);
		CHECK_NEAR(d(quat_yaw(q)), e[2], tol);
	}
}

UNIT_TEST(quat_error)
{
	/* error from identity to a small roll is +roll about body X */
	struct quat sp = tq_from_euler(SC(0.1), SC_ZERO, SC_ZERO);
	struct vec3 e = quat_error_b(sp, tq_identity());
	CHECK_NEAR(d(e.x), 2 * sin(0.05), OCTO_FIXED ? 8 * LSB : 1e-6);
	CHECK_NEAR(d(e.y), 0, OCTO_FIXED ? 8 * LSB : 1e-6);
	/* error is expressed in body axes: vehicle yawed 90 deg, setpoint = yaw 90 + roll 0.1 */
	struct quat cur = tq_from_euler(SC_ZERO, SC_ZERO, s(PI / 2));
	sp = tq_from_euler(SC(0.1), SC_ZERO, s(PI / 2));
	e = quat_error_b(sp, cur);
	CHECK_NEAR(d(e.x), 2 * sin(0.05), OCTO_FIXED ? 20 * LSB : 1e-6);
	CHECK_NEAR(d(e.y), 0, OCTO_FIXED ? 20 * LSB : 1e-6);
	/* shortest way: -q is the same attitude, and a 350 deg yaw is -10 deg */
	struct quat neg = {sc_neg(sp.w), sc_neg(sp.x), sc_neg(sp.y), sc_neg(sp.z)};
	struct vec3 e2 = quat_error_b(neg, cur);
	CHECK_NEAR(d(e2.x), d(e.x), 2 * LSB);
	sp = tq_from_euler(SC_ZERO, SC_ZERO, s(350.0 * PI / 180.0));
	e = quat_error_b(sp, tq_identity());
	CHECK_NEAR(d(e.z), -2 * sin(5.0 * PI / 180.0), OCTO_FIXED ? 2e-4 : 1e-6);
}

UNIT_TEST(vec3_ops)
{
	struct vec3 a = vec3_make(SC(1), SC(2), SC(3)), b = vec3_make(SC(-2), SC(0.5), SC(4));
	struct vec3 c = vec3_cross(a, b);
	CHECK_NEAR(d(c.x), 2 * 4 - 3 * 0.5, 2 * LSB);
	CHECK_NEAR(d(c.y), 3 * -2 - 1 * 4, 2 * LSB);
	CHECK_NEAR(d(c.z), 1 * 0.5 - 2 * -2, 2 * LSB);
	CHECK_NEAR(d(vec3_dot(a, b)), -2 + 1 + 12, 2 * LSB);
	CHECK_NEAR(d(vec3_norm(a)), sqrt(14.0), OCTO_FIXED ? 2 * LSB : 1e-6);
	struct vec3 k = vec3_clamp_abs(vec3_make(SC(5), SC(-5), SC(0.5)), vec3_make(SC(1), SC(2), SC(3)));
	CHECK(k.x == SC(1) && k.y == SC(-2) && k.z == SC(0.5));
}
