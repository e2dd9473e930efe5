/*
 * motor_id.h - joint identification of the rotor model from every rotor's commanded throttle
 * and its measured thrust and reaction torque: transport delay (whole frames), motor lag,
 * k_f, k_tau, thrust curve c and a per-rotor effectiveness (scale), each with its standard
 * deviation.
 *
 * ---------------------------------------------------------------- model
 * Rotor j: the throttle T_k sent at frame k acts after D more frames through a first-order
 * lag tau (exact ZOH discretisation): s_(k+1) = a s_k + (1 - a) T_(k-D), a = exp(-dt / tau);
 * frame k+1 reports f_j = m_j g(s), tau_j = rho m_j g(s), g(s) = (1 - c) s + c s^2,
 * m_j = scale_j k_f, rho = k_tau / k_f. D and tau are common to all rotors (one motor type,
 * one link); c is common; the scales are normalised to median 1, so k_f = median(m_j).
 *
 * ---------------------------------------------------------------- the bank
 * For every delay hypothesis D = 0..MOTOR_ID_DELAYS-1 and MOTOR_ID_LAGS lag values on a
 * geometric grid tau_D r^(i-1), i = 0..2, each rotor's command runs through that delay and
 * lag (s), and the per-rotor least-squares statistics of the thrust on the basis
 *     x = [s, s (s - 2 s_c)]     (s_c: the rotor's throttle at the start)
 * are accumulated: G = sum x x^T, b = sum x r, rr = sum r^2 with r = f - x^T theta_ref, the
 * residual of a reference model (common k_f and c), so that the sums do not cancel: the
 * prior at first; after MOTOR_ID_NREF frames of the first stage the fit so far, and at every
 * refinement the fit of the stage that ends (the statistics restart then, so nothing is
 * transformed). With the reference near the data SSR is not a small difference of large
 * sums, and its rounding (float or integer) stays far below the differences between lags. f = A s + B s (s - 2 s_c) is the curve model exactly: m = A + B (1 - 2 s_c),
 * c = B / m. The basis keeps G well conditioned at the low throttles of hover.
 * With curve estimation off the regressor is the prior curve's g (w^T x, one parameter).
 *
 * Selection by prediction error: J = sum over rotors of log SSR_j (every rotor's k_f and
 * curve fitted; -2/n times the log-likelihood with each rotor's noise unknown, so a rotor
 * no lag explains pulls the common lag little) is interpolated by a parabola in log tau
 * over the three lags; each delay's minimum is its lag. The grid is refined around it between frames
 * (motor_id_refine: wide ratio 2.5, then 1.3, then 1.08; a minimum beyond the grid keeps the
 * next grid wider, and one below the first grid walks twice as far, towards no lag; the statistics restart, the lag
 * filters keep running), so the last stage's data give the estimates. A minimum beyond the
 * second grid (a prior far from the lag) would leave the last grid wide (ratio up to 1.26),
 * whose interpolation biases the lag by a few % and k_f by several of its sds: then an
 * interim stage on that wider grid (55-65 % of the planned frames) places the last, 1.08 grid,
 * which starts at 65 % instead of 55 %. The final estimates
 * (motor_id_solve, between frames) take the delay of least interpolated SSR, its lag refined
 * by Newton steps on sum_j log SSR_j of the interpolated statistics, and the statistics at
 * that lag by quadratic interpolation over the grid (smooth in tau).
 * sd(tau) from the curvature of the profile criterion (the Fisher information of the lag with
 * k_f and c profiled out).
 *
 * k_tau: rho by regressing every rotor's measured torque on its measured thrust (no
 * intercept; the thrust noise biases it by -sigma_f^2 / mean(f^2), ~1e-4, corrected), so
 * k_tau = rho k_f with rho's and k_f's variances combined.
 *
 * Noise: while not excited (the experiment's settling second) the thrust noise is measured
 * from first differences (var(f_k - f_(k-1)) / 2: slow control motion cancels). The
 * acceptance compares the fit's residual variance with it (normalised error per rotor).
 *
 * Identifiability: k_f is thrust at FULL throttle; hovering rotors run near 0.1, so with the
 * curve estimated k_f is an extrapolation: d k_f / k_f = d c / (1 - c). Its sd includes that.
 * The sds of k_f, the curve and the scales also carry the lag's (their change with the lag
 * times its variance); k_f's part from the rotors is the variance of a median of eight
 * (0.19 of one rotor's, not the 0.5 of a mean of the two central ones).
 *
 * Whiteness (the data cannot fool the acceptance): at 75 % of the planned frames (85 % after
 * an interim stage: the last stage's first 20 % either way), the model of the hypothesis then best (or of the given delay) is frozen:
 * its lag (the criterion's minimum, a lag filter of its own started from the grid's states
 * interpolated there) and every rotor's k_f and curve, from the last stage's data so far. Over
 * the remaining frames each frame's one-step prediction error of every rotor under that model is taken, split by the rotor's
 * throttle level (three bins of s - s_c: below -0.025, within, above +0.025), and each
 * (rotor, level) series' normalised autocorrelation at lags 1..MOTOR_ID_WLAGS (about its own
 * mean) is accumulated. Under the model the prediction errors are the white measurement noise:
 * n sum_L rho_L^2 is chi-square with MOTOR_ID_WLAGS degrees of freedom (Box-Pierce), summed over
 * rotors and levels with their degrees. An error the model leaves (a lag or delay that is not
 * the plant's, a thrust curve not modelled, a rotor unlike the others) is a smooth function of
 * the recent commands, so it is correlated from frame to frame, which the test sees whatever
 * the noise level it is measured against (the normalised error needs that level). The sum over everything,
 * each rotor's and each level's sum are compared with their chi-square quantiles (Wilson-
 * Hilferty) at about 1e-3 false rejections in all; the one that fails names the cause (one
 * rotor: that rotor; one level: the thrust curve; else the dynamics). The frozen model's own
 * error (an estimate from the frames before) is of the order of its standard deviations: a
 * coloured error of a few noise variances in all, no measurable colour.
 *
 * Core rules: no heap, globals or I/O; interfaces in scalar_t. The per-frame part (motor_id.c:
 * motor_id_step, motor_id_process, motor_id_hold: the command ring, the lag filters, the sums)
 * computes in the types below: float in the float build, integers in the fixed build (no
 * soft float on Cortex-M0). The set-up, the refinement, the freezing of the whiteness model
 * and the solve (motor_id_solve.c) run between frames, in float in both builds (the step
 * does a due refinement itself if nobody did).
 */
