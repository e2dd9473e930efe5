/* Tests of firmware/core/pos_ctrl.h: the law against a double reference (random set points,
 * positions, velocities, attitudes and gains), the heading against quat_yaw, and closed-loop
 * position hold of a point mass whose tilt follows the set point through a lag and a frame
 * of delay (random start, heading and gains). Both builds. */
#include "unit_scalar.h"
#include "pos_ctrl.h"
#include "unit.h"
#include "unit_quat.h"

#include <math.h>

#define FRAME_S (1.0 / 90.0)
#define G_MPS2 9.796

static scalar_t s(double x) { return sc_from_float((float)x); }

static double clampd(double x, double lim) { return x > lim ? lim : (x < -lim ? -lim : x); }

static struct pos_ctrl_params random_params(struct unit_rng *g)
{
	struct pos_ctrl_params p;
	p.pos_gain_rps = s(unit_rand_uniform(g, 0.1, 1.0));
	p.vel_gain_rad_mps = s(unit_rand_uniform(g, 0.05, 0.3));
	p.vel_max_mps = s(unit_rand_uniform(g, 0.5, 4.0));
	p.tilt_max_rad = s(unit_rand_uniform(g, 0.1, 0.6));
	return p;
}

/* the law of pos_ctrl.h in double on the represented inputs; returns the flags */
static uint32_t ref_law(const struct pos_ctrl_params *p, const struct pos_ctrl_input *in, double *roll, double *pitch)
{
	uint32_t f = 0;
	double a[2];
	for (int i = 0; i < 2; i++) {
		double v = d(p->pos_gain_rps) * (d(in->pos_sp_m[i]) - d(in->pos_m[i]));
		if (fabs(v) > d(p->vel_max_mps))
			f |= POS_CTRL_VEL_LIM;
		v = clampd(v, d(p->vel_max_mps));
		a[i] = d(p->vel_gain_rad_mps) * (v - d(in->vel_mps[i]));
	}
	double w = d(in->q_b2i.w), x = d(in->q_b2i.x), y = d(in->q_b2i.y), z = d(in->q_b2i.z);
	double yaw = atan2(2 * (x * y + w * z), 1 - 2 * (y * y + z * z));
	double fwd = cos(yaw) * a[0] + sin(yaw) * a[1], left = -sin(yaw) * a[0] + cos(yaw) * a[1];
	double tm = d(p->tilt_max_rad);
	if (fabs(fwd) > tm || fabs(left) > tm)
		f |= POS_CTRL_TILT_LIM;
	*pitch = clampd(fwd, tm);
	*roll = clampd(-left, tm);
	return f;
}

UNIT_TEST(pos_ctrl_law_matches_double_reference)
{
	struct unit_rng g = {0x9051ULL};
	int n_vel = 0, n_tilt = 0;
	for (int k = 0; k < 2000; k++) {
		struct pos_ctrl_params p = random_params(&g);
		struct pos_ctrl_input in;
		double e = k % 2 ? 2.0 : 30.0; /* small errors (linear) and large ones (limits) */
		for (int i = 0; i < 2; i++) {
			in.pos_m[i] = s(unit_rand_uniform(&g, -500, 500));
			in.pos_sp_m[i] = s(d(in.pos_m[i]) + unit_rand_uniform(&g, -e, e));
			in.vel_mps[i] = s(unit_rand_uniform(&g, -3, 3));
		}
		in.q_b2i = tq_from_euler(s(unit_rand_uniform(&g, -0.6, 0.6)), s(unit_rand_uniform(&g, -0.6, 0.6)),
					 s(unit_rand_uniform(&g, -3.1, 3.1)));
		struct pos_ctrl_output o = pos_ctrl_update(&p, &in);
		double roll, pitch;
		uint32_t f = ref_law(&p, &in, &roll, &pitch);
		double tol = OCTO_FIXED ? 2e-3 : 2e-5;
		CHECK_NEAR(d(o.roll_rad), roll, tol);
		CHECK_NEAR(d(o.pitch_rad), pitch, tol);
		CHECK(fabs(d(o.roll_rad)) <= d(p.tilt_max_rad) && fabs(d(o.pitch_rad)) <= d(p.tilt_max_rad));
		/* flags as the reference's, except within rounding of a limit */
		double vm = d(p.vel_max_mps), margin = OCTO_FIXED ? 1e-3 : 1e-5;
		bool near = false;
		for (int i = 0; i < 2; i++)
			near = near ||
			       fabs(fabs(d(p.pos_gain_rps) * (d(in.pos_sp_m[i]) - d(in.pos_m[i]))) - vm) < margin;
		if (!near)
			CHECK((o.flags & POS_CTRL_VEL_LIM) == (f & POS_CTRL_VEL_LIM));
		if (fabs(fabs(roll) - d(p.tilt_max_rad)) > tol && fabs(fabs(pitch) - d(p.tilt_max_rad)) > tol)
			CHECK((o.flags & POS_CTRL_TILT_LIM) == (f & POS_CTRL_TILT_LIM));
		n_vel += (f & POS_CTRL_VEL_LIM) != 0;
		n_tilt += (f & POS_CTRL_TILT_LIM) != 0;
	}
	CHECK(n_vel > 200 && n_vel < 1800 && n_tilt > 200 && n_tilt < 1800); /* both sides of each limit */
}

