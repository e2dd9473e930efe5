/*
 * rotor_fail.h - a failed rotor, found from what the rotors measure.
 *
 * Each frame every rotor's measured output is compared with what its command asks. The
 * command is the throttle sent in the last step (what the plant answers with now), passed
 * through the motor lag (first order, tau_lag) and the thrust curve g(T) = (1 - c) T + c T^2:
 *   thrust rows:  model e_j = scale_j g_j, measured m_j = f_j   (m_j / e_j = k_f)
 *   rotor speed:  model e_j = sqrt(g_j),   measured m_j = w_j   (m_j / e_j = speed_max)
 * The common gain (k_f, or the speed at full throttle) is never needed: it is the ratio
 * M / E of the sums of measured and modelled outputs over the rotors in service (their
 * total follows the collective however an excitation or a correction moves them apart),
 * both low-passed alike (gain_tau_s), so that a motor slower or later than the model does
 * not swing it when many rotors move at once; a k_f drift or a wrong VEH_KF move every rotor
 * alike.
 * The decision compares the measured output with a lower envelope of the modelled output:
 * it follows the model's output at once where that falls (taken the lower of the output
 * through the lag and of the command itself, so a motor faster than the model is covered)
 * and rises towards it with time constant env_tau_s. Before identification the lag and
 * delay are the nominal ones; a working rotor slower or later than the model still gives at
 * least the envelope, a failed one far less. Rotor j is failing in a frame when
 *   m_j E < ratio_fail env_j M        (thrust; the speed: sqrt(ratio_fail), thrust ~ speed^2)
 * (M and E low-passed)
 * and has failed after `confirm` such frames in a row; its effectiveness is then scale_j
 * times the mean over those frames of q_j = (m_j / e_j) / (M' / E'), M' and E' the frame's
 * sums without the rotors failing (squared for the speed; 0 below ratio_zero: the rotor is left
 * out of the allocation). A frame where no rotor is failing takes products and comparisons
 * only; the divisions are the failing frames' and the coefficients', which are computed again
 * only when the frame period or the model's lag changes.
 *
 * The thrust rows decide when the frame has them; the speed when it has only that. A rotor
 * is judged only while its envelope is at least share_min of the mean modelled output (a
 * rotor the mixer holds near zero says nothing), the mean g(T) at least g_min, and at least
 * four rotors are judged. A frame that follows missing frames is not judged and restarts the
 * streaks: what the plant held while frames were missing is not known, and a failure is
 * concluded only from frames in a row.
 *
 * After a detection `land` is raised once, hold_s later: the vehicle holds on the remaining
 * rotors, then lands. A rotor stays in `failed` until its scale is set back to ratio_fail
 * or more; a rotor whose scale is 0 is failed (and not judged).
 *
 * Measurement noise: the frames a failing streak needs grow with the noise of q_j, so that a
 * working rotor (q at least q_work: a rotor weaker than its scale, not identified yet) does
 * not fall below the bound for a streak by chance. Each frame the change of every rotor's
 * residual m_j E - M e_j since the last frame is summed over the rotors in service and
 * averaged (noise_tau_s); white measurement noise of sd sigma gives a mean |change| of
 * 2 sigma / sqrt(pi) (times E). In a failing frame q_j's sd s_q follows (twice that for the
 * speed: q is its square), and with r = s_q / (q_work - bound) a streak needs confirm
 * frames for r <= 0.25, 9.33 (r - 0.25) more up to r = 1, 7 + 3.5 (r - 1) more beyond, at
 * most confirm_max: the
 * chance that a working rotor's q lies below the bound for so many frames in a row is below
 * 1e-8 (a failed rotor's q lies near 0: below the bound in nearly every frame). A modelled
 * output that differs from the measured one in its dynamics only reads as more noise (a
 * slower, never a falser decision). The noise costs products and comparisons only.
 *
 * Pure: no I/O, no globals; scalar_t in both builds (the ratios are about 1, thrusts below
 * 100 N, speeds below 2,000 rad/s: the products of a sum and an output stay in Q16.16).
 */
#ifndef OCTO_ROTOR_FAIL_H
#define OCTO_ROTOR_FAIL_H

#include "scalar.h"

#include <stdbool.h>
#include <stdint.h>

#define ROTOR_FAIL_ROTORS 8

enum rotor_fail_source {
	ROTOR_FAIL_SRC_NONE = 0,
	ROTOR_FAIL_SRC_THRUST = 1, /* the measured thrust rows */
	ROTOR_FAIL_SRC_SPEED = 2,  /* the rotor speeds (ESC telemetry) */
};

