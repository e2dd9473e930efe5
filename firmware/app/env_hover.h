/*
 * env_hover.h - the hover throttle learned in flight (core/hover_est), and what it gives
 * the step: the height controller's hover thrust 8 VEH_KF u_h, and the gain on the attitude
 * loop's torque demands that takes out the throttle map's error at hover. Between frames:
 * the HOV_* values of a HOLD entry, and the VEH_KF seed before a rotor experiment.
 * Why: docs/octo-fw.md, "Flight envelope".
 *
 * Knows nothing of the app: it reads its inputs and the parameters, and what it asks of
 * the app (parameters to write, a status line to post) is in its outputs.
 *
 * What hover learning and the k_f tracker (env_kf.h) measure the thrust with (ID_SOURCE):
 * the rotors' thrust rows, or the accelerometer. With the thrust rows the hover is learnt
 * from the vertical speed's derivative and the tracker sums the rows; with the accelerometer
 * both read the specific force along the body's z axis, a_z (g), whose total thrust is
 * VEH_MASS VEH_GRAV a_z. The accelerometer is calibrated on the ground: at rest it reads
 * exactly 1 g, so the mean of the ground frames' a_z before a take-off gives the factor
 * 1 / mean that takes its bias and scale error out at 1 g (where a hover reads). That
 * calibration survives env_hover_init (a take-off restarts the learning, not it).
 */
#ifndef OCTO_ENV_HOVER_H
#define OCTO_ENV_HOVER_H

#include <stdbool.h>

#include "hal.h"
#include "hover_est.h"
#include "params.h"
#include "sc_recip.h"
#include "vec3.h"

/* What the thrust is measured with (env_src_of). */
enum env_src {
	ENV_SRC_NONE = 0,   /* neither: the hover from the vertical speed, no tracking */
	ENV_SRC_THRUST = 1, /* the rotors' thrust rows */
	ENV_SRC_IMU = 2,    /* the accelerometer */
};

/* ID_SOURCE (0 auto, 1 thrust, 2 imu, 3 imu_rpm, 4 imu_rpm_torque) against what the frames
 * deliver: `rows` thrust rows seen since start, `acc` an accelerometer. Auto takes the rows
 * when the plant serves them, else the accelerometer. */
static inline enum env_src env_src_of(float id_source, bool rows, bool acc)
{
	if (id_source >= 1.5f)
		return ENV_SRC_IMU;
	if (id_source >= 0.5f)
		return ENV_SRC_THRUST;
	return rows ? ENV_SRC_THRUST : acc ? ENV_SRC_IMU : ENV_SRC_NONE;
}

/* The accelerometer's calibration on the ground (zeroed with the app, kept by env_hover_init). */
struct env_acc_cal {
	scalar_t sum;   /* sum of a_z - 1 (g) over the ground frames of the block under way */
	uint32_t n;     /* frames in it */
	scalar_t fac;   /* 1 / (1 + mean): the correction of a_z (valid with `have`) */
	double t_s;     /* plant time of the calibration */
	uint32_t n_cal; /* ground frames it averaged */
	bool have;      /* a calibration exists */
	bool rows;      /* thrust rows seen in a frame since start */
};

struct env_hover {
	struct hover_est hov;
	struct env_acc_cal cal;
	bool pub_due;          /* a HOLD entry's HOV_* wait for env_hover_publish */
	double pub_t_s;        /* plant time of that entry (the calibration's age) */
	scalar_t kf8;          /* 8 VEH_KF (N at full throttle, all rotors) */
	struct sc_recip kf8_r; /* its reciprocal, for the step's division by it */
	/* the hover thrust kf8 / theta of the last step and its operands: the division is redone
	 * only when one changed (theta stays while the estimator only tracks) */
	scalar_t hf_kf8, hf_theta, hf;
	bool hf_ok;
	/* the torque demands' gain: the target set between frames, the value the step applies */
	scalar_t tau_k_target, tau_k;
};

/* One step's inputs (scalars of this frame). */
struct env_hover_input {
	scalar_t f_achieved;  /* the collective thrust the mixer achieved last step, N */
	scalar_t acc_z_g;     /* the accelerometer's specific force along body z, g (calibrated: env_hover_acc) */
	enum env_src src;     /* what the thrust is measured with */
	bool acc_ok;          /* this frame has the accelerometer */
	scalar_t z_m, vz_mps; /* height and vertical speed */
	scalar_t z_ground_m;  /* the take-off ground */
	scalar_t cos_tilt;    /* the body's z axis, up component */
	scalar_t dt_s;
	bool learn_mode;    /* TAKEOFF, HOLD or LAND: airborne measurements teach */
	bool takeoff_climb; /* TAKEOFF with a set point above the vehicle (spool up) */
};