#ifndef OCTO_MOTOR_ID_H
#define OCTO_MOTOR_ID_H

#include "motor_id_q.h"
#include "scalar.h"

#include <stdbool.h>
#include <stdint.h>

#define MOTOR_ID_ROTORS 8
#define MOTOR_ID_DELAYS 5
#define MOTOR_ID_LAGS 3
#define MOTOR_ID_STAGES 4   /* the third only when a grid stays wide (motor_id_refine) */
#define MOTOR_ID_TAU_MIN 0.0005f
#define MOTOR_ID_TAU_MAX 0.5f
#define MOTOR_ID_WLAGS 3     /* autocorrelation lags of the whiteness test */
#define MOTOR_ID_WBINS 3     /* throttle levels of the whiteness test */
#define MOTOR_ID_NREF 30     /* first-stage frames before the reference is re-fitted */

struct motor_id_cfg {
	scalar_t dt_s;           /* frame period */
	float tau0_s;            /* prior lag: centre of the first grid (<= 0: 0.03 s) */
	float kf0;               /* prior k_f (reference model), N */
	float curve0;            /* prior curve c (the model when est_curve is false) */
	bool est_curve;          /* estimate c (else c = curve0) */
	uint32_t n_frames;       /* excited frames planned: refinements at 30 % and 55 % */
	bool fix_delay;          /* take delay_fr as known (else the bank chooses) */
	uint32_t delay_fr;       /* the given delay, frames (< MOTOR_ID_DELAYS) */
};

