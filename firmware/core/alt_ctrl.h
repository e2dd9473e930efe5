/*
 * alt_ctrl.h - height controller: total thrust f (N) from height and vertical speed.
 *
 * Law (cascade P on height -> PI on vertical speed, z up, S_I):
 *   vz_cmd = clamp(kz * (z_sp - z), -vz_max_down, +vz_max_up) + vz_ff
 *   a_cmd  = kv * (vz_cmd - vz) + a_int,   a_int += kv * ki * (vz_cmd - vz) * dt
 *   f      = clamp(f_hover * (g + a_cmd) / (g max(cos_tilt, cos_tilt_min)), f_min, f_max)
 * where f_hover is the thrust demand that holds the vehicle in hover: the learned one
 * (hover_est: 8 k_f u_h in the mixer's newtons) when the caller gives it, else mass * g.
 * With a learned f_hover the integrator and its limit +/-a_int_max are relative to the
 * learned hover (the integrator only removes what the estimate has not yet learned), so
 * a thrust scale 0.3x ... 3x the nominal needs no more integral than a correct one.
 * with kv = 2 zeta wn and kz = wn / (2 zeta): with the correct mass and ki = 0 the
 * height loop is s^2 + 2 zeta wn s + wn^2 with no zero (no overshoot for zeta >= 1);
 * ki adds a slow pole near -ki, almost cancelled by the zero at -ki, that removes a
 * mass or thrust-scale error. cos_tilt = quat_body_z_up(q_b2i), the vertical component
 * of the body Z axis (tilt compensation, bounded by cos_tilt_min).
 * Anti-windup: a_int is frozen while f is clamped in the direction the error pushes,
 * or while the allocation could not deliver the thrust in that direction on the previous
 * step (alloc_short_up / _down, e.g. from mixer_shortfall), and clamped to +/-a_int_max.
 *
 * Units: m, m/s, m/s^2, kg, N, s. Q16.16: heights within +/-1000 m and thrusts below
 * 30000 N keep every intermediate in range.
 */
#ifndef OCTO_ALT_CTRL_H
#define OCTO_ALT_CTRL_H

#include "quat.h"
#include "sc_recip.h"

#include <stdint.h>

#define ALT_CTRL_SAT_HIGH (1u << 0)  /* f clamped to f_max */
#define ALT_CTRL_SAT_LOW (1u << 1)   /* f clamped to f_min */
#define ALT_CTRL_VZ_LIM (1u << 2)    /* height part of vz_cmd clamped */
#define ALT_CTRL_TILT_LIM (1u << 3)  /* cos_tilt below cos_tilt_min */
#define ALT_CTRL_INT_LIM (1u << 4)   /* a_int at +/-a_int_max */
#define ALT_CTRL_BAD_INPUT (1u << 5) /* a non-finite input (float build): last f kept */

struct alt_ctrl_params {
	scalar_t wn_rps;          /* closed-loop natural frequency, rad/s (> 0) */
	scalar_t zeta;            /* damping ratio (> 0) */
	scalar_t ki_rps;          /* integral pole, 1/s (0 = none) */
	scalar_t vz_max_up_mps;   /* climb-rate limit of the height loop, m/s */
	scalar_t vz_max_down_mps; /* descent-rate limit of the height loop, m/s (> 0) */
	scalar_t a_int_max_mps2;  /* integral acceleration limit, m/s^2 */
	scalar_t cos_tilt_min;    /* tilt compensation bound, (0, 1] */
	scalar_t f_min_n;         /* thrust limits, N */
	scalar_t f_max_n;
	scalar_t g_mps2; /* gravity, m/s^2 */
};

struct alt_ctrl_input {
	scalar_t z_sp_m;       /* height setpoint (S_I, up), m */
	scalar_t vz_ff_mps;    /* vertical-speed feedforward (takeoff/landing ramps), m/s */
	scalar_t z_m;          /* measured height, m */
	scalar_t vz_mps;       /* measured vertical speed (up), m/s */
	struct quat q_b2i;     /* attitude, for the tilt compensation */
	scalar_t mass_kg;      /* current mass parameter, kg */
	scalar_t hover_f_n;    /* learned hover thrust demand, N (0: use mass * g) */
	scalar_t dt_s;         /* time since the last update, s */
	bool alloc_short_up;   /* the allocation delivered less thrust than demanded (last step) */
	bool alloc_short_down; /* it delivered more thrust than demanded (last step) */
};

struct alt_ctrl {
	struct alt_ctrl_params p;
	scalar_t a_int_mps2; /* integral state (acceleration), m/s^2 */
	scalar_t f_n;        /* last thrust output */
	uint32_t flags;      /* ALT_CTRL_* of the last update */
	/* the parameters' products and quotients, computed when they are set
	 * (alt_ctrl_set_params): no division by a parameter in the update */
	scalar_t m_kv;       /* kv = 2 zeta wn */
	scalar_t m_kz;       /* kz = wn^2 / (2 zeta wn) */
	struct sc_recip r_g; /* 1 / g_mps2 */
};

/* Default gains, the ones octo-fw flies: its parameter table (ALT_WN, ALT_ZETA, ALT_KI)
 * takes its defaults from these. */
#define ALT_CTRL_DEFAULT_WN_RPS 2.5f /* natural frequency, rad/s */
#define ALT_CTRL_DEFAULT_ZETA 1.0f   /* damping ratio */
#define ALT_CTRL_DEFAULT_KI_RPS 0.8f /* integral pole, 1/s */

/* Defaults for the paper's octocopter at 90 Hz (m = 2.132 kg, 8 x 28 N rotors):
 * the gains above (wn 2.5 rad/s, zeta 1.0, ki 0.8 1/s), vz limits +2 / -1.5 m/s, a_int_max 4 m/s^2,
 * cos_tilt_min 0.5, f in [2, 200] N, g 9.796 m/s^2. Measured in tests/core/test_alt_ctrl.c
 * (1 frame delay + 30 ms thrust lag): 1 m step 0 % overshoot, 5 % settling 2.0 s; 10 m
 * step rides the 2 m/s limit, 0 % overshoot, 4.9 s; mass or thrust scale wrong by
 * -20 ... +27 %: hover sag <= 0.23 m recovered (2 cm) in <= 4.7 s, converged steps 0 %. */
struct alt_ctrl_params alt_ctrl_params_default(void);

/* Copies params (alt_ctrl_set_params), zeroes the integral and flags. */
void alt_ctrl_init(struct alt_ctrl *s, const struct alt_ctrl_params *params);

/* Copies params (cos_tilt_min clamped to [0.05, 1]) and prepares their quotients; keeps the
 * integral. Parameters change only through this or alt_ctrl_init, never by assigning p. */
void alt_ctrl_set_params(struct alt_ctrl *s, const struct alt_ctrl_params *params);

/* Sets the integral state (m/s^2, clamped), e.g. 0 before takeoff. */
void alt_ctrl_reset(struct alt_ctrl *s, scalar_t a_int_mps2);

/* One control step (law above): returns the total thrust f in N; flags in s->flags. */
scalar_t alt_ctrl_update(struct alt_ctrl *s, const struct alt_ctrl_input *in);

#endif /* OCTO_ALT_CTRL_H */
