/*
 * imu_scale.h - each rotor's effectiveness from the accelerometer and the gyro against the
 * rotors' measured speeds (ESC telemetry), with its standard deviation.
 *
 * Model: rotor j's thrust is theta_j w_j^2 (w_j its measured speed: the speed already carries
 * the motor's delay, lag and curve), so over the frames
 *
 *   F          = sum_j c_j x_j + o_0                      (m g a_z, N)
 *   d omega_i  = gamma_i sum_j G_ij c_j x_j + o_i,  i = roll, pitch, yaw
 *
 * with x_j = w_j^2 / w_ref^2, c_j rotor j's coefficient, G the geometry (each rotor's roll
 * and pitch arm and yaw sign per newton of its thrust, given as data: only each row's shape
 * enters), gamma_i the unknown gain of axis i (1 / I_x, 1 / I_y, k_tau / (k_f I_z)) and o the
 * offsets (the accelerometer's, the gyro's drift). The force alone sees only sum_j c_j x_j
 * and what the null-space dithers leave of it; the gyro sees each pattern's two opposite
 * pairs apart and, on the yaw axis, the rotors of one spin direction against the other's: the
 * axes together separate every rotor. The effectiveness per w^2 is c_j / median(c); per
 * throttle (MOT_SCALE) it is that times the rotor's speed share (imu_scale_per_throttle).
 *
 * Sums: the rates' change over a window of 2 IMU_SCALE_HALF frames (the torque's integral
 * over it) against the regressors' trapezoid mean over the same frames, and the force's
 * trapezoid mean (one filter on both sides): over a long window the speeds' reaction to the
 * gyro's noise, which the attitude loop feeds back within a few frames, is a small share of
 * their change. One Gram matrix of (x, 1) and a right-hand side per axis, in float per cluster
 * of block_frames (merged in pairs when full) and in double over the run (each cluster added
 * as it completes: the regressors are nearly collinear).
 *
 * Solve (between frames): each axis' own least squares gives its noise variance; the joint
 * model, weighted by them, is fitted by Gauss-Newton from a collective start (the problem is
 * bilinear in c and gamma); the covariance is the larger of the white-noise one and the
 * cluster-robust sandwich (with G / (G - 3) for G clusters), per projection. A rotor whose
 * sd exceeds cfg.sd_max is not separated: the result says which, and publishes nothing.
 * The derivation: docs/identification.md, "Each rotor's effectiveness, with the rotor
 * speeds".
 *
 * Core rules: no heap, globals or I/O. imu_scale_step and imu_scale_hold store the frame;
 * imu_scale_process (the sums) and imu_scale_solve run between frames, in float (solve in
 * double) in both builds.
 */
#ifndef OCTO_IMU_SCALE_H
#define OCTO_IMU_SCALE_H

#include "scalar.h"

#include <stdbool.h>
#include <stdint.h>

#define IMU_SCALE_ROTORS 8
#define IMU_SCALE_AXES 4                    /* the force, roll, pitch, yaw */
#define IMU_SCALE_NR (IMU_SCALE_ROTORS + 1) /* regressors: x_j and the offset */
#define IMU_SCALE_NT (IMU_SCALE_NR * (IMU_SCALE_NR + 1) / 2)
#define IMU_SCALE_NP (IMU_SCALE_ROTORS + 3 + 4) /* c, gamma (3 axes), offsets (4) */
#define IMU_SCALE_BLOCKS 32
#define IMU_SCALE_ITERS 12 /* Gauss-Newton steps at most */
/* the window's half-width, frames: the rates' change over 2 HALF frames against the
 * regressors' trapezoid mean over the same frames (and the force's, the same filter) */
#define IMU_SCALE_HALF 16
#define IMU_SCALE_WIN (2 * IMU_SCALE_HALF + 1)

struct imu_scale_cfg {
	float dt_s;
	float geo[3][IMU_SCALE_ROTORS]; /* roll, pitch, yaw torque per N of rotor j's thrust */
	uint32_t block_frames;          /* a cluster's frames (0: 90) */
	float sd_max;                   /* the largest sd of a scale taken as determined */
};

/* one set of sums: G (upper triangle of (x, 1), row by row), b and z'z per axis */
struct imu_scale_stat {
	float g[IMU_SCALE_NT];
	float b[IMU_SCALE_AXES][IMU_SCALE_NR];
	float zz[IMU_SCALE_AXES];
};

/* the run's sums, in double: the blocks' added as each completes (a float sum over the whole
 * run loses the rotors' small differences to rounding: the regressors are nearly collinear) */
struct imu_scale_dstat {
	double g[IMU_SCALE_NT];
	double b[IMU_SCALE_AXES][IMU_SCALE_NR];
	double zz[IMU_SCALE_AXES];
};

