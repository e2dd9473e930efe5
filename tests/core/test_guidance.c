/* Tests of firmware/core/guidance.h: the take-off profile (rate and acceleration limits, the
 * target reached exactly, hold entry only when there, still and ready), retries, landing
 * (descent rate, floor, touch-down time, interrupted touch-downs), and the level set points
 * near the ground. Random heights, rates and time steps; both builds. */
#include "unit_scalar.h"
#include "guidance.h"
#include "unit.h"

#include <math.h>

static scalar_t s(double x) { return sc_from_float((float)x); }

/* one random case: rates, touch-down time and profile acceleration, the ground's height, a
 * take-off height in [h_min, 30] m and a time step */
struct rcase {
	struct guid_params p;
	double ground, h, dt;
};

static struct rcase random_case(struct unit_rng *g, double h_min)
{
	struct rcase c;
	c.p = guid_params_default();
	c.p.tko_vel_mps = s(unit_rand_uniform(g, 0.3, 4.0));
	c.p.land_vel_mps = s(unit_rand_uniform(g, 0.2, 2.5));
	c.p.touch_down_s = s(unit_rand_uniform(g, 0.3, 3.0));
	c.p.profile_acc_mps2 = s(unit_rand_uniform(g, 0.3, 2.0));
	c.ground = unit_rand_uniform(g, -20, 50);
	c.h = unit_rand_uniform(g, h_min, 30);
	c.dt = unit_rand_uniform(g, 0.008, 0.014);
	return c;
}

UNIT_TEST(guid_takeoff_profile)
{
	struct unit_rng g = {0x7a6eULL};
	for (int run = 0; run < 40; run++) {
		struct rcase rc = random_case(&g, 0.5);
		const struct guid_params p = rc.p;
		const double ground = rc.ground, h = rc.h, dt = rc.dt;
		struct guid gd;
		guid_init(&gd, &p);
		scalar_t pos[3] = {s(unit_rand_uniform(&g, -9, 9)), s(unit_rand_uniform(&g, -9, 9)), s(ground)};
		guid_arm(&gd, pos, s(0.4));
		guid_ground(&gd, s(ground), true);
		CHECK(guid_takeoff(&gd, GUID_GROUND, s(h), pos, s(0.7)));
		CHECK(gd.pos_sp_m[0] == pos[0] && gd.pos_sp_m[1] == pos[1] && gd.yaw_sp_rad == s(0.7));
		CHECK(guid_level_only(&gd, GUID_TAKEOFF, s(ground + 0.1)));
		CHECK(!guid_level_only(&gd, GUID_TAKEOFF, s(ground + 0.5)));
		CHECK(!guid_level_only(&gd, GUID_HOLD, s(ground + 0.1)));
		double vmax = d(p.tko_vel_mps), acc = d(p.profile_acc_mps2), q = OCTO_FIXED ? 2e-4 : 1e-5;
		double prev_sp = d(gd.z_sp_m), prev_v = 0, t = 0;
		int steps = 0, reached = -1;
		struct guid_input in = {s(ground), SC_ZERO, s(dt), false};
		for (int k = 0; k < 100000 && reached < 0; k++) {
			uint32_t ev = guid_update(&gd, GUID_TAKEOFF, &in);
			double sp = d(gd.z_sp_m), v = d(gd.vz_ff_mps);
			CHECK(v >= -q && v <= vmax + q); /* climbs, never faster */
			/* no jump in the rate: acc dt a step; braking on sqrt(2 acc d) with d sampled a
			 * step apart brakes by up to acc dt (1 + acc dt / v); the profile snaps to the
			 * target from a rate below 8 acc dt (measured: up to 7) */
			double adt = acc * dt;
			if (v == 0 && sp == d(gd.z_target_m))
				CHECK(prev_v <= 8 * adt);
			else
				CHECK(fabs(v - prev_v) <= adt * (1 + adt / fmax(fmin(v, prev_v), adt)) + q);
			CHECK(sp >= prev_sp - q && sp <= ground + h + q); /* monotonic, never past */
			prev_sp = sp, prev_v = v, t += dt, steps++;
			in.z_m = gd.z_sp_m; /* a vehicle that follows */
			if (sp == d(gd.z_target_m)) {
				/* at the target: no hold before the vehicle is there, still and ready */
				in.vz_mps = s(0.5);
				CHECK(guid_update(&gd, GUID_TAKEOFF, &in) == 0);
				in.vz_mps = SC_ZERO;
				in.hold_ready = false;
				CHECK(guid_update(&gd, GUID_TAKEOFF, &in) == 0);
				in.hold_ready = true;
				in.z_m = s(ground + h - 0.2);
				CHECK(guid_update(&gd, GUID_TAKEOFF, &in) == 0);
				in.z_m = gd.z_sp_m;
				ev = guid_update(&gd, GUID_TAKEOFF, &in);
				CHECK(ev == GUID_HOLD_REACHED);
				reached = k;
			} else {
				CHECK(ev == 0);
			}
		}
		CHECK(reached >= 0);
		CHECK_NEAR(d(gd.z_target_m), ground + h, 1e-3);
		/* a trapezoid takes at least h / vmax and about h / vmax + vmax / acc */
		double t_min = h / vmax, t_max = h / vmax + vmax / acc + 0.5;
		CHECK(t >= t_min - dt && t <= t_max);
		/* a retry of the same target changes nothing; another one starts from the target */
		CHECK(!guid_takeoff(&gd, GUID_HOLD, s(h + 0.005), pos, SC_ZERO));
		CHECK(guid_takeoff(&gd, GUID_HOLD, s(h + 2), pos, SC_ZERO));
		CHECK_NEAR(d(gd.z_sp_m), ground + h, 1e-3);
		CHECK(gd.yaw_sp_rad == s(0.7)); /* the heading of the first take-off stays */
	}
}

