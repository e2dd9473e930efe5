/* Tests of firmware/core/quat.h (and vec3.h) in whichever build this is.
 * References are computed in double; tolerances are stated per check:
 * float ~1e-6, Q16.16 a few LSB (1.5e-5) per operation, more where errors accumulate. */
#include "unit_scalar.h"
#include "quat.h"
#include "unit.h"

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
	R[0][0] = 1 - 2 * (y * y + z * z); R[0][1] = 2 * (x * y - w * z);     R[0][2] = 2 * (x * z + w * y);
	R[1][0] = 2 * (x * y + w * z);     R[1][1] = 1 - 2 * (x * x + z * z); R[1][2] = 2 * (y * z - w * x);
	R[2][0] = 2 * (x * z - w * y);     R[2][1] = 2 * (y * z + w * x);     R[2][2] = 1 - 2 * (x * x + y * y);
}

static struct quat random_quat(struct unit_rng *r)
{
	double q[4], n = 0;
	for (int i = 0; i < 4; i++) {
		q[i] = unit_rand_normal(r);
		n += q[i] * q[i];
	}
	n = sqrt(n);
	struct quat o = { s(q[0] / n), s(q[1] / n), s(q[2] / n), s(q[3] / n) };
	return o;
}

static void to_d(struct quat q, double o[4])
{
	o[0] = d(q.w), o[1] = d(q.x), o[2] = d(q.y), o[3] = d(q.z);
}

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
	struct unit_rng r = { 0x9a7e1ULL };
	for (int i = 0; i < 200; i++) {
		struct quat a = random_quat(&r), b = random_quat(&r);
		double da[4], db[4], dr[4], got[4];
		to_d(a, da), to_d(b, db);
		dq_mul(da, db, dr);
		to_d(quat_mul(a, b), got);
		for (int k = 0; k < 4; k++)
			CHECK_NEAR(got[k], dr[k], OCTO_FIXED ? 4 * LSB : 1e-6); /* 4 products, rounded */
		/* q (x) conj(q) = identity */
		to_d(quat_mul(a, quat_conj(a)), got);
		CHECK_NEAR(got[0], 1.0, OCTO_FIXED ? 8 * LSB : 1e-6);
		CHECK_NEAR(got[1], 0.0, OCTO_FIXED ? 4 * LSB : 1e-6);
		/* normalisation of a scaled quaternion */
		struct quat big = { sc_mul(a.w, SC(3.7)), sc_mul(a.x, SC(3.7)), sc_mul(a.y, SC(3.7)), sc_mul(a.z, SC(3.7)) };
		struct quat n = quat_normalize(big);
		CHECK_NEAR(d(quat_norm2(n)), 1.0, OCTO_FIXED ? 8 * LSB : 1e-6);
		to_d(n, got);
		CHECK_NEAR(qdist(got, da), 0.0, OCTO_FIXED ? 8 * LSB : 1e-6);
	}
	/* degenerate input gives the identity, not NaN */
	struct quat z = { SC_ZERO, SC_ZERO, SC_ZERO, SC_ZERO };
	struct quat n = quat_normalize(z);
	CHECK(n.w == SC(1) && n.x == SC_ZERO && n.y == SC_ZERO && n.z == SC_ZERO);
}

UNIT_TEST(quat_rotate_matches_matrix)
{
	struct unit_rng r = { 0x5eedULL };
	for (int i = 0; i < 200; i++) {
		struct quat q = random_quat(&r);
		double dq[4], R[3][3];
		to_d(q, dq);
		dq_to_R(dq, R);
		double v[3] = { unit_rand_uniform(&r, -3, 3), unit_rand_uniform(&r, -3, 3), unit_rand_uniform(&r, -3, 3) };
		struct vec3 vs = vec3_make(s(v[0]), s(v[1]), s(v[2]));
		struct vec3 vi = quat_rotate(q, vs);
		double ref[3];
		for (int k = 0; k < 3; k++)
			ref[k] = R[k][0] * d(vs.x) + R[k][1] * d(vs.y) + R[k][2] * d(vs.z);
		double tol = OCTO_FIXED ? 40 * LSB : 4e-6; /* |v| <= 5.2, ~10 rounded products */
		CHECK_NEAR(d(vi.x), ref[0], tol);
		CHECK_NEAR(d(vi.y), ref[1], tol);
		CHECK_NEAR(d(vi.z), ref[2], tol);
		/* inverse rotation brings it back */
		struct vec3 vb = quat_rotate_inv(q, vi);
		CHECK_NEAR(d(vb.x), d(vs.x), 2 * tol);
		CHECK_NEAR(d(vb.y), d(vs.y), 2 * tol);
		CHECK_NEAR(d(vb.z), d(vs.z), 2 * tol);
		/* rotate by a product = rotate twice */
		struct quat p = random_quat(&r);
		struct vec3 v2 = quat_rotate(quat_mul(p, q), vs), v3 = quat_rotate(p, quat_rotate(q, vs));
		CHECK_NEAR(d(v2.x), d(v3.x), 3 * tol);
		CHECK_NEAR(d(v2.z), d(v3.z), 3 * tol);
		/* body Z axis' vertical component */
		CHECK_NEAR(d(quat_body_z_up(q)), R[2][2], OCTO_FIXED ? 4 * LSB : 1e-6);
	}
}

