/*
 * imu_id.h - the rotors' collective model from the accelerometer: transport delay (whole
 * frames), motor lag, k_f and the thrust curve c, each with its standard deviation, from the
 * specific force along body z, the vehicle's mass and the throttles sent. No per-rotor thrust
 * row is read: this is what a flight controller measures.
 *
 * Model: rotor j's throttle acts after D whole frames through a first-order lag tau (y_j);
 * the rotors together push F = m a_z = k_f sum_j s_j g(y_j), with g(y) = (1 - c) y + c y^2
 * and s_j the per-rotor effectiveness taken as known (MOT_SCALE, or from the refinement on the
 * scales imu_id_set_scales gave). Linear in (A, B) = (k_f (1 - c), k_f c) with the
 * regressors x1 = sum s_j y_j, x2 = sum s_j y_j^2; the lag filters are linear and
 * time-invariant, so a delayed hypothesis is the undelayed filter's output read D frames
 * late. The filters run on the throttles of IMU_ID_DELAYS - 1 frames before (one filter per
 * rotor and grid point), and the bank pairs those regressors with the force D frames after
 * them: every delay regresses on the same regressors, so their products x x' are one set of
 * sums per lag, and each hypothesis keeps only its products with its own force and its
 * residual's square, relative to a reference model (the prior k_f and curve), which keeps
 * them well conditioned in float.
 *
 * Refinement: at IMU_ID_FREEZE of the planned frames the lag grid narrows to
 * +/- IMU_ID_FINE_HALF of its steps about the lag found so far (the Gauss-Newton step below
 * is first order: between the first grid's points it leaves an error of several tenths of
 * a percent in k_f); the filters start from the old grid's states interpolated, and the sums
 * restart with the first frame whose regressors and forces all come after it.
 *
 * Choice: the hypothesis of least residual. Each hypothesis also carries the lag's
 * sensitivities x3 = d x1 / d ln tau and x4 = d x2 / d ln tau (central differences across
 * the grid, second order at its ends): d F / d ln tau = A x3 + B x4 for any curve, so the
 * least squares over (x1, x2, x3, x4, 1) is a Gauss-Newton step in ln tau from the grid
 * point (A d ln tau and B d ln tau are linear parameters), and tau, k_f and c come with their
 * joint covariance.
 *
 * Both sides pass through the same [1 2 1] / 4 smoother first: its zero at half the frame
 * rate removes the vibration of rotors turning near half the frame rate (a hover), and a
 * linear filter on both sides keeps the regression's parameters. What remains is coloured
 * and grows with the rotor speed (near the frame rate a rotor's tone aliases to almost a
 * constant over a sweep step), so each sd is the white-noise one scaled by a cluster-robust
 * factor measured on the hypothesis frozen at IMU_ID_FREEZE of the planned frames, its
 * clusters blocks of the sweep's period. The cluster-robust variance is leverage-corrected
 * (bias-reduced, CR2: the sweep's few high steps carry the curve, and a plain sandwich reads
 * their residuals after the fit has bent towards them), and its degrees of freedom
 * nu are those its clusters give the projection (Bell and McCaffrey): the error then follows
 * a t with nu degrees of freedom, whose variance nu / (nu - 2) the factor carries. The factor
 * is the clusters' alone, below 1 where the residuals' power lies at frequencies the sweep's
 * slow regressors average out (the white-noise sd then overstates), floored at a quarter (the
 * sd at least half the white-noise one: the clusters' variance rests on a dozen degrees of
 * freedom). The clusters take the top steps' errors as independent; a rotor's tone aliased
 * near 0 Hz in the same phase at every top step is one offset the curve absorbs. So the
 * clusters that carry most of each projection are left out and the fit of the rest compared
 * with the whole: a difference beyond 2.5 of its sds adds its excess to the variance
 * (top_t: k_f's difference in its sds).
 *
 * With the ESCs' shaft torques (their sum Q, from the motor currents) the same regressors
 * explain Q = k_tau sum_j s_j g(y_j) plus the current sensors' summed offset: a second
 * response over the same sums, solved on the hypothesis the force chose, gives k_tau with
 * its own cluster-robust sd. The accelerometer's calibration does not enter it.
 *
 * The accelerometer's bias and scale error are calibrated in flight: its offset is a fourth
 * parameter of the regression (a constant beside the thrust's linear and quadratic shapes,
 * which the throttle sweep separates), and over the excited frames the vertical (world)
 * component of m times the reading, less the offset, must average m g plus m times the
 * vertical velocity's change over their time: the ratio (kappa) scales the force. Its sd
 * (the velocity's, the offset's) joins k_f's.
 * The derivation: docs/identification.md, "From the IMU".
 *
 * Core rules: no heap, globals or I/O. imu_id_step and imu_id_hold store the frame (scalars,
 * no conversion); the bank update (imu_id_process, imu_id.c) and the solve run between
 * frames. The bank update is integer in the fixed build (imu_id_q.h: the lag filters,
 * smoothers, regressors and sums); the set-up, the grid's refinement (once) and the solve
 * (imu_id_solve.c) are float in both builds, reading the sums converted.
 */
