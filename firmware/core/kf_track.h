/*
 * kf_track.h - tracking a drifting thrust coefficient k_f in hover: scalar recursive
 * least squares with exponential forgetting whose memory is sized to the noise.
 *
 * Model: y = k_f phi + e, with y the sum of the measured rotor thrusts (N) and phi the
 * sum of the rotors' throttles passed through the thrust curve and the motor lag (a
 * first-order filter of time constant tau_lag), so that a throttle change is compared
 * with the thrust it produces, not with the thrust before it.
 *
 * Memory: with relative noise s (sd of e / y per sample), sample rate f_s and a drift
 * of r (fraction of k_f per second), the tracking error of a memory T has variance
 * s^2 / (f_s T) (noise) plus (r T)^2 (lag behind the drift); the best memory is
 *     T* = (s^2 / (4 r^2 f_s))^(1/3),   lambda = 1 - dt / T*
 * (the regressor's power is already in s, the noise relative to y). s is learned from
 * the change of the residual from sample to sample (exponential average over s_tau_s; a
 * tracking error or a step changes slowly and is not taken for noise), r is the parameter drift_per_min
 * (the largest drift to follow), T* is bounded to [t_min_s, t_max_s].
 *
 * Wind-up: forgetting without excitation makes P grow without bound. Updates are gated
 * on phi >= phi_min (rotors turning, vehicle flying: the caller's gate), and P is bounded
 * by its steady state at the shortest memory, so it never winds up.
 *
 * Estimate and sd: kr = sum lambda^i phi y / sum lambda^i phi^2; with P = 1 / sum lambda^i phi^2,
 * var(kr) = sigma^2 P / (1 + lambda) (sigma = s y). Q16.16: the noise is kept in percent.
 *
 * Lag: kr is a weighted mean of the samples' y / phi, so it lags a drift by their mean age,
 * about one memory T*: at the best memory that lag is comparable to kr's sd, an error of
 * the drift's sign on every sample. The published k is kr moved ahead by that age along
 * the drift measured by the long windows (below: the slope of kr's line over KF_TRACK_L_MEM
 * T*), the slope bounded by drift_per_min (a step is no drift). The correction's own error
 * (the change of the slope from window to window) and the lag it leaves (a drift beyond the
 * bound) are in the long windows' part of the sd.
 *
 * Samples: with avg_n > 1 the tracker updates once per avg_n frames, on the means of y and
 * of the lag-filtered regressor over them (the lag filter still runs every frame). That is
 * for a y whose noise is coloured at the frame rate (an accelerometer's vibration folded
 * near half the frame rate): the means are nearly white at their own rate, which the noise
 * estimate and var(k) assume. A block with a gated frame is dropped. avg_n = 1 updates on
 * every frame.
 *
 * Coloured noise: var(k) above holds for white noise. Noise slower than the sample rate (an
 * accelerometer's vibration folded close to 0 Hz) moves k by more, and the differences that
 * measure s do not see it. So the measurement y / phi is also averaged over windows of T*:
 * half the squared change between consecutive window means is the variance of a T* mean as
 * observed (noise at every frequency the estimate passes, and the drift over a window), and
 * half that again the variance of a 2 T* mean, the span an exponential memory T* weighs like a
 * plain mean. Averaged over the last KF_TRACK_W_AVG or so comparisons, it is the window part
 * of the sd. A window of T* rather than 2 T* keeps a fold whose period is near 2 T* from
 * passing unseen; it errs on the safe side for white noise (the two parts then agree within
 * sqrt 2). Noise much slower than T* is followed like a drift: so kr's own spread about a
 * straight line fitted over a long window (KF_TRACK_L_MEM T*, the line taking the drift out),
 * with the error of the lag's correction along its slope (above), is a third part, averaged
 * over windows alike: a fold of a period up to a few T* moves k by about its amplitude, and
 * this spread is its rms. A fold slower than the long window (a rotor's harmonic within a few
 * hundredths of a hertz of a multiple of the frame rate: a period of tens of T*) swings k by
 * its amplitude too, and the long window's line follows it: the slow part, the fourth, is kr
 * at each window's end about its line over the last some KF_TRACK_H_MEM windows (weights
 * decaying by 1 - 1 / KF_TRACK_H_MEM a window, the residual variance scaled by
 * n_eff / (n_eff - 2) for the line's two parameters; n_eff > 4). It sees a fold of a period up
 * to about KF_TRACK_H_MEM T* whole (0.8 of its variance at twice that), once it has seen about
 * a period of it; on white noise it is kr's own variance, the formula's. What varies slower
 * than that horizon, or has not yet shown a period since a start, is a bias no part sees. The
 * window parts need a few windows (some 10 T* after a start). kf_track_sd is the largest of
 * the four.
 *
 * The sd is the tracking's alone: relative to the rotor model (curve, scales, lag) the
 * regressor is built from. The model's own uncertainty is the caller's to add (env_kf.h).
 */