/* the whiteness test's sums (see above) */
struct motor_id_white {
	bool on;                 /* the last stage's model is frozen and the sums run */
	uint8_t delay;           /* the hypothesis followed (its lag: grid index 1) */
	uint8_t run;             /* consecutive frames in the ring (a lost frame restarts it) */
	motor_id_u_t k1;         /* the frozen model: 1 - a of its lag, */
	motor_id_u_t s[MOTOR_ID_ROTORS];       /* its lag filters, */
	motor_id_f_t dl[MOTOR_ID_ROTORS][2];   /* its change of theta from the reference */
	motor_id_f_t ring[MOTOR_ID_WLAGS][MOTOR_ID_ROTORS];   /* last prediction errors, newest first */
	/* per rotor and level: n, sum e, sum e^2, sum e_k e_(k-L); a series stops taking
	 * frames at n = 65535 (12 min of excitation at 90 Hz) */
	uint16_t n[MOTOR_ID_ROTORS][MOTOR_ID_WBINS];
	motor_id_sum_t se[MOTOR_ID_ROTORS][MOTOR_ID_WBINS], see[MOTOR_ID_ROTORS][MOTOR_ID_WBINS],
	      sl[MOTOR_ID_ROTORS][MOTOR_ID_WBINS][MOTOR_ID_WLAGS];
};

/* least-squares sums of one rotor under one hypothesis (see above) */
struct motor_id_stat {
	motor_id_sum_t g11, g12, g22, b1, b2, rr;
};

struct motor_id {
	struct motor_id_cfg cfg;
	motor_id_u_t hist[MOTOR_ID_DELAYS][MOTOR_ID_ROTORS];   /* commands, ring over frames */
	motor_id_u_t s[MOTOR_ID_DELAYS][MOTOR_ID_LAGS][MOTOR_ID_ROTORS];
	motor_id_u_t k1[MOTOR_ID_DELAYS][MOTOR_ID_LAGS];       /* 1 - a of each lag */
	float lag_c[MOTOR_ID_DELAYS], lag_r[MOTOR_ID_DELAYS];   /* grid centre (s) and ratio */
	struct motor_id_stat st[MOTOR_ID_DELAYS][MOTOR_ID_LAGS][MOTOR_ID_ROTORS];
	motor_id_u_t s_c[MOTOR_ID_ROTORS];
	motor_id_sum_t ff, tf, tt;   /* torque ratio: sums over every rotor of f^2, t f, t^2 */
	motor_id_sum_t nz_ss;        /* thrust noise from differences: sum of squares, */
	uint32_t nz_n;               /* and its count */
	motor_id_u_t kf0n, c0;       /* the reference model: its k_f 2^-kexp, its curve */
	uint32_t n_stat;         /* frames in the current stage's statistics */
	uint32_t n_exc;          /* excited frames so far */
	uint32_t n_next;         /* n_exc at which the stage ends (or the whiteness model freezes) */
	motor_id_e_t e[MID_E_N]; /* exponents of the sums (fixed build; 0 in the float build) */
	int8_t kexp;             /* thrusts and torques are taken as value 2^-kexp (fixed build) */
	uint8_t head;            /* the ring's newest slot */
	uint8_t skip;            /* frames not accumulated after a refinement (lag transients) */
	uint8_t stage;
	bool interim;            /* the wide interim stage ran (the last stage starts later) */
	bool nz_have;            /* the last frame taken was not excited (and none was lost since) */
	bool refine_due;
	bool white_due;          /* the whiteness model is to be frozen (between frames) */
	bool reref_due, reref_done;   /* the first stage's early re-referencing (see above) */
	/* the frame motor_id_step took, waiting for motor_id_process (its commands sit in
	 * hist's next slot, its noise sums are already taken) */
	bool q_excited, q_pending;
	scalar_t q_f[MOTOR_ID_ROTORS], q_tq[MOTOR_ID_ROTORS];
	struct motor_id_white wh;
};

/* why an estimate is not to be applied */
enum motor_id_cause {
	MOTOR_ID_OK = 0,
	MOTOR_ID_NO_DATA,        /* too few frames */
	MOTOR_ID_NOISE_UNKNOWN,  /* no noise measurement (no frames without excitation) */
	MOTOR_ID_LAG_RANGE,      /* the lag at 0.5 or 500 ms, or the criterion not convex inside the grid */
	MOTOR_ID_DELAY_RANGE,    /* the best delay is the largest hypothesis */
	MOTOR_ID_DELAY_AMBIGUOUS,/* two delays explain the data about equally */
	MOTOR_ID_CURVE,          /* curve estimation off but the data show a curve */
	MOTOR_ID_ROTOR,          /* one rotor is not explained (rotor index in cause_rotor) */
	MOTOR_ID_MODEL,          /* residuals above the noise on every rotor */
	MOTOR_ID_DELAY_GIVEN,    /* the given delay (fix_delay) is contradicted: another fits better */
	MOTOR_ID_LEVEL,          /* prediction errors coloured at one throttle level: thrust curve */
	MOTOR_ID_COLOURED,       /* prediction errors coloured on every rotor: lag or delay dynamics */
	MOTOR_ID_LAG_REACH,      /* the lag found lies outside the last grid (its statistics
				  * extrapolated), inside the lag range: the grids, started at the
				  * prior (ID_MOT_TAU), walked too little */
};