UNIT_TEST(guid_takeoff_down_and_hold)
{
	struct guid_params p = guid_params_default();
	struct guid gd;
	guid_init(&gd, &p);
	scalar_t pos[3] = {SC(0), SC(0), SC(0)};
	guid_arm(&gd, pos, SC_ZERO);
	pos[2] = SC(10);
	CHECK(guid_takeoff(&gd, GUID_GROUND, SC(10), pos, SC_ZERO));
	CHECK(guid_takeoff(&gd, GUID_TAKEOFF, SC(4), pos, SC_ZERO)); /* a lower target: descends */
	struct guid_input in = {SC(10), SC_ZERO, s(1.0 / 90), true};
	guid_update(&gd, GUID_TAKEOFF, &in);
	CHECK(gd.vz_ff_mps < SC_ZERO && gd.z_sp_m < SC(10));
	guid_update(&gd, GUID_HOLD, &in);
	CHECK(gd.z_sp_m == gd.z_target_m && gd.vz_ff_mps == SC_ZERO);
}

UNIT_TEST(guid_landing)
{
	struct unit_rng g = {0x1a4dULL};
	for (int run = 0; run < 40; run++) {
		struct rcase rc = random_case(&g, 1.0);
		const struct guid_params p = rc.p;
		const double ground = rc.ground, h = rc.h, dt = rc.dt, vl = d(p.land_vel_mps);
		struct guid gd;
		guid_init(&gd, &p);
		double q = OCTO_FIXED ? 2e-4 : 1e-5;
		scalar_t pos[3] = {SC_ZERO, SC_ZERO, s(ground)};
		guid_arm(&gd, pos, SC_ZERO);
		gd.z_sp_m = s(ground + h + 1); /* the set point above the vehicle: landing starts at it */
		guid_land(&gd, s(ground + h));
		CHECK_NEAR(d(gd.z_sp_m), ground + h, q);
		struct guid_input in = {s(ground + h), SC_ZERO, s(dt), false};
		double prev = d(gd.z_sp_m), t_ground = 0;
		int landed = -1, bounced = 0;
		for (int k = 0; k < 200000 && landed < 0; k++) {
			uint32_t ev = guid_update(&gd, GUID_LAND, &in);
			double sp = d(gd.z_sp_m);
			CHECK(sp >= ground - d(p.land_floor_m) - q);       /* floor below the ground */
			CHECK(sp <= prev + q && prev - sp <= vl * dt + q); /* down at land_vel at most */
			CHECK_NEAR(d(gd.vz_ff_mps), -vl, q);
			prev = sp;
			/* the vehicle follows down to the ground; one bounce half way through the touch-down */
			double z = fmax(sp, ground);
			if (z <= ground && !bounced && t_ground > 0.5 * d(p.touch_down_s)) {
				z = ground + 0.3;
				bounced = 1;
				t_ground = 0;
			} else if (z <= ground + 0.1) {
				t_ground += dt;
			}
			in.z_m = s(z);
			if (ev == GUID_LANDED)
				landed = k;
		}
		CHECK(landed >= 0 && bounced);
		/* landed only after touch_down_s on the ground since the bounce */
		CHECK(t_ground >= d(p.touch_down_s) - 2 * dt && t_ground <= d(p.touch_down_s) + 3 * dt);
	}
}

UNIT_TEST(guid_on_the_ground)
{
	struct guid gd;
	struct guid_params p = guid_params_default();
	guid_init(&gd, &p);
	guid_ground(&gd, SC(3), true);
	CHECK(gd.z_ground_m == SC(3) && gd.z_sp_m == SC(3));
	struct guid_input in = {SC(2.5), SC(0.3), s(1.0 / 90), true};
	CHECK(guid_update(&gd, GUID_GROUND, &in) == 0);
	CHECK(gd.z_sp_m == SC(2.5) && gd.vz_ff_mps == SC_ZERO && gd.z_ground_m == SC(3));
	/* a take-off from a landing starts at the vehicle, with no feedforward */
	scalar_t pos[3] = {SC(1), SC(2), SC(6)};
	gd.vz_ff_mps = SC(-0.7);
	CHECK(guid_takeoff(&gd, GUID_LAND, SC(5), pos, SC_ZERO));
	CHECK(gd.z_sp_m == SC(6) && gd.vz_ff_mps == SC_ZERO && gd.z_target_m == SC(8));
}