UNIT_TEST(quat_frames_and_euler_signs)
{
	/* yaw +90 deg: body X (forward) points to inertial +Y */
	struct quat q = quat_from_euler(SC_ZERO, SC_ZERO, s(PI / 2));
	struct vec3 x = quat_rotate(q, vec3_make(SC(1), SC_ZERO, SC_ZERO));
	double tol = OCTO_FIXED ? 10 * LSB : 1e-6;
	CHECK_NEAR(d(x.x), 0, tol);
	CHECK_NEAR(d(x.y), 1, tol);
	/* pitch +0.3 rad (about Y, which points left): the nose goes down */
	q = quat_from_euler(SC_ZERO, SC(0.3), SC_ZERO);
	x = quat_rotate(q, vec3_make(SC(1), SC_ZERO, SC_ZERO));
	CHECK_NEAR(d(x.z), -sin(0.3), tol);
	/* roll +0.3 rad: body Y (left) goes up */
	q = quat_from_euler(SC(0.3), SC_ZERO, SC_ZERO);
	struct vec3 y = quat_rotate(q, vec3_make(SC_ZERO, SC(1), SC_ZERO));
	CHECK_NEAR(d(y.z), sin(0.3), tol);
	CHECK_NEAR(d(quat_body_z_up(q)), cos(0.3), tol);
}

UNIT_TEST(quat_euler_round_trip)
{
	struct unit_rng r = { 0xe1e1ULL };
	for (int i = 0; i < 300; i++) {
		double e[3] = { unit_rand_uniform(&r, -3.1, 3.1), unit_rand_uniform(&r, -1.5, 1.5),
				unit_rand_uniform(&r, -3.1, 3.1) };
		struct quat q = quat_from_euler(s(e[0]), s(e[1]), s(e[2]));
		/* against the double reference Rz Ry Rx */
		double cr = cos(e[0] / 2), sr = sin(e[0] / 2), cp = cos(e[1] / 2), sp = sin(e[1] / 2);
		double cy = cos(e[2] / 2), sy = sin(e[2] / 2);
		double qz[4] = { cy, 0, 0, sy }, qy[4] = { cp, 0, sp, 0 }, qx[4] = { cr, sr, 0, 0 }, ref[4], got[4];
		dq_mul(qz, qy, ref);
		dq_mul(ref, qx, ref);
		to_d(q, got);
		CHECK_NEAR(qdist(got, ref), 0, OCTO_FIXED ? 2e-4 : 2e-6); /* Q16.16: float trig + 16 products */
		struct vec3 b = quat_to_euler(q);
		/* pitch near +/-90 deg loses roll/yaw separately: tolerance grows with 1/cos(pitch) */
		double tol = (OCTO_FIXED ? 2e-3 : 2e-5) / cos(e[1]);
		CHECK_NEAR(d(b.x), e[0], tol);
		CHECK_NEAR(d(b.y), e[1], OCTO_FIXED ? 2e-3 : 2e-5);
		CHECK_NEAR(d(b.z), e[2], tol);
	}
}

