/*
 * hover_est.h - hover-throttle estimator: a one-state Kalman filter on the throttle
 * that holds the vehicle in hover, learned in flight from the vertical acceleration
 * and the collective throttle (after PX4's hover-thrust estimator).
 *
 * Model (z up, S_I): the total thrust is proportional to the collective throttle u (the
 * mean linearised throttle, sum f_j / (8 k_f,nominal)); at the hover throttle u_h it
 * carries the weight, so
 *     a_z + g = g * cos_tilt * u / u_h.
 * With theta = 1 / u_h the prediction is y^ = g cos_tilt u theta and a measurement
 * y = a_z + g gives the relative innovation e = y / y^ - 1 of theta: the filter runs on
 * the relative error of theta (no linearisation about u_h), with its variance P held in
 * percent squared so that Q16.16 keeps its resolution from 0.1 % to 100 %:
 *     r = (100 sigma_acc / y^)^2,  k = P / (P + r),  theta *= 1 + k e,  P = P r / (P + r).
 * Random-walk process noise P += (100 q_rel)^2 dt lets it follow a slow change (battery),
 * and innovations beyond gate_sigma standard deviations are rejected (gusts, contact).
 * A run of rejected innovations of one sign lasting HOVER_EST_GATED_S is no gust: the
 * estimate is wrong and its variance too small (it converged during a fast throttle change
 * through an unmodelled motor lag); the variance is raised to the innovation's square, so
 * that the filter can move again (as PX4's estimator does after repeated rejections).

 * The vertical acceleration is not measured: it is the derivative of the vertical speed
 * through a first-order state-variable filter of time constant tau_s,
 *     v_f' = (vz - v_f) / tau_s,   a_f = (vz - v_f) / tau_s,
 * and u cos_tilt goes through the same filter, so that both sides of the model see the
 * same lag (a lag on one side only would bias u_h during climbs).
 *
 * With an accelerometer (hover_est_update_acc): the specific force along the body's z axis,
 * a_b = f / m, is the thrust itself, so the model is a_b = g u / u_h (no tilt, no
 * derivative): y = a_b and y^ = g u theta, both through the same first-order filter of time
 * constant tau_s (the motor lag and the accelerometer's vibration are then out of the
 * innovation), with the accelerometer's own noise level sigma_imu. The caller calibrates a_b
 * (at rest it reads exactly 1 g: env_hover.h). A filter runs on one kind of input at a time:
 * a change of kind restarts it.
 *
 * Ground: on the ground the acceleration is zero whatever the throttle, so no update is
 * made there. While the caller commands a climb that has not lifted off,
 * hover_est_spool() raises u_h at a bounded rate (the controller then raises the
 * throttle with it): take-off works from a nominal k_f far too large.
 *
 * Results: u_h and its standard deviation, and the thrust coefficient it implies,
 * k_f = m g / (n u_h) with sd(k_f) = k_f sd(u_h) / u_h (first order).
 *
 * The filter's variance P is that of its model, a random walk of q_rel: it lets the filter
 * follow a change of the hover throttle, and it is much larger than what a battery's drift
 * does, so sqrt(P) overstates the error (by about three on a hover). The error itself is
 * e' = (1 - k) e + k nu per update (nu the measurement's relative noise), so its variance
 * from the noise is V' = (1 - k)^2 V + k^2 R, with R the noise's variance per update
 * including its correlation (the filtered reading's, the vibration's): B times the
 * variance of a mean of B innovations, measured as half the squared change between
 * consecutive block means (HOVER_EST_BLK), averaged over HOVER_EST_BLK_AVG blocks. Only
 * blocks that begin once the filter has settled count (P's decrease per update within
 * twice the process noise's increase): before, the innovations are its convergence, not
 * the noise.
 *
 * Lag: the estimate is a mean of innovations of mean age (1 - k) / k updates, and the
 * filters add tau_s: it lags a drift by that age, an error of the drift's sign on every
 * vehicle (about 1.2 s, 0.05 % at 2.5 %/min: about half the error's sd in a hover). The
 * innovations' mean over about the filter's memory (the average of the block means with
 * weight 1/2 a block) is the error now, the lag of (1 - k) / k updates (in a drift the
 * error is the same from update to update); times 1 + tau_s k / (dt (1 - k)) it is the whole
 * lag, and hover_est_u_ahead is u_h moved ahead by it (with drift_per_s > 0). That holds at
 * any drift rate: the sd carries the move's own noise, not a drift's bound. (The estimate's
 * own slope over the settled blocks, some 4 s at a HOLD entry, shows the drift no better:
 * its error is about the drift itself.) A convergence still under way (an error decaying
 * through the filter's memory) shows a larger mean than the error now and is overtaken.
 * hover_est_sd_err's variance is the sum of
 *  - the larger of V and the estimate's own wander: the variance of its values at the last
 *    HOVER_EST_BLK_AVG blocks' ends about their straight line, plus the line's change over
 *    half the window beyond what a drift of drift_per_s makes, squared (a vibration that
 *    folds slower than the blocks moves the estimate but not the block means' changes, and
 *    no battery moves k_f so fast);
 *  - moved ahead: the move's noise, that of the innovations' mean, (r_eff / B) / 3 (the
 *    average of white block means with weight 1/2), times the factor's square;
 *  - with drift_per_s 0 (not moved): the innovations' mean, squared, counted beyond twice
 *    its own noise's variance.
 * With the accelerometer, u goes through the motors' lag tau_m_s (dt / (tau_m + dt / 2) per
 * frame: 1 - exp(-dt / tau_m) to second order) before the filter: the thrust the
 * accelerometer reads lags the throttle by it, and an unmodelled lag makes every throttle
 * change an innovation (the attitude and height loops' activity), which the block means'
 * changes overstate at the filter's slower memory.
 *
 * Units: m/s, m/s^2, s, throttle (0..1). No heap, no globals.
 */