#ifndef OCTO_IMU_ID_H
#define OCTO_IMU_ID_H

#include "imu_id_q.h"
#include "scalar.h"

#include <stdbool.h>
#include <stdint.h>

#define IMU_ID_ROTORS 8
#define IMU_ID_DELAYS 5 /* 0..4 frames beyond the loop's one */
#define IMU_ID_LAGS 16  /* log grid IMU_ID_TAU_MIN .. IMU_ID_TAU_MAX, refined at IMU_ID_FREEZE */
#define IMU_ID_TAU_MIN 0.005f
#define IMU_ID_TAU_MAX 0.25f
#define IMU_ID_BLOCKS 32    /* clusters of the variance (merged in pairs when full) */
#define IMU_ID_VEL_SD 0.05f /* the velocity's error at either end of the calibration, m/s */
#define IMU_ID_FREEZE \
	0.2f /* share of the planned frames after which the grid refines and the clusters' hypothesis freezes */
#define IMU_ID_FINE_HALF 2.0f /* the refined grid's half-width, in steps of the first grid */

/* parameters: A (or k_f), B, A d ln tau, B d ln tau, the accelerometer's offset */
#define IMU_ID_NP 5
#define IMU_ID_NT 15 /* their upper triangle */

struct imu_id_cfg {
	float dt_s;                  /* frame period */
	float mass_kg;               /* the weighed mass */
	float g;                     /* gravity, m/s^2 */
	float kf0, curve0;           /* the reference model (and the curve when not estimated) */
	bool est_curve;              /* estimate c (else c = curve0) */
	float scale[IMU_ID_ROTORS];  /* per-rotor effectiveness (MOT_SCALE) */
	uint32_t n_frames;           /* excited frames planned */
	uint32_t block_frames;       /* a cluster's frames (the sweep's period; 0: 90) */
	float pat[2][IMU_ID_ROTORS]; /* the null-space dithers' patterns (the scales' check) */
	bool torque;                 /* the ESCs' torques are read: k_tau beside k_f */
	float kt0;                   /* the torque's reference model: the prior k_tau, N m */
};

#define IMU_ID_NX (IMU_ID_NP + 2) /* the scales' check: the parameters and two patterns' responses */
#define IMU_ID_T_ROTOR 5.0f       /* |t| of a pattern's response beyond which the scales are wrong */

/* least-squares sums of one hypothesis: G (upper triangle, row by row), b, z'z; and the
 * torque's b and z'z over the same G (cfg.torque) */
struct imu_id_stat {
	imu_id_sum_t g[IMU_ID_NT], b[IMU_ID_NP], rr;
	imu_id_sum_t bt[IMU_ID_NP], rrt;
};