#ifndef OCTO_KF_TRACK_H
#define OCTO_KF_TRACK_H

#include "sc_recip.h"

#include <stdbool.h>
#include <stdint.h>

#define KF_TRACK_ROTORS 8
#define KF_TRACK_W_CLIP 5    /* percent: a sample's y / phi from the window's reference, clipped */
#define KF_TRACK_W_MAX 4096u /* samples in a window at most (the clipped sum stays in range) */
#define KF_TRACK_W_AVG 8u    /* window comparisons averaged */
#define KF_TRACK_L_MEM 8     /* a long window: this many memories T* */
#define KF_TRACK_L_MAX 1024u /* samples in a long window at most (its sums stay in range) */
#define KF_TRACK_H_MEM 32    /* the slow part's horizon: a line over some this many windows */

struct kf_track_params {
	scalar_t drift_per_min; /* largest drift to follow, fraction per minute (e.g. 0.02) */
	scalar_t t_min_s;       /* bounds of the memory T*, s */
	scalar_t t_max_s;
	scalar_t phi_min;                /* gate: smallest regressor (sum of throttles) */
	scalar_t tau_lag_s;              /* motor lag of the regressor, s (0: none) */
	scalar_t curve;                  /* thrust curve c: g(T) = (1 - c) T + c T^2 */
	scalar_t scale[KF_TRACK_ROTORS]; /* per-rotor effectiveness: rotor j gives scale_j k g(T_j) */
	scalar_t s_tau_s;                /* averaging time of the noise estimate, s */
	scalar_t s0_pct;                 /* noise assumed before any residual, percent of y */
	uint32_t avg_n;                  /* frames per sample (means over them; 1: every frame) */
};

