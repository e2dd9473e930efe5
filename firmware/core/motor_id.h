/*
 * motor_id.h - joint identification of the rotor model from every rotor's commanded throttle
 * and its measured thrust and reaction torque: transport delay (whole frames), motor lag,
 * k_f, k_tau, thrust curve c and a per-rotor effectiveness (scale), each with its standard
 * deviation.
 *
 * Model: rotor j's throttle acts after a delay of D whole frames through a first-order lag
 * tau; it reports thrust f_j = scale_j k_f g(s) and torque (k_tau / k_f) f_j, with the thrust
 * curve g(s) = (1 - c) s + c s^2. A bank of least-squares fits over delay hypotheses and lag
 * grids, refined between frames, chooses D and tau by prediction error; a whiteness test of
 * the frozen model's one-step prediction errors guards the acceptance (enum motor_id_cause).
 * The derivation: docs/identification.md, "The motor model".
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
#define MOTOR_ID_STAGES 4
#define MOTOR_ID_LAST_PCT \
	55u /* the last stage, whose data alone make the estimates, starts here (% of the planned frames) */
#define MOTOR_ID_TAU_MIN 0.0005f
#define MOTOR_ID_TAU_MAX 0.5f
#define MOTOR_ID_WLAGS 3 /* autocorrelation lags of the whiteness test */
#define MOTOR_ID_WBINS 3 /* throttle levels of the whiteness test */
#define MOTOR_ID_NREF 30 /* first-stage frames before the reference is re-fitted */

struct motor_id_cfg {
	scalar_t dt_s;     /* frame period */
	float tau0_s;      /* prior lag: centre of the first grid (<= 0: 0.03 s) */
	float kf0;         /* prior k_f (reference model), N */
	float curve0;      /* prior curve c (the model when est_curve is false) */
	bool est_curve;    /* estimate c (else c = curve0) */
	uint32_t n_frames; /* excited frames planned: refinements at 30, 45 and 55 % (65 %: REPEAT_PCT) */
	bool fix_delay;    /* take delay_fr as known (else the bank chooses) */
	uint32_t delay_fr; /* the given delay, frames (< MOTOR_ID_DELAYS) */
};

/* the whiteness test's sums (docs/identification.md, "Whiteness") */
struct motor_id_white {
	bool on;                             /* the last stage's model is frozen and the sums run */
	uint8_t delay;                       /* the hypothesis followed (its lag: grid index 1) */
	uint8_t run;                         /* consecutive frames in the ring (a lost frame restarts it) */
	motor_id_u_t k1;                     /* the frozen model: 1 - a of its lag, */
	motor_id_u_t s[MOTOR_ID_ROTORS];     /* its lag filters, */
	motor_id_f_t dl[MOTOR_ID_ROTORS][2]; /* its change of theta from the reference */
	motor_id_f_t ring[MOTOR_ID_WLAGS][MOTOR_ID_ROTORS]; /* last prediction errors, newest first */
	/* per rotor and level: n, sum e, sum e^2, sum e_k e_(k-L); a series stops taking
	 * frames at n = 65535 (12 min of excitation at 90 Hz) */
	uint16_t n[MOTOR_ID_ROTORS][MOTOR_ID_WBINS];
	motor_id_sum_t se[MOTOR_ID_ROTORS][MOTOR_ID_WBINS], see[MOTOR_ID_ROTORS][MOTOR_ID_WBINS],
		sl[MOTOR_ID_ROTORS][MOTOR_ID_WBINS][MOTOR_ID_WLAGS];
};

/* least-squares sums of one rotor under one hypothesis (the bank) */
struct motor_id_stat {
	motor_id_sum_t g11, g12, g22, b1, b2, rr;
};

struct motor_id {
	struct motor_id_cfg cfg;
	motor_id_u_t hist[MOTOR_ID_DELAYS][MOTOR_ID_ROTORS]; /* commands, ring over frames */
	motor_id_u_t s[MOTOR_ID_DELAYS][MOTOR_ID_LAGS][MOTOR_ID_ROTORS];
	motor_id_u_t k1[MOTOR_ID_DELAYS][MOTOR_ID_LAGS];      /* 1 - a of each lag */
	float lag_c[MOTOR_ID_DELAYS], lag_r[MOTOR_ID_DELAYS]; /* grid centre (s) and ratio */
	struct motor_id_stat st[MOTOR_ID_DELAYS][MOTOR_ID_LAGS][MOTOR_ID_ROTORS];
	motor_id_u_t s_c[MOTOR_ID_ROTORS];
	motor_id_sum_t ff, tf, tt; /* torque ratio: sums over every rotor of f^2, t f, t^2 */
	motor_id_sum_t nz_ss;      /* thrust noise from differences: sum of squares, */
	uint32_t nz_n;             /* and its count */
	motor_id_u_t kf0n, c0;     /* the reference model: its k_f 2^-kexp, its curve */
	uint32_t n_stat;           /* frames in the current stage's statistics */
	uint32_t n_exc;            /* excited frames so far */
	uint32_t n_next;           /* n_exc at which the stage ends (or the whiteness model freezes) */
	motor_id_e_t e[MID_E_N];   /* exponents of the sums (fixed build; 0 in the float build) */
	int8_t kexp;               /* thrusts and torques are taken as value 2^-kexp (fixed build) */
	uint8_t head;              /* the ring's newest slot */
	uint8_t skip;              /* frames not accumulated after a refinement (lag transients) */
	uint16_t white_pause;      /* excited frames left out of the whiteness sums (motor_id_white_pause) */
	uint8_t stage;
	bool repeated; /* the third stage ran twice: its minimum lay beyond its grid (motor_id_refine) */
	bool nz_have;  /* the last frame taken was not excited (and none was lost since) */
	bool refine_due;
	bool white_due;             /* the whiteness model is to be frozen (between frames) */
	bool reref_due, reref_done; /* the first stage's early re-referencing (after MOTOR_ID_NREF frames) */
	/* the frame motor_id_step took, waiting for motor_id_process (its commands sit in
	 * hist's next slot, its noise sums are already taken) */
	bool q_excited, q_pending;
	scalar_t q_f[MOTOR_ID_ROTORS], q_tq[MOTOR_ID_ROTORS];
	struct motor_id_white wh;
};