/* a hypothesis' own sums: b but its offset's, z'z; the torque's the same (its G is its lag's,
 * the offset's b its delay's force sum less the lag's reference: imu_id.c, hyp_stat) */
struct imu_id_hyp {
	imu_id_sum_t b[IMU_ID_NP - 1], rr;
	imu_id_sum_t bt[IMU_ID_NP - 1], rrt;
};

/* The per-frame coefficients of the centred regressors (imu_id.c: xmap), set at the start
 * and at the refinement: x0 = k0 x1 + k1 x2 + o0, x1' = k3 x1 + k4 x2 + o1 (k: k0, k1, k3,
 * k4), the reference's regressor r0 x0 + r1 x1', 1 / (2 h) of the grid's step, the reference's
 * k_f and k_tau (normalised) and its force and torque at the start's hover (fref, tref) */
struct imu_id_xmap {
	imu_id_c_t k[4], r0, r1, ih, kf, kt;
	imu_id_x_t o[2], fref, tref;
};

struct imu_id {
	struct imu_id_cfg cfg;
	/* the regressors are centred at the start's hover (y_h, the scales' sum S): x1 - y_h S,
	 * sum s (y - y_h)^2, x3, x4 - 2 y_h x3 (imu_id.c: basis) */
	float yh, ssum;
	float ln0, lstep; /* the lag grid: ln tau_l = ln0 + l lstep */
	bool refined;     /* the grid was refined (the sums restarted) */
	uint32_t n_st;    /* excited frames in the bank's sums */
	/* the lags' poles exp(-dt / tau): a in the float build, 1 - a in the fixed (its precision) */
	imu_id_u_t lk[IMU_ID_LAGS];
	/* the filters, on the throttles IMU_ID_DELAYS - 1 frames old: each rotor's output times
	 * the square root of its scale (rs), and the scaled outputs' sum x1 */
	imu_id_u_t y[IMU_ID_LAGS][IMU_ID_ROTORS], rs[IMU_ID_ROTORS];
	imu_id_x_t yc[IMU_ID_LAGS];
	imu_id_c_t sc[IMU_ID_ROTORS], pc[2][IMU_ID_ROTORS]; /* cfg's scales and patterns */
	imu_id_u_t uq[IMU_ID_DELAYS - 1][IMU_ID_ROTORS]; /* the throttles waiting for the filters (uqh: the oldest's) */
	uint8_t uqh;
	/* the [1 2 1] / 4 smoother's state (the last input, the last two's sum) of x1, x2 and the
	 * patterns' responses (sum p_kj s_j y_j, at the clusters' lag: imu_id.c); qs: the latter smoothed */
	imu_id_x_t x1[IMU_ID_LAGS][2], x2[IMU_ID_LAGS][2];
	imu_id_x_t q1[2], q2[2], qs[2];
	struct imu_id_xmap xm;
	/* the scales' check on the frozen hypothesis: the products of its regressors and the
	 * two patterns' responses with the latter (rows 0..IMU_ID_NX - 1) and with the force
	 * (row IMU_ID_NX), over its xn frames (the other sums are the blocks') */
	imu_id_sum_t xq[IMU_ID_NX + 1][2];
	uint32_t xn;
	imu_id_x_t fr[3]; /* the force's last three frames, newest first */
	imu_id_x_t tr[3]; /* the torques' sum, the same */
	uint32_t n_fr;    /* consecutive frames in fr (a gap restarts it) */
	/* rings by age: the smoothed force and torque less the reference at hover, and
	 * (bit k) whether the frame of age k is taken; the bank takes the regressors of age
	 * IMU_ID_DELAYS - 1 when all are, delay D with the force of age IMU_ID_DELAYS - 1 - D */
	imu_id_x_t fz[IMU_ID_DELAYS], tz[IMU_ID_DELAYS]; /* the frame of age k in slot (fh + k) % IMU_ID_DELAYS */
	uint8_t fh, fok;
	/* each lag's G up to (2, 3), then (3, 3): the sums of x2 and x3 follow from those of x0
	 * and x1 (imu_id.c: hyp_stat), the count is n_st */
	imu_id_sum_t gx[IMU_ID_LAGS][IMU_ID_NT - 3];
	struct imu_id_hyp hs[IMU_ID_LAGS][IMU_ID_DELAYS];
	imu_id_acc_t fs[IMU_ID_DELAYS], ts[IMU_ID_DELAYS]; /* each delay's force and torque sums (fz, tz) */
	/* the still frames' force: its count, mean and spread (the noise, about the mean) */
	uint32_t nz_n;
	imu_id_acc_t nz_s, nz_ss, nz_thr; /* nz_thr: the still frames' summed mean throttle */
	/* the clusters: the frozen hypothesis and its blocks' sums (the last one being filled) */
	bool cl_on;
	uint8_t cl_d, cl_l, nb; /* hypothesis, complete blocks */
	uint32_t cl_len, cl_k;  /* frames per block, frames in the block being filled */
	struct imu_id_stat blk[IMU_ID_BLOCKS + 1];
	uint32_t n_exc;    /* excited frames so far */
	uint32_t n_freeze; /* the excited frames after which the grid refines (IMU_ID_FREEZE of the planned) */
	imu_id_acc_t ff;   /* their force's sum of squares (the noise's growth with thrust) */
	/* the accelerometer's calibration in flight: over the excited frames the mean vertical
	 * specific force is g plus the velocity's change over their time */
	imu_id_acc_t fw_sum;
	scalar_t vz_prev, v0, v_last;
	uint32_t n_cal;
	bool q_pending, q_excited;
	bool tq_lost; /* a torque reading was not finite: k_tau is not estimated */
	scalar_t q_thr[IMU_ID_ROTORS], q_f, q_fw, q_vz, q_tq; /* the frame stored, as given */
	scalar_t h_thr[IMU_ID_ROTORS];                        /* the throttles of the frames lost before it, */
	uint32_t n_hold;                                      /* and their count (imu_id_hold; taken between frames) */
	scalar_t fw_last;                                     /* the last frame taken's vertical force (a lost one's) */
	float scale_next[IMU_ID_ROTORS];                      /* imu_id_set_scales: the scales the refinement takes */
	bool scale_new;
#if OCTO_FIXED
	/* forces and torques are taken as value 2^-kexp, 2^-texp; the sums' exponents, one per
	 * member of the records of gx, hs, blk and xq */
	int8_t kexp, texp;
	int8_t e_gx[IMU_ID_NT - 3], e_hs[2 * IMU_ID_NP], e_blk[2 * IMU_ID_NP + IMU_ID_NT + 2],
		e_xq[2 * (IMU_ID_NX + 1)];
#endif
};