#ifndef OCTO_HOVER_EST_H
#define OCTO_HOVER_EST_H

#include "sc_recip.h"

#include <stdbool.h>
#include <stdint.h>

#define HOVER_EST_GATED_S 1.0f
#define HOVER_EST_BLK 45u    /* innovations per block of the error's measured variance (0.5 s at 90 Hz) */
#define HOVER_EST_BLK_AVG 8u /* blocks averaged */

struct hover_est_params {
	scalar_t u_min; /* accepted hover throttle range, e.g. [0.02, 0.95] */
	scalar_t u_max;
	scalar_t sigma_u0;    /* initial standard deviation of u_h as a fraction of u_h (e.g. 1.0) */
	scalar_t sigma_acc;   /* measurement noise of the filtered acceleration, m/s^2 */
	scalar_t sigma_imu;   /* the same of the filtered accelerometer reading, m/s^2 */
	scalar_t q_rel;       /* process noise: relative drift of u_h per sqrt(s) */
	scalar_t tau_s;       /* state-variable filter time constant, s */
	scalar_t tau_m_s;     /* the motors' first-order lag (the accelerometer's thrust behind u), s; 0: none */
	scalar_t drift_per_s; /* a battery's drift of u_h, relative per s (the wander's bound); > 0: moved ahead */
	scalar_t gate_sigma;  /* innovation gate, standard deviations */
	scalar_t spool_rate;  /* ground spool-up: fraction of u_h per second */
	scalar_t g_mps2;
};

