/* quat.c - see quat.h for the conventions (q_b2i, Hamilton, Z-Y-X Euler). */
#include "quat.h"

#include "scalar_ops.h"

struct quat quat_mul(struct quat a, struct quat b)
{
	struct quat r;
	r.w = sc_sub(sc_sub(sc_mul(a.w, b.w), sc_mul(a.x, b.x)), sc_add(sc_mul(a.y, b.y), sc_mul(a.z, b.z)));
	r.x = sc_add(sc_add(sc_mul(a.w, b.x), sc_mul(a.x, b.w)), sc_sub(sc_mul(a.y, b.z), sc_mul(a.z, b.y)));
	r.y = sc_add(sc_sub(sc_mul(a.w, b.y), sc_mul(a.x, b.z)), sc_add(sc_mul(a.y, b.w), sc_mul(a.z, b.x)));
	r.z = sc_add(sc_add(sc_mul(a.w, b.z), sc_mul(a.x, b.y)), sc_sub(sc_mul(a.z, b.w), sc_mul(a.y, b.x)));
	return r;
}

scalar_t quat_norm2(struct quat q)
{
	return sc_add(sc_add(sc_mul(q.w, q.w), sc_mul(q.x, q.x)), sc_add(sc_mul(q.y, q.y), sc_mul(q.z, q.z)));
}

struct quat quat_normalize(struct quat q)
{
	scalar_t n2 = quat_norm2(q);
	if (!(n2 > SC(1e-6))) {
		struct quat one = {SC(1), SC_ZERO, SC_ZERO, SC_ZERO};
		return one;
	}
#if OCTO_FIXED
	/* sc_sqrt(n2) == SC(1) exactly when n2 is 1 or 1 + 2^-16 (sqrt(n2 2^16) in
	 * [65535.5, 65536.5)): a unit quaternion skips the root */
	if (n2 == SC(1) || n2 == SC(1) + 1)
		return q;
#endif
	scalar_t n = sc_sqrt(n2);
	if (n == SC(1)) /* already unit (Q16.16: to the LSB): the divisions would change nothing */
		return q;
#if !SC_HARD_FLOAT
	struct quat r = {sc_div(q.w, n), sc_div(q.x, n), sc_div(q.y, n), sc_div(q.z, n)};
#else
	/* n > 1e-3: sc_div's quotient is the division instruction's */
	struct quat r = {q.w / n, q.x / n, q.y / n, q.z / n};
#endif
	return r;
}

scalar_t quat_body_z_up(struct quat q_b2i)
{
	scalar_t s = sc_add(sc_mul(q_b2i.x, q_b2i.x), sc_mul(q_b2i.y, q_b2i.y));
	return sc_sub(SC(1), sc_add(s, s));
}

struct quat_yaw_half quat_yaw_half(scalar_t yaw)
{
	scalar_t hy = sc_mul(yaw, SC(0.5));
	struct quat_yaw_half yh;
	sc_sincos(hy, &yh.s, &yh.c);
	return yh;
}

struct quat quat_from_euler_yh(scalar_t roll, scalar_t pitch, struct quat_yaw_half yh)
{
	scalar_t hr = sc_mul(roll, SC(0.5)), hp = sc_mul(pitch, SC(0.5));
	scalar_t cr, sr, cp, sp;
	sc_sincos(hr, &sr, &cr);
	sc_sincos(hp, &sp, &cp);
	/* Rz(yaw) Ry(pitch) Rx(roll); the yaw-pitch products are shared by two components each */
	scalar_t cycp = sc_mul(yh.c, cp), sysp = sc_mul(yh.s, sp);
	scalar_t cysp = sc_mul(yh.c, sp), sycp = sc_mul(yh.s, cp);
	struct quat q;
	q.w = sc_add(sc_mul(cycp, cr), sc_mul(sysp, sr));
	q.x = sc_sub(sc_mul(cycp, sr), sc_mul(sysp, cr));
	q.y = sc_add(sc_mul(cysp, cr), sc_mul(sycp, sr));
	q.z = sc_sub(sc_mul(sycp, cr), sc_mul(cysp, sr));
	return quat_normalize(q);
}

scalar_t quat_yaw(struct quat q)
{
	/* yaw = atan2(2 (w z + x y), 1 - 2 (y^2 + z^2)) */
	scalar_t two = SC(2);
	scalar_t yn = sc_mul(two, sc_add(sc_mul(q.w, q.z), sc_mul(q.x, q.y)));
	scalar_t yd = sc_sub(SC(1), sc_mul(two, sc_add(sc_mul(q.y, q.y), sc_mul(q.z, q.z))));
	return sc_atan2(yn, yd);
}

struct vec3 quat_error_b(struct quat q_sp_b2i, struct quat q_b2i)
{
	struct quat c = {q_b2i.w, sc_neg(q_b2i.x), sc_neg(q_b2i.y), sc_neg(q_b2i.z)};
	struct quat e = quat_mul(c, q_sp_b2i);
	/* 2 e (or -2 e: the shorter way round) as sums, the same as the products by +/-2 */
	struct vec3 v = vec3_make(sc_add(e.x, e.x), sc_add(e.y, e.y), sc_add(e.z, e.z));
	return e.w < SC_ZERO ? vec3_make(sc_neg(v.x), sc_neg(v.y), sc_neg(v.z)) : v;
}