/* Constant body rate: q(t) = q0 (x) exp([0, omega t / 2]) exactly. */
UNIT_TEST(quat_kinematics_constant_rate)
{
	const double w[3] = { 0.8, -1.3, 2.1 }, dt = 1.0 / 90.0;
	const int n = 450; /* 5 s, |omega| t = 13.5 rad */
	double q0[4] = { 0.9, 0.1, -0.3, 0.2 }, m = 0;
	for (int i = 0; i < 4; i++)
		m += q0[i] * q0[i];
	for (int i = 0; i < 4; i++)
		q0[i] /= sqrt(m);
	struct quat q = { s(q0[0]), s(q0[1]), s(q0[2]), s(q0[3]) };
	struct vec3 ws = vec3_make(s(w[0]), s(w[1]), s(w[2]));
	scalar_t dts = s(dt);
	double wn = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
	double worst = 0;
	for (int k = 1; k <= n; k++) {
		q = quat_integrate(q, ws, dts);
		double t = k * d(dts); /* the dt actually represented */
		double a = 0.5 * wn * t, e[4] = { cos(a), sin(a) * w[0] / wn, sin(a) * w[1] / wn, sin(a) * w[2] / wn };
		double ref[4], got[4];
		dq_mul(q0, e, ref);
		to_d(q, got);
		double dd = qdist(got, ref);
		worst = dd > worst ? dd : worst;
		CHECK_NEAR(d(quat_norm2(q)), 1.0, OCTO_FIXED ? 8 * LSB : 1e-6);
	}
	/* float: ~1e-7 rounding per step; Q16.16: omega dt / 2 is quantised (~3e-4 relative
	 * rate error) and each step rounds: the angle error grows linearly, ~2e-3 after 450 steps */
	CHECK_NEAR(worst, 0, OCTO_FIXED ? 4e-3 : 2e-5);

	/* the derivative of eq. (4) against the explicit matrix form */
	struct quat qd = quat_derivative(q, ws);
	double c[4];
	to_d(q, c);
	double ref[4] = { 0.5 * (-w[0] * c[1] - w[1] * c[2] - w[2] * c[3]),
			  0.5 * (w[0] * c[0] + w[2] * c[2] - w[1] * c[3]),
			  0.5 * (w[1] * c[0] - w[2] * c[1] + w[0] * c[3]),
			  0.5 * (w[2] * c[0] + w[1] * c[1] - w[0] * c[2]) };
	CHECK_NEAR(d(qd.w), ref[0], OCTO_FIXED ? 1e-4 : 1e-6);
	CHECK_NEAR(d(qd.x), ref[1], OCTO_FIXED ? 1e-4 : 1e-6);
	CHECK_NEAR(d(qd.y), ref[2], OCTO_FIXED ? 1e-4 : 1e-6);
	CHECK_NEAR(d(qd.z), ref[3], OCTO_FIXED ? 1e-4 : 1e-6);
}

UNIT_TEST(quat_rotvec_and_error)
{
	/* rotation vector of 1 rad about Z */
	struct quat q = quat_from_rotvec(vec3_make(SC_ZERO, SC_ZERO, SC(1)));
	CHECK_NEAR(d(q.w), cos(0.5), OCTO_FIXED ? 4 * LSB : 1e-6);
	CHECK_NEAR(d(q.z), sin(0.5), OCTO_FIXED ? 4 * LSB : 1e-6);
	/* error from identity to a small roll is +roll about body X */
	struct quat sp = quat_from_euler(SC(0.1), SC_ZERO, SC_ZERO);
	struct vec3 e = quat_error_b(sp, quat_identity());
	CHECK_NEAR(d(e.x), 2 * sin(0.05), OCTO_FIXED ? 8 * LSB : 1e-6);
	CHECK_NEAR(d(e.y), 0, OCTO_FIXED ? 8 * LSB : 1e-6);
	/* error is expressed in body axes: vehicle yawed 90 deg, setpoint = yaw 90 + roll 0.1 */
	struct quat cur = quat_from_euler(SC_ZERO, SC_ZERO, s(PI / 2));
	sp = quat_from_euler(SC(0.1), SC_ZERO, s(PI / 2));
	e = quat_error_b(sp, cur);
	CHECK_NEAR(d(e.x), 2 * sin(0.05), OCTO_FIXED ? 20 * LSB : 1e-6);
	CHECK_NEAR(d(e.y), 0, OCTO_FIXED ? 20 * LSB : 1e-6);
	/* shortest way: -q is the same attitude, and a 350 deg yaw is -10 deg */
	struct quat neg = { sc_neg(sp.w), sc_neg(sp.x), sc_neg(sp.y), sc_neg(sp.z) };
	struct vec3 e2 = quat_error_b(neg, cur);
	CHECK_NEAR(d(e2.x), d(e.x), 2 * LSB);
	sp = quat_from_euler(SC_ZERO, SC_ZERO, s(350.0 * PI / 180.0));
	e = quat_error_b(sp, quat_identity());
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