struct hover_est {
	struct hover_est_params p;
	scalar_t theta;    /* 1 / u_h */
	scalar_t p_pct2;   /* variance of theta's relative error, percent^2 */
	scalar_t v_f;      /* filtered vertical speed (or specific force, acc) */
	scalar_t uc_f;     /* filtered u cos_tilt */
	scalar_t u_m;      /* u through the motors' lag (the accelerometer's kind of input) */
	bool primed;       /* filters initialised */
	bool acc;          /* the filters hold the accelerometer's kind of input */
	int8_t gated_sign; /* sign of the current run of gated innovations */
	uint32_t updates;  /* accepted measurements */
	uint32_t rejected; /* gated measurements */
	scalar_t gated_s;  /* time of the current run of gated innovations of one sign, s */
	/* the error's variance as the data show it (hover_est_sd_err) */
	scalar_t v_pct2;  /* of theta's relative error from the noise, percent^2 */
	scalar_t r_eff;   /* the innovations' noise, percent^2 per update, correlation included */
	scalar_t e_mean;  /* the innovations' mean over about the filter's memory, percent (the error now) */
	scalar_t b_sum;   /* the block under way: its innovations' sum, percent */
	scalar_t b_prev;  /* the last block's mean */
	uint32_t b_n;     /* innovations in the block under way */
	uint32_t b_count; /* blocks ended since the filter settled */
	bool b_settled;   /* the filter had settled at the last block's end */
	scalar_t k_last;  /* the last update's gain */
	scalar_t th_ref;  /* theta at the first settled block's end */
	scalar_t w_x[HOVER_EST_BLK_AVG]; /* theta at the last settled blocks' ends, percent of th_ref (a ring) */
	/* what depends on the parameters and the frame period only, computed at init and when
	 * the period changes: the update's divisions by them become products, with the same
	 * quotients */
	scalar_t theta_lo, theta_hi; /* 1 / u_max, 1 / u_min */
	struct sc_recip r_tau;       /* 1 / tau_s */
	scalar_t al_dt, al;          /* the filters' coefficient dt / (tau + dt) and its dt (0: none) */
	scalar_t am;                 /* the motor lag's coefficient dt / (tau_m + dt / 2) (1: none) */
	scalar_t q2;                 /* (100 q_rel)^2, percent^2 per s */
	scalar_t y_min;              /* 0.05 g: the least predicted acceleration that is learnt from */
	scalar_t r_sd0;              /* 100 sigma_acc */
	scalar_t r_sd0_imu;          /* 100 sigma_imu */
	scalar_t gate2;              /* gate_sigma^2 */
};

/* Defaults: u_h in [0.02, 0.95], sigma_u0 1.0, sigma_acc 0.5 m/s^2, sigma_imu 0.3 m/s^2,
 * q_rel 0.003 /sqrt(s), tau 0.1 s, no motor lag, no drift allowed for, gate 4 sigma, spool
 * 0.6 /s, g 9.796. */
struct hover_est_params hover_est_params_default(void);

/* Starts from the nominal hover throttle u0 (clamped to the range), relative sd sigma_u0. */
void hover_est_init(struct hover_est *s, const struct hover_est_params *p, scalar_t u0);

/* One airborne step: vertical speed vz (up), collective throttle u, cos of the tilt.
 * Returns true when the measurement was used (false: filters priming, gated or bad input). */
bool hover_est_update(struct hover_est *s, scalar_t vz_mps, scalar_t u, scalar_t cos_tilt, scalar_t dt_s);

/* A step on the ground (or not to be used): keeps the filters in step with the signals
 * without updating the state. */
void hover_est_track(struct hover_est *s, scalar_t vz_mps, scalar_t u, scalar_t cos_tilt, scalar_t dt_s);

/* The same two from the accelerometer: a_mps2 the specific force along the body's z axis
 * (calibrated), m/s^2. */
bool hover_est_update_acc(struct hover_est *s, scalar_t a_mps2, scalar_t u, scalar_t dt_s);
void hover_est_track_acc(struct hover_est *s, scalar_t a_mps2, scalar_t u, scalar_t dt_s);

/* Ground spool-up (a climb commanded, no lift-off): u_h *= 1 + spool_rate dt, up to u_max;
 * the variance is kept at least at the initial one. */
void hover_est_spool(struct hover_est *s, scalar_t dt_s);

/* Hover throttle and its standard deviation (the filter's: its random walk q_rel sets it). */
scalar_t hover_est_u(const struct hover_est *s);
scalar_t hover_est_sd(const struct hover_est *s);

/* u_h moved ahead by its lag behind a drift, as the innovations' mean shows it (header
 * comment, "Lag"): what hover_est_sd_err is the sd of. hover_est_u itself before two settled
 * blocks, or with drift_per_s 0. */
scalar_t hover_est_u_ahead(const struct hover_est *s);

/* The standard deviation of hover_est_u_ahead's error as the data show it: the filter's own
 * gains applied to the innovations' measured noise or the estimate's own wander, and the
 * move's noise (header comment); the filter's before two settled blocks of innovations
 * have been seen. */
scalar_t hover_est_sd_err(const struct hover_est *s);

/* True once the relative standard deviation of u_h is below rel_sd. */
bool hover_est_converged(const struct hover_est *s, scalar_t rel_sd);

#endif /* OCTO_HOVER_EST_H */