/* A HOLD entry's publication: HOV_THR, HOV_THR_SD, HOV_KF, HOV_KF_SD and a status line;
 * alloc: the torques are allocated with the learned k_f (env_hover_alloc_learned), a second line. */
struct env_hover_pub {
	float u, sd, kf, kf_sd;
	bool alloc;
	float tau_k; /* the torque gain it aims at (env_hover_torque_scale) */
};

/* Every stepped frame, before the flying steps: notes thrust rows (valid: HAL_FRAME_* bits)
 * and, on the ground (disarmed or idle, `ground`), takes the accelerometer's a_z (g) into its
 * calibration; the first frame off the ground ends the calibration's block. */
void env_hover_sense(struct env_hover *h, uint32_t valid, scalar_t acc_z_g, bool ground, double t_s);
/* The calibrated a_z (g): a_z itself before any calibration. */
static inline scalar_t env_hover_acc(const struct env_hover *h, scalar_t acc_z_g)
{
	return h->cal.have ? sc_mul(acc_z_g, h->cal.fac) : acc_z_g;
}
/* What the thrust is measured with under ID_SOURCE, given the frame's bits. */
static inline enum env_src env_hover_src(const struct env_hover *h, const struct app_params *p, uint32_t valid)
{
	return env_src_of(p->id_source, h->cal.rows, (valid & HAL_FRAME_ACCEL) != 0);
}

/* From the parameters: the estimator starts at m g / (8 VEH_KF); the torque gain at 1. */
void env_hover_init(struct env_hover *h, const struct app_params *p);
/* After a parameter change: what the step reads of VEH_KF. */
void env_hover_model_sync(struct env_hover *h, const struct app_params *p);

/* Once per flying step, before the height controller: learns from the last step and returns
 * the hover thrust demand in the mixer's newtons, 8 VEH_KF u_h. *up: above the take-off
 * ground by more than the airborne margin. */
scalar_t env_hover_step(struct env_hover *h, const struct env_hover_input *in, bool *up);

/* Nothing learned yet (no airborne measurement since the last init). */
static inline bool env_hover_untaught(const struct env_hover *h) { return h->hov.updates == 0; }
/* Take-off may end (HOLD) once the hover throttle is known to 3 % (relative sd). */
bool env_hover_ready(const struct env_hover *h);

/* On entering HOLD at plant time t_s: what the hover taught is due for env_hover_publish. */
void env_hover_on_hold(struct env_hover *h, double t_s);
/* Between frames: true (and *out) once after a HOLD entry: the hover throttle moved ahead by
 * its lag and its sd (hover_est.h), computed here rather than in the entry's step, with, when
 * it learnt from the calibrated accelerometer, what its innovations cannot see: the
 * calibration's error, (KFT_ACC_NOISE / VEH_GRAV)^2 / n_cal (the mean of n_cal ground
 * frames), and the bias's walk since, (KFT_ACC_WALK / VEH_GRAV)^2 (t_s - t_cal), both
 * relative to the 1 g a hover reads; added to hover_est_sd_err's variance. */
bool env_hover_publish(struct env_hover *h, const struct app_params *p, struct env_hover_pub *out);

/* Between frames: the torque demands' gain, from the hover throttle learned so far (1 until
 * it is known): r = 8 VEH_KF u_h / (m g), the map's thrust at hover over the thrust that holds
 * the vehicle, i.e. VEH_KF over the k_f learned at hover. Below 1 it is r (down to 0.1): the
 * map overrates the rotors' effectiveness. Above 1 it is r / 2, at least 1 (up to 10): r is a
 * secant, and the slope the loop feels is steeper by up to about half again with a thrust curve
 * (a curve of 0.54 at a hover throttle of 0.52 puts r at 2.1 where the slope's ratio is 1.5),
 * so only what no curve explains is corrected; a torque left up to twice too weak flies,
 * five times too weak does not (the attitude loop, its integral and the position loop
 * around it then oscillate), and one too strong oscillates too. */
void env_hover_torque_scale(struct env_hover *h, const struct app_params *p);
/* The gain's target is above 1, or below 1/2 (beyond what an earlier build allowed): said at
 * the HOLD entry. VEH_KF itself stays. */
bool env_hover_alloc_learned(const struct env_hover *h);
/* In the step: the torque demand with that gain (moving 2 % of the way to its target per step). */
struct vec3 env_hover_torque(struct env_hover *h, struct vec3 tau);

/* Before experiment `id`: true with *kf = m g / (8 u_h) when NAV_KF_SEED asks for it, the
 * experiment identifies the rotors, the hover is known and VEH_KF is more than 10 % off. */
bool env_hover_seed_kf(const struct env_hover *h, const struct app_params *p, int id, float *kf);

#endif /* OCTO_ENV_HOVER_H */