struct motor_id_result {
	uint32_t delay;          /* frames beyond the loop's one */
	/* tau = 0: no lag (below 0.18 of a frame: a = exp(-dt / tau) < 0.004, indistinguishable) */
	float delay_margin;      /* log-likelihood ratio of the best delay over the next best
				  * (> 12: a clear choice) */
	float tau, tau_sd;       /* s */
	float kf, kf_sd, ktau, ktau_sd, curve, curve_sd;
	float scale[MOTOR_ID_ROTORS], scale_sd[MOTOR_ID_ROTORS];
	float ne[MOTOR_ID_ROTORS];   /* residual variance / measured noise variance, per rotor */
	float ne_all;            /* the same over all rotors */
	float noise_sd;          /* measured thrust noise, N */
	float curve_chi2;        /* with est_curve false: the curve's likelihood-ratio statistic
				  * (chi-square, one degree of freedom per rotor under the model) */
	uint32_t n;              /* frames used */
	/* whiteness: the statistic over everything, its limit and degrees of freedom; each
	 * rotor's and each level's statistic over its limit (> 1: fails) */
	bool white_ok, white_have;   /* the test passed; it ran at all (the last stage's frames) */
	float white_q, white_lim, white_dof;
	float white_rotor[MOTOR_ID_ROTORS], white_level[MOTOR_ID_WBINS];
	uint32_t free_delay;     /* the bank's own choice (differs from delay when one was given) */
	enum motor_id_cause cause;
	int cause_rotor;         /* 0-based, for MOTOR_ID_ROTOR; else -1 */
};

/* thr0: the throttles before the start (the filters' initial state) */
void motor_id_init(struct motor_id *m, const struct motor_id_cfg *cfg,
		   const scalar_t thr0[MOTOR_ID_ROTORS]);

/* One frame: thr_prev[8] = throttles sent on the previous frame, f[8] = measured thrusts
 * (N), tq[8] = measured reaction-torque magnitudes (N m) of this frame. excited = false: the
 * filters run and the noise is measured; true: the bank accumulates. The step only takes
 * the frame (and, when still, its noise sums; a few hundred instructions); the bank update
 * (15 hypotheses x 8 rotors, ~8,000 instructions on M4F) runs in motor_id_process, between
 * frames; a step that finds the previous frame still waiting processes it first, so nothing
 * is lost or reordered. */
void motor_id_step(struct motor_id *m, const scalar_t thr_prev[MOTOR_ID_ROTORS],
		   const scalar_t f[MOTOR_ID_ROTORS], const scalar_t tq[MOTOR_ID_ROTORS], bool excited);

/* Between frames: the bank update of the frame motor_id_step took (no-op if none waits).
 * motor_id_hold, motor_id_refine and (the caller's duty) motor_id_solve come after it. */
void motor_id_process(struct motor_id *m);

/* A frame without measurement: the plant held thr_prev one more frame (filters advance). */
void motor_id_hold(struct motor_id *m, const scalar_t thr_prev[MOTOR_ID_ROTORS]);

/* Between frames: re-centres the lag grids when a stage ended (no-op otherwise). */
void motor_id_refine(struct motor_id *m);

/* Between frames: the estimates from the data so far, with the acceptance cause (call
 * motor_id_process first: a frame still waiting is not in them).
 * ne_max: largest accepted normalised error (residual over noise variance). */
void motor_id_solve(const struct motor_id *m, float ne_max, struct motor_id_result *res);

const char *motor_id_cause_text(enum motor_id_cause c);
/* what to do about it (short) */
const char *motor_id_cause_remedy(enum motor_id_cause c);

#endif /* OCTO_MOTOR_ID_H */