struct imu_scale {
	struct imu_scale_cfg cfg;
	float w2_ref;                   /* w_ref^2: the first frame's mean w^2 */
	float x0[IMU_SCALE_ROTORS], f0; /* the centring point: the first frame's x and force */
	bool have_ref;                  /* w2_ref, x0, f0 set */
	bool lost;                      /* a speed was not finite, or negative, in an excited frame */
	/* the window's frames, a ring (rh: the newest's slot): x, force, rates, excited flag */
	float xr[IMU_SCALE_WIN][IMU_SCALE_ROTORS];
	float fr[IMU_SCALE_WIN], rr3[IMU_SCALE_WIN][3];
	bool er[IMU_SCALE_WIN];
	float sx[IMU_SCALE_ROTORS], sf; /* the ring's sums of x and of the force (summed afresh each lap) */
	uint32_t n_fr, rh;              /* consecutive frames in the ring, the newest's slot */
	struct imu_scale_dstat all;     /* the completed blocks' sums */
	uint32_t n;                     /* frames in the sums */
	struct imu_scale_stat blk[IMU_SCALE_BLOCKS + 1];
	uint32_t nb, cl_len, cl_k;   /* complete blocks, frames per block, frames in the last */
	bool q_pending, q_excited;   /* the frame stored, as given */
	float q_w[IMU_SCALE_ROTORS]; /* speeds, rad/s */
	scalar_t q_thr[IMU_SCALE_ROTORS];
	/* each rotor's speed per throttle: over the excited frames the sums of w^2 / w_ref^2, of
	 * the throttle and of its square (the curve is applied at the solve) */
	float sw2[IMU_SCALE_ROTORS], sy[IMU_SCALE_ROTORS], syy[IMU_SCALE_ROTORS];
	scalar_t q_f, q_rate[3]; /* force (N), body rates (rad/s) */
};

enum imu_scale_cause {
	IMU_SCALE_OK = 0,
	IMU_SCALE_NO_DATA,       /* too few frames, or the sums singular */
	IMU_SCALE_SPEED_LOST,    /* a speed reading was not usable */
	IMU_SCALE_NOT_SEPARATED, /* a rotor's sd beyond cfg.sd_max: the excitation does not separate it */
};

struct imu_scale_result {
	float scale[IMU_SCALE_ROTORS], scale_sd[IMU_SCALE_ROTORS];
	/* the scales' covariance: white-noise and cluster-robust (each quantity takes the larger) */
	float cov_w[IMU_SCALE_ROTORS][IMU_SCALE_ROTORS], cov_c[IMU_SCALE_ROTORS][IMU_SCALE_ROTORS];
	float gain[3];     /* gamma: the axes' gains (1 / I_x, 1 / I_y in the force's units) */
	float noise_sd[4]; /* each axis' residual sd (N, rad/s^2) */
	uint32_t blocks, n, iters;
	int worst; /* the rotor of the largest sd */
	enum imu_scale_cause cause;
};

void imu_scale_init(struct imu_scale *m, const struct imu_scale_cfg *cfg);
/* One frame: the throttles acting (those sent on the previous frame), the speeds (rad/s, as
 * measured), the force m g a_z (N) and the body rates (rad/s); excited: into the sums.
 * Stores only. */
void imu_scale_step(struct imu_scale *m, const scalar_t thr[IMU_SCALE_ROTORS], const float w_rps[IMU_SCALE_ROTORS],
		    scalar_t f_n, const scalar_t rate[3], bool excited);
/* A frame without measurement: the rings restart. */
void imu_scale_hold(struct imu_scale *m);
/* Between frames: the stored frame into the sums (no-op if none waits). */
void imu_scale_process(struct imu_scale *m);
void imu_scale_solve(const struct imu_scale *m, struct imu_scale_result *r);
/* The scales per throttle (what MOT_SCALE is): those per w^2 of the solve times each rotor's
 * speed share, w_j^2 per unit of g(y_j) (a motor that turns slower at the same throttle),
 * over their median. The shares: share[] with their sds share_sd[] (a model of the speeds
 * with the motor's delay and lag, motor_id.h), or if NULL the ratio of w_j^2 to g(y_j) summed
 * over the excited frames (g the thrust curve; the throttles sent, not lagged: a bias of the
 * curve times the dithers' variance, a few 0.1 %), whose sd from the curve's (curve_sd) joins
 * the diagonal. No-op unless r->cause is IMU_SCALE_OK. */
void imu_scale_per_throttle(const struct imu_scale *m, float curve, float curve_sd, const float *share,
			    const float *share_sd, struct imu_scale_result *r);
/* The sd of ln(sum_j a_j s_j / sum_j b_j s_j) under the scales' covariance (either b may be
 * NULL: the numerator alone): what the scales' uncertainty adds to a quantity they scale. */
float imu_scale_ratio_rsd(const struct imu_scale_result *r, const float a[IMU_SCALE_ROTORS],
			  const float b[IMU_SCALE_ROTORS]);
const char *imu_scale_cause_text(enum imu_scale_cause c);

#endif /* OCTO_IMU_SCALE_H */