struct kf_track {
	struct kf_track_params p;
	scalar_t k;       /* estimate, N per unit throttle: kr with its lag behind a drift taken out */
	scalar_t kr;      /* the recursive estimate (the weighted mean of the samples' y / phi) */
	scalar_t P;       /* 1 / sum lambda^i phi^2 */
	scalar_t s2_pct2; /* relative noise variance, percent^2 */
	scalar_t s_pct;   /* its square root, set with it (the update and kf_track_sd read it) */
	scalar_t mem_s;   /* current memory T*, s */
	scalar_t lambda;
	scalar_t p_rt;       /* sqrt(P / (1 + lambda)), set with P and lambda (kf_track_sd reads it) */
	scalar_t phi_f;      /* lag-filtered regressor */
	scalar_t phi_s;      /* the last sample's regressor (a block's mean) */
	scalar_t e_prev_pct; /* last residual, percent of y */
	/* what depends on the frame period and the parameters only, computed when they change
	 * (the update's divisions by them become products) */
	scalar_t c_dt;           /* the frame period they were computed for (0: none yet) */
	scalar_t lag_al;         /* the lag filter's coefficient 1 - e^(-dt/tau_lag) */
	scalar_t a_s;            /* the noise average's coefficient ds / (s_tau_s + ds), ds the sample period */
	scalar_t c_ds;           /* the sample period: avg_n frames */
	scalar_t dt_tmin;        /* sample period / t_min_s */
	struct sc_recip r_drift; /* 1 / drift_per_min */
	scalar_t blk_phi, blk_y; /* sums of the current block of avg_n frames */
	uint32_t blk_n;          /* frames in it */
	/* the window means (coloured noise, header comment) */
	scalar_t w_sum;  /* sum of the samples' y / phi, percent from w_kref (each within +/- KF_TRACK_W_CLIP) */
	scalar_t w_t;    /* the window's time so far, s */
	uint32_t w_n;    /* its samples */
	scalar_t w_kref; /* k at its start, and 100 / w_kref */
	scalar_t w_inv;
	scalar_t w_prev;     /* the last window's mean, N */
	scalar_t w_var_pct2; /* variance of a window's mean, percent^2 (average over windows) */
	uint32_t w_count;    /* windows compared */
	/* the long windows: k's spread about its own straight line over KF_TRACK_L_MEM T* */
	scalar_t l_t, l_tn;     /* the window's time so far, s, and in memories T* */
	uint32_t l_n;           /* its samples */
	scalar_t l_kref, l_inv; /* k at its start, 100 / l_kref */
	scalar_t l_su, l_suu, l_sc, l_scc,
		l_suc;        /* sums of u, u^2, c, c^2, u c (u: time in T*; c: k, percent from l_kref) */
	scalar_t l_var_pct2;  /* the spread's variance, percent^2 (average over windows) */
	scalar_t l_slope_pct; /* the last long window's slope of kr, percent per memory */
	uint32_t l_count;     /* windows ended */
	/* the slow part: kr at each window's end about its line over the last some KF_TRACK_H_MEM
	 * windows (weights decaying by 1 - 1 / KF_TRACK_H_MEM a window) */
	scalar_t h_ref, h_inv; /* kr the values are taken from, and 100 / h_ref */
	scalar_t h_s0, h_s00, h_su, h_suu, h_sc, h_scc,
		h_suc;       /* weighted sums of 1, (the weights squared), u, u^2, c, c^2, u c
			       * (u: a value's age in KF_TRACK_H_MEM windows, <= 0; c: kr, percent from h_ref) */
	scalar_t h_var_pct2; /* the residual variance about the line, percent^2 (0: too few windows yet) */
	bool started;        /* an estimate exists */
	bool primed;         /* the lag filter holds a value */
	uint32_t updates;
};

/* Defaults: 2 %/min, T* in [0.2, 60] s, phi_min 0.08, tau_lag 0.03 s, curve 0, scales 1,
 * noise average 5 s, initial noise 1 %, every frame a sample (avg_n 1). */
struct kf_track_params kf_track_params_default(void);

/* k0 > 0: the starting estimate (e.g. VEH_KF); the first updates replace it quickly. */
void kf_track_init(struct kf_track *s, const struct kf_track_params *p, scalar_t k0);

/* One frame: throttles thr[0..n-1] (n <= KF_TRACK_ROTORS) as commanded, the total thrust
 * measured y (N: the rotors' thrust rows summed, or mass times the specific force), dt.
 * `gate` false (on the ground, a frame without the measurement) only advances the lag filter
 * (and drops the block under way). Returns true when the estimate was updated. */
bool kf_track_update(struct kf_track *s, const scalar_t *thr, int n, scalar_t y_n, scalar_t dt_s, bool gate);

/* Standard deviation of k (N): the largest of the white-noise formula's and the three window
 * parts' (header comment). */
scalar_t kf_track_sd(const struct kf_track *s);

#endif /* OCTO_KF_TRACK_H */