enum imu_id_cause {
	IMU_ID_OK = 0,
	IMU_ID_NO_DATA,       /* too few frames */
	IMU_ID_NOISE_UNKNOWN, /* no still frames measured the noise */
	IMU_ID_LAG_RANGE,     /* the best lag at the grid's edge */
	IMU_ID_DELAY_RANGE,   /* the best delay is the largest hypothesis */
	IMU_ID_DELAY_AMBIGUOUS,
	IMU_ID_MODEL,      /* residuals coloured far beyond the vibration's (the cluster factor, the
			    * top steps' disagreement included) */
	IMU_ID_CURVE_WEAK, /* the data cannot tell the curve (no throttle spread) */
	IMU_ID_SCALES,     /* the force answers a null-space dither: a rotor's effectiveness is
			    * not MOT_SCALE's (the accelerometer cannot tell which rotor) */
};

struct imu_id_result {
	uint32_t delay;
	float delay_margin; /* log-likelihood ratio of the best delay over the next best */
	float tau, tau_sd;
	float kf, kf_sd, curve, curve_sd;
	float ne;              /* residual variance / the still noise's, grown with the thrust */
	float noise_sd;        /* the still frames' force spread, N */
	float hac;             /* k_f's variance over its white-noise one (the clusters', the top check's excess) */
	float top_t;           /* k_f's top blocks' check: the fit without them against it, in its sds */
	float dof, curve_dof;  /* their degrees of freedom (the t k_f's and the curve's errors follow) */
	uint32_t blocks;       /* clusters behind it */
	float t_pattern[2];    /* the null-space patterns' responses over their sds */
	float kappa, kappa_sd; /* the accelerometer's calibration factor found in flight */
	float offset_n;        /* the accelerometer's offset found, as a force (N) */
	/* the thrust's slope at the hover throttle y_h, k_f g'(y_h) (N per unit throttle, a
	 * rotor), and its relative sd: what scales the inertia experiments' modelled torque
	 * (the weight pins k_f g(y_h), the collective dither the slope) */
	float slope, slope_rsd, thr_hover;
	/* with the ESCs' torques (cfg.torque): k_tau, its sd, the cluster factor and its degrees
	 * of freedom behind it and the residual's sd (N m); tq_ok: estimated (readings finite throughout, the fit regular);
	 * the torque's slope at y_h, relative sd (what scales the yaw phase's modelled torque) */
	bool tq_ok;
	bool tq_moved; /* not estimated: the best delay is not the one frozen at the refinement,
			* the only one whose torque sums are kept (cl_delay) */
	uint8_t cl_delay;
	float ktau, ktau_sd, tq_hac, tq_dof, tq_noise, tq_slope, tq_slope_rsd;
	uint32_t n;
	enum imu_id_cause cause;
};

