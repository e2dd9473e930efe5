/*
 * guidance.h - the height and horizontal set points of take-off, hold and landing.
 *
 * The autopilot's modes decide what is flown; guidance turns that into set points for
 * alt_ctrl (z_sp, vz_ff) and pos_ctrl / att_ctrl (pos_sp, yaw_sp), one update per step:
 *   GUID_TAKEOFF  a trapezoidal height profile from z_sp to z_target: the climb rate
 *                 vz_ff = min(tko_vel, sqrt(2 acc |d|), |vz_ff| + acc dt) accelerates and
 *                 brakes at profile_acc, so neither the set point nor its feedforward jumps;
 *                 at the target it reports GUID_HOLD_REACHED once the vehicle is within
 *                 hold_entry_m of it, slower than hold_entry_mps, and the caller says the
 *                 hover is ready (hold_ready).
 *   GUID_HOLD     z_sp = z_target, no feedforward (hold and experiments).
 *   GUID_LAND     z_sp descends at land_vel down to land_floor_m below the ground (so the
 *                 height loop keeps pushing down after touch-down); GUID_LANDED once the
 *                 vehicle has been within landed_h_m of the ground, slower than
 *                 landed_vz_mps, for touch_down_s without interruption.
 * On the ground (disarmed or idle) guid_ground keeps the set points at the vehicle.
 *
 * Units: m, m/s, m/s^2, rad, s; heights z up in S_I. Q16.16: heights within +/-1000 m.
 */
#ifndef OCTO_GUIDANCE_H
#define OCTO_GUIDANCE_H

#include "scalar.h"

#include <stdbool.h>
#include <stdint.h>

enum guid_mode { GUID_GROUND = 0, GUID_TAKEOFF, GUID_HOLD, GUID_LAND };

/* events (the return value of guid_update) */
#define GUID_HOLD_REACHED (1u << 0) /* take-off finished: the caller may hold */
#define GUID_LANDED (1u << 1)       /* landing finished: the caller may stop the motors */

struct guid_params {
	scalar_t tko_vel_mps;      /* climb rate of take-off (> 0) */
	scalar_t land_vel_mps;     /* descent rate of landing (> 0) */
	scalar_t touch_down_s;     /* landing: time on the ground before GUID_LANDED */
	scalar_t profile_acc_mps2; /* take-off profile acceleration and braking (> 0) */
	scalar_t hold_entry_m;     /* take-off ends within this of the target ... */
	scalar_t hold_entry_mps;   /* ... and slower than this */
	scalar_t landed_h_m;       /* landing: "on the ground" below this height above ground ... */
	scalar_t landed_vz_mps;    /* ... and slower than this */
	scalar_t level_h_m;        /* take-off: level set points below this height above ground */
	scalar_t land_floor_m;     /* landing: the set point stops this far below the ground */
};

struct guid {
	struct guid_params p;
	scalar_t z_ground_m;  /* height of the ground (where the vehicle was armed or idled) */
	scalar_t z_target_m;  /* height of take-off and hold */
	scalar_t z_sp_m;      /* height set point */
	scalar_t vz_ff_mps;   /* its rate (feedforward of the height loop) */
	scalar_t pos_sp_m[2]; /* horizontal set point, x and y of S_I */
	scalar_t yaw_sp_rad;  /* heading set point */
	scalar_t on_ground_s; /* landing: time spent touched down */
};

struct guid_input {
	scalar_t z_m;    /* measured height */
	scalar_t vz_mps; /* measured vertical speed (up) */
	scalar_t dt_s;   /* time since the last update */
	bool hold_ready; /* take-off may end (e.g. the hover thrust is known) */
};

/* Defaults of octo-fw: take-off 1.5 m/s, landing 0.7 m/s, touch-down 1 s, profile
 * 0.5 m/s^2, hold entry 5 cm and 0.1 m/s, landed below 0.2 m and 0.25 m/s, level below
 * 0.3 m, landing floor 1 m. */
#define GUID_DEFAULT_TKO_VEL_MPS 1.5f
#define GUID_DEFAULT_LAND_VEL_MPS 0.7f
#define GUID_DEFAULT_TOUCH_DOWN_S 1.0f
struct guid_params guid_params_default(void);

/* Copies params; every set point at zero. */
void guid_init(struct guid *g, const struct guid_params *params);

/* On the ground (disarmed or idle), each step: the height set point at the vehicle, no
 * feedforward; set_ground: the ground is here (idle). */
void guid_ground(struct guid *g, scalar_t z_m, bool set_ground);

/* Arming: the ground, the horizontal set point and the heading are where the vehicle is. */
void guid_arm(struct guid *g, const scalar_t pos_m[3], scalar_t yaw_rad);

/* A take-off to height_m above the ground from mode `from` (GUID_GROUND: idle on the
 * ground, the set points start at the vehicle; GUID_LAND: the profile starts at the
 * vehicle's height; GUID_TAKEOFF / GUID_HOLD: from the current set point). Returns false,
 * changing nothing, for a retry of the same target (within 1 cm) while in the air. */
bool guid_takeoff(struct guid *g, enum guid_mode from, scalar_t height_m, const scalar_t pos_m[3], scalar_t yaw_rad);

/* A landing from the air: the set point starts no higher than the vehicle. */
void guid_land(struct guid *g, scalar_t z_m);

/* One step in mode m (see above); returns GUID_* events. */
uint32_t guid_update(struct guid *g, enum guid_mode m, const struct guid_input *in);

/* Whether the attitude set points should be level (take-off still near the ground). */
bool guid_level_only(const struct guid *g, enum guid_mode m, scalar_t z_m);

#endif /* OCTO_GUIDANCE_H */