UNIT_TEST(pos_ctrl_heading_is_quat_yaw)
{
	struct unit_rng g = {0x4ead1ULL};
	for (int k = 0; k < 1000; k++) {
		struct quat q = tq_from_euler(s(unit_rand_uniform(&g, -1.2, 1.2)), s(unit_rand_uniform(&g, -1.2, 1.2)),
					      s(unit_rand_uniform(&g, -3.14, 3.14)));
		scalar_t c, sn;
		pos_ctrl_heading(q, &c, &sn);
		double yaw = d(quat_yaw(q)), tol = OCTO_FIXED ? 1e-3 : 1e-5;
		CHECK_NEAR(d(c), cos(yaw), tol);
		CHECK_NEAR(d(sn), sin(yaw), tol);
	}
	/* nose straight up: no heading, yaw 0 */
	scalar_t c, sn;
	pos_ctrl_heading(tq_from_euler(SC(0), SC(-1.5707963), SC(0.7)), &c, &sn);
	CHECK(fabs(d(c)) <= 1.0 && fabs(d(sn)) <= 1.0);
	pos_ctrl_heading(tq_from_euler(SC(0), SC(0), SC(0)), &c, &sn);
	CHECK_NEAR(d(c), 1.0, 1e-4);
	CHECK_NEAR(d(sn), 0.0, 1e-4);
}

/* Point mass: the tilt follows the set point through one frame of delay and a first-order
 * lag (0.15 s, the attitude loop), horizontal acceleration g tan(tilt) along the heading's
 * axes. From a random offset (3-8 m), velocity and heading, with random gains around the
 * defaults: tilt within tilt_max, speed within 1.2 vel_max, no overshoot beyond 10 % of the
 * offset, within 5 cm after 25 s. */
UNIT_TEST(pos_ctrl_closed_loop_holds)
{
	struct unit_rng g = {0xc105eULL};
	for (int run = 0; run < 12; run++) {
		struct pos_ctrl_params p = pos_ctrl_params_default();
		p.pos_gain_rps = s(d(p.pos_gain_rps) * unit_rand_uniform(&g, 0.7, 1.4));
		p.vel_gain_rad_mps = s(d(p.vel_gain_rad_mps) * unit_rand_uniform(&g, 0.7, 1.4));
		double yaw = unit_rand_uniform(&g, -3.1, 3.1), ang = unit_rand_uniform(&g, -3.1, 3.1);
		double r0 = unit_rand_uniform(&g, 3, 8);
		double pos[2] = {r0 * cos(ang), r0 * sin(ang)},
		       vel[2] = {unit_rand_uniform(&g, -1, 1), unit_rand_uniform(&g, -1, 1)};
		double tilt[2] = {0, 0}, cmd_prev[2] = {0, 0}; /* pitch, roll */
		struct pos_ctrl_input in;
		in.pos_sp_m[0] = in.pos_sp_m[1] = SC_ZERO;
		in.q_b2i = tq_from_euler(SC(0), SC(0), s(yaw));
		double max_tilt = 0, max_speed = 0, max_past = 0;
		const double lag = 0.15, vmax = d(p.vel_max_mps);
		int n = (int)(40.0 / FRAME_S);
		for (int k = 0; k < n; k++) {
			for (int i = 0; i < 2; i++) {
				in.pos_m[i] = s(pos[i]);
				in.vel_mps[i] = s(vel[i]);
			}
			struct pos_ctrl_output o = pos_ctrl_update(&p, &in);
			double cmd[2] = {d(o.pitch_rad), d(o.roll_rad)};
			for (int i = 0; i < 2; i++) {
				tilt[i] += (cmd_prev[i] - tilt[i]) * (1 - exp(-FRAME_S / lag));
				cmd_prev[i] = cmd[i];
				max_tilt = fmax(max_tilt, fabs(cmd[i]));
			}
			double fwd = G_MPS2 * tan(tilt[0]), left = -G_MPS2 * tan(tilt[1]);
			double acc[2] = {cos(yaw) * fwd - sin(yaw) * left, sin(yaw) * fwd + cos(yaw) * left};
			for (int i = 0; i < 2; i++) {
				vel[i] += acc[i] * FRAME_S;
				pos[i] += vel[i] * FRAME_S;
			}
			max_speed = fmax(max_speed, hypot(vel[0], vel[1]));
			/* overshoot: how far past the set point along the start direction */
			double past = -(pos[0] * cos(ang) + pos[1] * sin(ang));
			max_past = fmax(max_past, past);
		}
		CHECK(max_tilt <= d(p.tilt_max_rad) + 1e-6);
		CHECK(max_speed < 1.2 * vmax * sqrt(2.0));
		CHECK(max_past < 0.10 * r0);
		CHECK(hypot(pos[0], pos[1]) < 0.05);
	}
}

/* A non-finite input (float build) gives level set points and a flag. */
UNIT_TEST(pos_ctrl_nan_guard)
{
#if OCTO_FIXED
	(void)u; /* Q16.16 has no NaN */
#else
	struct pos_ctrl_params p = pos_ctrl_params_default();
	struct pos_ctrl_input in = {{0, 0}, {1, 2}, {0.5f, 0}, tq_identity()};
	in.vel_mps[1] = __builtin_nanf("");
	struct pos_ctrl_output o = pos_ctrl_update(&p, &in);
	CHECK(o.flags == POS_CTRL_BAD_INPUT && o.roll_rad == 0 && o.pitch_rad == 0);
#endif
}