struct rotor_fail_params {
	scalar_t ratio_fail;         /* q_j below this is failing (0.6) */
	scalar_t ratio_fail_excited; /* ... while the rotors swing through a model not yet identified (0.3) */
	scalar_t ratio_zero;         /* a detected effectiveness below this is 0 (0.1) */
	scalar_t share_min;          /* judged only while its envelope is this share of the mean output (0.3; > 0) */
	scalar_t g_min;              /* ... and the mean g(T) is at least this (0.02; > 0) */
	scalar_t env_tau_s;          /* the envelope's rise: beyond the lag and delay of any motor met (0.1 s) */
	scalar_t gain_tau_s;         /* the low-pass of the sums the common gain is taken from (0.3 s) */
	scalar_t hold_s;             /* hold before landing (2 s) */
	scalar_t q_work;             /* the weakest working rotor's q (a scale not yet identified: 0.8) */
	scalar_t noise_tau_s;        /* the measured noise's average (0.5 s) */
	uint8_t confirm;             /* frames in a row (3), at the least */
	uint8_t confirm_max;         /* ... at the most, however noisy (30) */
};

/* The rotor model (set when the parameters change): lag, curve, effectiveness. */
struct rotor_fail_model {
	scalar_t tau_lag_s;                /* ID_MOT_TAU */
	scalar_t curve;                    /* MOT_CURVE, in [-1, 1]: g(T) >= 0 on [0, 1] */
	scalar_t scale[ROTOR_FAIL_ROTORS]; /* MOT_SCALEj (0: failed, left out) */
};

struct rotor_fail_input {
	const scalar_t *thr;       /* the throttles sent in the last step, in [0, 1] (ROTOR_FAIL_ROTORS) */
	const scalar_t *thrust_n;  /* measured thrusts, N; NULL: not in this frame */
	const scalar_t *speed_rps; /* measured rotor speeds, rad/s; NULL: not in this frame */
	scalar_t dt_s;             /* this step's time */
	bool judge;                /* flying: rotors are judged (else only the lag filter runs) */
	bool gap;                  /* frames were missing before this one: not judged, streaks restart */
	bool excited;              /* the rotors swing (an excitation, an oscillation): ratio_fail_excited decides */
};

struct rotor_fail_output {
	int rotor;      /* 0-based rotor found failed in this frame; -1: none */
	scalar_t scale; /* its effectiveness now (what MOT_SCALEj becomes) */
	enum rotor_fail_source source;
	bool land; /* the hold after a detection is over: land now (once) */
};

struct rotor_fail {
	struct rotor_fail_params p;
	struct rotor_fail_model m;
	scalar_t lag[ROTOR_FAIL_ROTORS];   /* lag-filtered throttles */
	scalar_t env[ROTOR_FAIL_ROTORS];   /* lower envelope of the modelled outputs */
	scalar_t q_sum[ROTOR_FAIL_ROTORS]; /* sum of q_j over the current streak */
	uint8_t streak[ROTOR_FAIL_ROTORS];
	uint8_t streaking; /* bit j: streak[j] > 0 */
	uint8_t failed;    /* bit j: rotor j+1 has failed */
	uint8_t env_src;   /* the envelope holds outputs of this source (enum rotor_fail_source) */
	bool primed;       /* the lag filter holds a value */
	bool holding;      /* a detection's hold is running */
	scalar_t hold_left_s;
	scalar_t c_dt, c_tau;             /* what the coefficients were computed for */
	scalar_t lag_al, env_al, gain_al; /* the lag's, the envelope's and the sums' coefficients */
	scalar_t m_lp, e_lp;              /* the low-passed sums of measured and modelled outputs */
	scalar_t m_prev[ROTOR_FAIL_ROTORS], e_prev[ROTOR_FAIL_ROTORS]; /* last frame's outputs */
	scalar_t noise;                  /* sum over rotors of |change of m_j E - M e_j| a frame, averaged */
	scalar_t noise_al;               /* its average's coefficient */
	bool prev_ok;                    /* m_prev, e_prev hold last frame's outputs */
	bool noise_ok;                   /* noise holds a value */
	int8_t n_lp;                     /* the rotors they sum (-1: none yet) */
	scalar_t rf_speed, rf_speed_exc; /* sqrt(ratio_fail), sqrt(ratio_fail_excited) */
};

struct rotor_fail_params rotor_fail_params_default(void);
void rotor_fail_init(struct rotor_fail *s, const struct rotor_fail_params *p);
/* The rotor model; a rotor whose scale is 0 is marked failed, a failed one whose scale is
 * ratio_fail or more again is cleared. */
void rotor_fail_set_model(struct rotor_fail *s, const struct rotor_fail_model *m);
/* One frame. */
struct rotor_fail_output rotor_fail_step(struct rotor_fail *s, const struct rotor_fail_input *in);

#endif /* OCTO_ROTOR_FAIL_H */