/* why an estimate is not to be applied */
enum motor_id_cause {
	MOTOR_ID_OK = 0,
	MOTOR_ID_NO_DATA,         /* too few frames */
	MOTOR_ID_NOISE_UNKNOWN,   /* no noise measurement (no frames without excitation) */
	MOTOR_ID_LAG_RANGE,       /* the lag at 0.5 or 500 ms, or the criterion not convex inside the grid */
	MOTOR_ID_DELAY_RANGE,     /* the best delay is the largest hypothesis */
	MOTOR_ID_DELAY_AMBIGUOUS, /* two delays explain the data about equally */
	MOTOR_ID_CURVE,           /* curve estimation off but the data show a curve */
	MOTOR_ID_ROTOR,           /* one rotor is not explained (rotor index in cause_rotor) */
	MOTOR_ID_MODEL,           /* residuals above the noise on every rotor */
	MOTOR_ID_DELAY_GIVEN,     /* the given delay (fix_delay) is contradicted: another fits better */
	MOTOR_ID_LEVEL,           /* prediction errors coloured at one throttle level: thrust curve */
	MOTOR_ID_COLOURED,        /* prediction errors coloured on every rotor: lag or delay dynamics */
	MOTOR_ID_LAG_REACH,       /* the lag found lies outside the last grid (its statistics
				  * extrapolated), inside the lag range: the grids, started at the
				  * prior (ID_MOT_TAU), walked too little */
};

struct motor_id_result {
	uint32_t delay; /* frames beyond the loop's one */
	/* tau = 0: no lag (below 0.18 of a frame: a = exp(-dt / tau) < 0.004, indistinguishable) */
	float delay_margin; /* log-likelihood ratio of the best delay over the next best
				  * (> 12: a clear choice) */
	float tau, tau_sd;  /* s */
	float kf, kf_sd, ktau, ktau_sd, curve, curve_sd;
	float scale[MOTOR_ID_ROTORS], scale_sd[MOTOR_ID_ROTORS];
	float ne[MOTOR_ID_ROTORS]; /* residual variance / measured noise variance, per rotor */
	float ne_all;              /* the same over all rotors */
	float noise_sd;            /* measured thrust noise, N */
	float curve_chi2;          /* with est_curve false: the curve's likelihood-ratio statistic
				  * (chi-square, one degree of freedom per rotor under the model) */
	uint32_t n;                /* frames used */
	/* whiteness: the statistic over everything, its limit and degrees of freedom; each
	 * rotor's and each level's statistic over its limit (> 1: fails) */
	bool white_ok, white_have; /* the test passed; it ran at all (the last stage's frames) */
	float white_q, white_lim, white_dof;
	float white_rotor[MOTOR_ID_ROTORS], white_level[MOTOR_ID_WBINS];
	uint32_t free_delay; /* the bank's own choice (differs from delay when one was given) */
	enum motor_id_cause cause;
	int cause_rotor; /* 0-based, for MOTOR_ID_ROTOR; else -1 */
};

/* thr0: the throttles before the start (the filters' initial state) */
void motor_id_init(struct motor_id *m, const struct motor_id_cfg *cfg, const scalar_t thr0[MOTOR_ID_ROTORS]);

/* One frame: thr_prev[8] = throttles sent on the previous frame, f[8] = measured thrusts
 * (N), tq[8] = measured reaction-torque magnitudes (N m) of this frame. excited = false: the
 * filters run and the noise is measured; true: the bank accumulates. The step only takes
 * the frame (and, when still, its noise sums); the bank update (15 hypotheses x 8 rotors)
 * runs in motor_id_process, between frames; a step that finds the previous frame still
 * waiting processes it first, so nothing is lost or reordered. */
void motor_id_step(struct motor_id *m, const scalar_t thr_prev[MOTOR_ID_ROTORS], const scalar_t f[MOTOR_ID_ROTORS],
		   const scalar_t tq[MOTOR_ID_ROTORS], bool excited);

/* The next `frames` excited frames (from the frame taken last) stay out of the whiteness
 * sums, which restart after them as after a lost frame; the bank takes them as any other.
 * For a throttle sweep's large steps: the frozen model's small parameter error, times a
 * regressor many times the dither's, would colour its prediction errors there, and the test
 * is of the model's form, which the dither frames show at the noise's scale. */
void motor_id_white_pause(struct motor_id *m, uint16_t frames);

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