/* thr0: the throttles before the start (the filters' initial state) */
void imu_id_init(struct imu_id *m, const struct imu_id_cfg *cfg, const scalar_t thr0[IMU_ID_ROTORS]);
/* One frame: the throttles sent on the previous frame; of this one the force m g a_z along
 * body z (N, the reading a in g), its vertical (world) component m g (R a)_z (N), the
 * vertical velocity (m/s, up) and the ESCs' torques summed (N m; read with cfg.torque);
 * excited: the bank accumulates, else the still noise is measured. Stores only. */
void imu_id_step(struct imu_id *m, const scalar_t thr_prev[IMU_ID_ROTORS], scalar_t f_n, scalar_t fw_n, scalar_t vz,
		 scalar_t tq_n, bool excited);
/* Between frames: the stored frame into the bank (no-op if none waits). */
void imu_id_process(struct imu_id *m);
/* A frame without measurement: the plant held thr_prev one more frame (counted; the bank
 * takes it between frames, before the next frame stored). */
void imu_id_hold(struct imu_id *m, const scalar_t thr_prev[IMU_ID_ROTORS]);
/* Between frames: the estimates and the acceptance cause. ne_max: the largest accepted
 * cluster factor (hac: the residuals' colour; beyond it the model misses something the
 * vibration does not explain). NE (the residual over the still hover's spread) is reported
 * only: the still second's spread mixes the noise with the hover control's own thrust
 * changes, so it measures neither. */
void imu_id_solve(const struct imu_id *m, float ne_max, struct imu_id_result *r);
/* Scales identified in flight (the rotor speeds' imu_scale.h) for the sums after the grid's
 * refinement, which restarts them: cfg.scale becomes these, the reference model keeps its
 * weight (k_f0 sum s g at the start). Ignored once refined. */
void imu_id_set_scales(struct imu_id *m, const float scale[IMU_ID_ROTORS]);
const char *imu_id_cause_text(enum imu_id_cause c);
const char *imu_id_cause_remedy(enum imu_id_cause c);

#endif /* OCTO_IMU_ID_H */
