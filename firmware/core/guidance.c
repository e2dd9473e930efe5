/* guidance.c - see guidance.h for the set points, units and frames. */
#include "guidance.h"

struct guid_params guid_params_default(void)
{
	const struct guid_params p = {
		.tko_vel_mps = SC(GUID_DEFAULT_TKO_VEL_MPS),
		.land_vel_mps = SC(GUID_DEFAULT_LAND_VEL_MPS),
		.touch_down_s = SC(GUID_DEFAULT_TOUCH_DOWN_S),
		.profile_acc_mps2 = SC(0.5),
		.hold_entry_m = SC(0.05),
		.hold_entry_mps = SC(0.1),
		.landed_h_m = SC(0.2),
		.landed_vz_mps = SC(0.25),
		.level_h_m = SC(0.3),
		.land_floor_m = SC(1.0),
	};
	return p;
}

void guid_init(struct guid *g, const struct guid_params *params)
{
	struct guid z = {0};
	*g = z;
	g->p = *params;
}

void guid_ground(struct guid *g, scalar_t z_m, bool set_ground)
{
	if (set_ground)
		g->z_ground_m = z_m;
	g->z_sp_m = z_m;
	g->vz_ff_mps = SC_ZERO;
}

void guid_arm(struct guid *g, const scalar_t pos_m[3], scalar_t yaw_rad)
{
	g->z_ground_m = pos_m[2];
	g->pos_sp_m[0] = pos_m[0];
	g->pos_sp_m[1] = pos_m[1];
	g->yaw_sp_rad = yaw_rad;
}

bool guid_takeoff(struct guid *g, enum guid_mode from, scalar_t height_m, const scalar_t pos_m[3], scalar_t yaw_rad)
{
	scalar_t target = sc_add(g->z_ground_m, height_m);
	switch (from) {
	case GUID_GROUND:
		g->z_sp_m = pos_m[2];
		g->pos_sp_m[0] = pos_m[0];
		g->pos_sp_m[1] = pos_m[1];
		g->yaw_sp_rad = yaw_rad;
		break;
	case GUID_LAND:
		g->z_sp_m = pos_m[2];
		g->vz_ff_mps = SC_ZERO;
		break;
	case GUID_TAKEOFF:
	case GUID_HOLD:
		if (sc_abs(sc_sub(target, g->z_target_m)) < SC(0.01))
			return false; /* a retry: nothing changes */
		if (from == GUID_HOLD)
			g->z_sp_m = g->z_target_m;
		break;
	}
	g->z_target_m = target;
	g->on_ground_s = SC_ZERO;
	return true;
}

void guid_land(struct guid *g, scalar_t z_m)
{
	g->z_sp_m = sc_min(g->z_sp_m, z_m);
	g->vz_ff_mps = SC_ZERO;
	g->on_ground_s = SC_ZERO;
}

static uint32_t takeoff_step(struct guid *g, const struct guid_input *in)
{
	const struct guid_params *p = &g->p;
	scalar_t dt = in->dt_s;
	scalar_t d = sc_sub(g->z_target_m, g->z_sp_m), ad = sc_abs(d);
	scalar_t v =
		sc_min(sc_min(p->tko_vel_mps, sc_sqrt(sc_mul(sc_add(p->profile_acc_mps2, p->profile_acc_mps2), ad))),
		       sc_add(sc_abs(g->vz_ff_mps), sc_mul(p->profile_acc_mps2, dt)));
	if (ad <= sc_mul(v, dt) || ad < SC(1e-3)) {
		g->z_sp_m = g->z_target_m;
		g->vz_ff_mps = SC_ZERO;
		if (sc_abs(sc_sub(in->z_m, g->z_target_m)) < p->hold_entry_m &&
		    sc_abs(in->vz_mps) < p->hold_entry_mps && in->hold_ready)
			return GUID_HOLD_REACHED;
		return 0;
	}
	g->vz_ff_mps = d > SC_ZERO ? v : sc_neg(v);
	g->z_sp_m = sc_add(g->z_sp_m, sc_mul(g->vz_ff_mps, dt));
	return 0;
}

static uint32_t land_step(struct guid *g, const struct guid_input *in)
{
	const struct guid_params *p = &g->p;
	g->z_sp_m =
		sc_max(sc_sub(g->z_sp_m, sc_mul(p->land_vel_mps, in->dt_s)), sc_sub(g->z_ground_m, p->land_floor_m));
	g->vz_ff_mps = sc_neg(p->land_vel_mps);
	if (sc_sub(in->z_m, g->z_ground_m) < p->landed_h_m && sc_abs(in->vz_mps) < p->landed_vz_mps)
		g->on_ground_s = sc_add(g->on_ground_s, in->dt_s);
	else
		g->on_ground_s = SC_ZERO;
	return g->on_ground_s > p->touch_down_s ? GUID_LANDED : 0;
}

uint32_t guid_update(struct guid *g, enum guid_mode m, const struct guid_input *in)
{
	switch (m) {
	case GUID_GROUND: guid_ground(g, in->z_m, false); return 0;
	case GUID_TAKEOFF: return takeoff_step(g, in);
	case GUID_HOLD:
		g->z_sp_m = g->z_target_m;
		g->vz_ff_mps = SC_ZERO;
		return 0;
	case GUID_LAND: return land_step(g, in);
	}
	return 0;
}

bool guid_level_only(const struct guid *g, enum guid_mode m, scalar_t z_m)
{
	return m == GUID_TAKEOFF && sc_sub(z_m, g->z_ground_m) < g->p.level_h_m;
}
