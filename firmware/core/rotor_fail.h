/*
 * rotor_fail.h - a failed rotor, found from what the rotors measure.
 *
 * Each frame every rotor's measured output is compared with what its command asks. The
 * command is the throttle sent in the last step (what the plant answers with now), passed
 * through the motor lag (first order, tau_lag) and the thrust curve g(T) = (1 - c) T + c T^2:
 *   thrust rows:  r_j = f_j / (scale_j g_j)          (k_f, when the model is right)
 *   rotor speed:  r_j = w_j / sqrt(g_j)              (speed_max, thrust going with speed^2)
 * and divided by the median of the rotors judged, so that neither k_f nor the speed at full
 * throttle need be known, and a k_f drift or a wrong VEH_KF move every rotor alike. What is
 * left, q_j = r_j / median (squared for the speed), is rotor j's effectiveness relative to
 * what MOT_SCALEj says. The decision compares the measured output with the smallest modelled
 * output of the last ROTOR_FAIL_WINDOW frames, through the model's lag and without it: before
 * identification the model's lag and delay are the nominal ones, and a working rotor slower,
 * faster or later than the model still gives at least that (its output follows some recent
 * command), while a failed one gives far less.
 * A rotor whose q_j so formed stays below ratio_fail for `confirm` frames in a row has
 * failed; its effectiveness is then scale_j times the mean of the plain q_j over those frames
 * (0 below ratio_zero: the rotor is left out of the allocation).
 *
 * The thrust rows decide when the frame has them; the speed when it has only that. A rotor
 * is judged only while its modelled output is at least share_min of the mean (a rotor the
 * mixer holds near zero says nothing), the mean throttle at least g_min, and at least four
 * rotors are judged (a median of fewer is not robust to one failure).
 *
 * After a detection `land` is raised once, hold_s later: the vehicle holds on the remaining
 * rotors, then lands. A rotor stays in `failed` until its scale is set back to ratio_fail
 * or more; a rotor whose scale is 0 is failed (and not judged).
 *
 * Pure: no I/O, no globals; scalar_t in both builds (the ratios are about 1, the speeds
 * over sqrt(g) below 2,000 rad/s).
 */
#ifndef OCTO_ROTOR_FAIL_H
#define OCTO_ROTOR_FAIL_H

#include "scalar.h"

#include <stdbool.h>
#include <stdint.h>

#define ROTOR_FAIL_ROTORS 8
/* frames of modelled output the decision looks back over: longer than the motor lag and delay
 * of any motor the experiments meet, beyond the nominal ones (about 0.15 s at 90 Hz) */
#define ROTOR_FAIL_WINDOW 14

enum rotor_fail_source {
	ROTOR_FAIL_SRC_NONE = 0,
	ROTOR_FAIL_SRC_THRUST = 1, /* the measured thrust rows */
	ROTOR_FAIL_SRC_SPEED = 2,  /* the rotor speeds (ESC telemetry) */
};

struct rotor_fail_params {
	scalar_t ratio_fail; /* q_j below this is failing (0.6) */
	scalar_t
		ratio_fail_excited; /* ... while an experiment excites the rotors through a model not yet identified (0.3) */
	scalar_t ratio_zero;        /* a detected effectiveness below this is 0 (0.1) */
	scalar_t share_min;         /* judged only while its modelled output is this share of the mean (0.3) */
	scalar_t g_min;             /* ... and the mean g(T) is at least this (0.02) */
	scalar_t hold_s;            /* hold before landing (2 s) */
	uint8_t confirm;            /* frames in a row (3) */
};

/* The rotor model (set when the parameters change): lag, curve, effectiveness. */
struct rotor_fail_model {
	scalar_t tau_lag_s;                /* ID_MOT_TAU */
	scalar_t curve;                    /* MOT_CURVE */
	scalar_t scale[ROTOR_FAIL_ROTORS]; /* MOT_SCALEj (0: failed, left out) */
};

struct rotor_fail_input {
	const scalar_t *thr;       /* the throttles sent in the last step (ROTOR_FAIL_ROTORS) */
	const scalar_t *thrust_n;  /* measured thrusts, N; NULL: not in this frame */
	const scalar_t *speed_rps; /* measured rotor speeds, rad/s; NULL: not in this frame */
	scalar_t dt_s;             /* this step's time */
	bool judge;                /* flying: rotors are judged (else only the lag filter runs) */
	bool excited;              /* an experiment's excitation: ratio_fail_excited decides */
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
	scalar_t lag[ROTOR_FAIL_ROTORS];                     /* lag-filtered throttles */
	scalar_t hist[ROTOR_FAIL_WINDOW][ROTOR_FAIL_ROTORS]; /* the modelled outputs of recent frames */
	uint8_t hist_at, hist_n;                             /* the next slot; slots filled */
	scalar_t q_sum[ROTOR_FAIL_ROTORS];                   /* sum of q_j over the current streak */
	uint8_t streak[ROTOR_FAIL_ROTORS];
	uint8_t failed; /* bit j: rotor j+1 has failed */
	bool primed;    /* the lag filter holds a value */
	bool holding;   /* a detection's hold is running */
	scalar_t hold_left_s;
	scalar_t c_dt, c_tau, lag_al; /* the lag coefficient and what it was computed for */
};

struct rotor_fail_params rotor_fail_params_default(void);
void rotor_fail_init(struct rotor_fail *s, const struct rotor_fail_params *p);
/* The rotor model; a rotor whose scale is 0 is marked failed, a failed one whose scale is
 * ratio_fail or more again is cleared. */
void rotor_fail_set_model(struct rotor_fail *s, const struct rotor_fail_model *m);
/* One frame. */
struct rotor_fail_output rotor_fail_step(struct rotor_fail *s, const struct rotor_fail_input *in);

#endif /* OCTO_ROTOR_FAIL_H */
