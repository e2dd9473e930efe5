/*
 * ident.h - in-flight identification estimators: rotor coefficients k_f, k_tau
 * (lag-aware and the paper's plain estimator side by side), inertia about one body axis,
 * validation statistics (NE, fit %), and the acceptance rule.
 *
 * Rotor coefficients: one RLS (1 parameter, 2 outputs) of the measured thrust and torque of
 * rotor 1 on the lag-aware regressor phi_k = g(s_hat_k), the previous frame's throttle through
 * the modelled delay (ID_DELAY_FR) and lag (ID_MOT_TAU); beside it the paper's plain
 * estimator (eqs. 18-20: the raw command of the same frame), biased whenever thrust lags.
 * Inertia about axis i: Euler's equation sampled exactly over a frame, torque (from the
 * measured rotor forces through Gamma_o), rate and gyroscopic product through the same
 * state-variable filter, RLS of 1 parameter.
 * The derivations: docs/identification.md, "Inertia and rotor coefficients".
 *
 * ---------------------------------------------------------------- number formats
 * One source, two builds (docs/number-formats.md). What runs every frame (ident.c: the
 * delay, lag and sensitivity, the regressors, the SVF, the instrumental-variable sums, the
 * validation sums, the body torque) is scalar_t and integer in the fixed build, with the
 * RLS's own formats inside (rls.h). Initialisation, the float getters and the acceptance
 * rules run off the 90 Hz path and are float in both builds (ident_setup.c).
 *   signals (throttle, N, N m, rad/s, rad/s^2), filter states        scalar_t: Q16.16
 *   sums of products of two signals (ident_sum_t)                    Q31.32 in int64:
 *       each product exact; range +/-2.1e9, resolution 2.3e-10; saturate (never wrap).
 *       An hour at 90 Hz (324,000 frames) of products up to 6,600 (e.g. 1 N m x 6,600
 *       rad/s^2, or (81 N)^2) fits; larger ones saturate and the estimate stays finite.
 *   counters                                                         uint32_t
 * Float build: ident_sum_t is float.
 */
#ifndef OCTO_IDENT_H
#define OCTO_IDENT_H

#include "filt.h"
#include "mixer.h"
#include "rls.h"
#include "scalar.h"

#include <stdbool.h>
#include <stdint.h>

#define IDENT_ROTORS 8

/* sums of products of two scalar_t values (see the formats above) */
#if OCTO_FIXED
typedef int64_t ident_sum_t; /* Q31.32 (QF_PROD_FRAC) */
#else
typedef float ident_sum_t;
#endif

/* the two other axes (j, k) = (i + 1, i + 2) mod 3 of axis i, cyclic */
static inline void ident_other_axes(unsigned i, unsigned *j, unsigned *k)
{
	*j = i >= 2u ? 0u : i + 1u; /* no division: Cortex-M0 has no divider */
	*k = i == 0u ? 2u : i - 1u;
}

/* ---------------------------------------------------------------- rotor coefficients */
struct ident_rotor_cfg {
	scalar_t dt_s;         /* frame period (90 Hz: 1/90) */
	scalar_t mot_tau_s;    /* modelled first-order lag (0 = none) */
	uint32_t delay_frames; /* modelled transport delay beyond the loop's one frame */
	scalar_t curve;        /* thrust curve c of g(s) (MOT_CURVE; 0 = linear) */
	scalar_t thr0;         /* throttle before the start (initial state of delay and lag) */
	float kf0, ktau0;      /* initial estimates (nominal values) */
	float p0;              /* initial covariance (0 = 1e6) */
};

struct ident_rotor {
	scalar_t mot_tau_s, curve; /* of the configuration: what is read after the init */
	struct filt_delay delay;
	struct filt_lag lag;
	struct rls lagaware; /* theta[0][0] = k_f, theta[1][0] = k_tau */
	struct rls plain;
	struct rls sens;      /* lag check: f_1 on [phi, d phi / d tau_m] (2 parameters) */
	scalar_t dphi_dtau;   /* sensitivity of the lagged throttle to tau_m, 1/s */
	scalar_t dalpha_dtau; /* d alpha / d tau_m of the lag's coefficient, 1/s */
	scalar_t phi;         /* last lag-aware regressor */
	scalar_t y_prev[2];   /* measurement of the previous frame (for the plain update) */
	bool have_prev;
	uint32_t n;
	/* the frame ident_rotor_update took, its RLS updates waiting for ident_rotor_process:
	 * the sensitivity's regressor, the plain pair, the measurement */
	scalar_t q_dphi, q_phi_raw, q_y_prev[2], q_y[2];
	bool q_plain, q_excited, q_pending;
};

void ident_rotor_init(struct ident_rotor *r, const struct ident_rotor_cfg *cfg);

/* One frame: thr_sent_prev = throttle of the rotor sent on the previous frame; f_meas, tau_meas
 * = measured thrust (N) and reaction-torque magnitude (N m) of this frame. `excited` gates
 * both RLS (false: the filters run, the estimates do not move). The step advances the delay,
 * lag and sensitivity and forms the regressors; the three RLS updates wait for
 * ident_rotor_process (between frames). An update, and every getter below, processes a frame
 * still waiting first, so nothing is lost or reordered and the estimates read include every
 * frame taken. */
void ident_rotor_update(struct ident_rotor *r, scalar_t thr_sent_prev, scalar_t f_meas, scalar_t tau_meas,
			bool excited);
/* Between frames: the RLS updates of the frame ident_rotor_update took (no-op if none waits). */
void ident_rotor_process(struct ident_rotor *r);

/* A frame without measurement (lost on the link): the plant held thr_sent_prev for one more
 * frame; the delay, lag and sensitivity advance, nothing is estimated, and the plain
 * estimator's pairing restarts. */
void ident_rotor_hold(struct ident_rotor *r, scalar_t thr_sent_prev);

/* estimates and standard deviations: which 0 = k_f, 1 = k_tau (each processes a waiting
 * frame first: ident_rotor_update) */
float ident_rotor_est(struct ident_rotor *r, unsigned which);
float ident_rotor_sd(struct ident_rotor *r, unsigned which);
/* All four at once, as ident_rotor_est/sd/plain/plain_sd give them (the same values):
 * est = {k_f, k_tau, k_f plain, k_tau plain}, sd = their standard deviations. */
void ident_rotor_read(struct ident_rotor *r, float est[4], float sd[4]);
float ident_rotor_plain(struct ident_rotor *r, unsigned which);
static inline float ident_rotor_plain_sd(struct ident_rotor *r, unsigned which)
{
	ident_rotor_process(r);
	return rls_std(&r->plain, which, 0);
}

/* Check of the modelled motor lag (a Gauss-Newton step, not used by the estimates above):
 * f_1 regressed on [phi(tau), d phi / d tau] at the modelled tau gives
 * [k_f, k_f (tau_true - tau)] to first order, so tau_hat = tau + theta_2 / theta_1. The
 * sensitivity runs beside the lag: sigma_k = (1 - alpha) sigma_(k-1) + alpha' (u_k - s_(k-1)),
 * alpha' = d alpha / d tau = -(dt / tau^2) exp(-dt / tau). Returns tau_hat (s), or -1 when
 * the model has no lag (tau = 0: no sensitivity) or no data. */
float ident_rotor_tau_check(struct ident_rotor *r);

/* The closed form of the plain estimator's relative bias (the formula above); an inline (no
 * flash unless a caller uses it: the firmware does not, the tests do) */
static inline float ident_plain_bias(float e_d2, float e_d_dlag, float t_hover)
{
	float den = t_hover * t_hover + e_d2;
	return den > 0.0f ? -(e_d2 - e_d_dlag) / den : 0.0f;
}

/* ---------------------------------------------------------------- body torque */
/* Torque about S_B from measured rotor thrusts f[8] (N) through Gamma_o rows 2-3 (eq. 14,
 * arm l) and yaw from the measured reaction-torque magnitudes tm[8] (odd rotors +, even -). */
void ident_body_torque(scalar_t arm_l_m, const scalar_t f[IDENT_ROTORS], const scalar_t tm[IDENT_ROTORS],
		       scalar_t tau_out[3]);

/* The same torque through the mixer's own Gamma (its rotor mask and layout, custom or
 * eq. (14) with its arm length): roll and pitch are rows 2-3 of Gamma f; yaw is the sum of
 * the measured reaction torques of the rotors present, signed as Gamma's yaw row (the
 * measured torques, not k_tau / k_f times the thrusts). */
void ident_body_torque_mixer(const struct mixer *m, const scalar_t f[IDENT_ROTORS], const scalar_t tm[IDENT_ROTORS],
			     scalar_t tau_out[3]);

/* ---------------------------------------------------------------- inertia */
#define IDENT_INR_LAGS 32u /* most lags of the residual's autocovariance in the IV std */

struct ident_inertia {
	unsigned axis;     /* 0 x, 1 y, 2 z */
	scalar_t coupling; /* I_k - I_j of the gyroscopic term */
	scalar_t alpha;    /* torque weight (ident_torque_weight) */
	scalar_t inv_dt;
	scalar_t tau_prev, ww_prev, wf_prev, w_prev;
	struct filt_svf svf_tau, svf_w, svf_ww;
	struct rls rls;
	float sd_scale; /* coloured-residual correction of the RLS std */
	uint32_t n;
	/* instrumental variable (ident_inertia_instrument): the excitation through the same SVF */
	struct filt_svf svf_z;
	scalar_t z_in;          /* the instrument's input for the next update */
	bool iv;                /* an instrument was given: the estimate is the IV one */
	uint32_t s_n, b_len;    /* excited updates; those before the estimate is the IV one */
	ident_sum_t s_zy, s_zp; /* sums of z y and z phi over the excited updates */
	/* the IV std (ident_inertia_sd): lag products of the instrument from the first excited
	 * update on, of the residual r = y - i0 phi from the b_len-th on (i0: the IV ratio
	 * then), over runs of consecutive excited updates (a ring of the last ones) */
	scalar_t i0;
	bool r_on;                   /* the residual's sums run */
	uint32_t lags;               /* largest lag, <= IDENT_INR_LAGS */
	uint32_t ring_pos, z_n, r_n; /* next slot; entries with z, with r */
	scalar_t ring_z[IDENT_INR_LAGS], ring_r[IDENT_INR_LAGS], ring_p[IDENT_INR_LAGS];
	ident_sum_t c_zz[IDENT_INR_LAGS + 1]; /* sum z_k z_(k+h) */
	ident_sum_t c_rr[IDENT_INR_LAGS + 1], c_rp[IDENT_INR_LAGS + 1], c_pp[IDENT_INR_LAGS + 1];
	uint32_t c_rn[IDENT_INR_LAGS + 1]; /* the residual's pairs at lag h */
	/* the frame ident_inertia_update took, its updates waiting for ident_inertia_process */
	scalar_t q_phi, q_y, q_z;
	bool q_excited, q_pending, q_iv;
	/* the torque's sensitivity to a model parameter (ident_inertia_sensitivity) through the
	 * torque's filter, and its sum with the instrument over the excited updates */
	struct filt_svf svf_d;
	scalar_t d_in, d_prev;
	ident_sum_t s_zd;
	bool sens;
};

/* The std: the RLS std assumes white residuals, but the SVF colours the (white) torque
 * noise; with a regressor slow compared with wc the estimate's variance is that of the
 * unfiltered noise, whose power is 4 zeta / (wc dt) times the filtered one. So
 * ident_inertia_sd = rls_std * sqrt(4 zeta / (wc dt)) (checked by Monte Carlo in
 * tests/core/test_ident.c and against the spread over simulated flights).
 * wc, zeta: the SVF; inertia[3]: current values (the two others enter the gyroscopic term;
 * the axis' own is the initial estimate). */
void ident_inertia_init(struct ident_inertia *e, unsigned axis, scalar_t wc_rps, scalar_t zeta, scalar_t dt_s,
			scalar_t alpha, const scalar_t inertia[3], const scalar_t w0[3], const scalar_t tau0[3]);
/* Weight of the torque measured at the end of a frame in the frame's mean torque when every
 * rotor thrust is a first-order lag tau_m of a throttle held over the frame (exact):
 *     alpha = (1 - c) / (1 - a), a = exp(-dt / tau_m), c = (tau_m / dt) (1 - a); 1 if tau_m <= 0 */
scalar_t ident_torque_weight(scalar_t tau_m_s, scalar_t dt_s);
/* One frame: body torque (ident_body_torque) and body rates of the same frame. The step runs
 * the filters and the instrument's sums; the RLS update waits for ident_inertia_process
 * (between frames); an update and the getters process a frame still waiting first. */
void ident_inertia_update(struct ident_inertia *e, const scalar_t tau_b[3], const scalar_t w_b[3], bool excited);
/* Between frames: the RLS update of the frame ident_inertia_update took (no-op if none waits). */
void ident_inertia_process(struct ident_inertia *e);
/* Frames lost on the link before this frame's update (the plant held the last command over
 * them). The filters assume uniform sampling: one update for k + 1 frames would see the
 * change of the gyro over all of them as one frame's derivative, an equation error
 * correlated with the excitation (the estimate biased low). ident_inertia_gap advances the
 * filters through k lost frames with values interpolated linearly between the last update's
 * and this frame's (tau_b, w_b), the instrument held, without adding to the estimate; the
 * residual error, second order in the gap, decays with the filters (a few frames without
 * updates after it: the caller's). ident_inertia_restart, for a gap too long to interpolate
 * or of unknown length: every filter at rest at this frame's values (the caller then waits
 * for the filters to settle, ident_inertia_settle_frames). Either is followed by the frame's
 * ident_inertia_update. */
void ident_inertia_gap(struct ident_inertia *e, const scalar_t tau_b[3], const scalar_t w_b[3], unsigned k);
void ident_inertia_restart(struct ident_inertia *e, const scalar_t tau_b[3], const scalar_t w_b[3]);
float ident_inertia_est(struct ident_inertia *e);
float ident_inertia_sd(struct ident_inertia *e);
/* Instrumental variable against gyro noise. The regressor phi is the derivative of the
 * filtered gyro, so gyro noise is noise in the regressor (errors in variables): least squares
 * is then biased low by var(noise of phi) / var(phi) (-3 ... -8 % on yaw at 10x the default
 * gyro noise), and the attitude loop feeds the same noise into the torque, which biases the
 * reversed regression too. The excitation u (the torque added by the experiment, known and
 * independent of every noise) filtered by the same SVF is an instrument z:
 *     I = sum z y / sum z phi,   I - I_true = sum z r / sum z phi,  r = y - I_true phi.
 * The residual r is noise the SVF colours (stationary, independent of the known z), so
 *     var(I) = sum_h w_h Z(h) R(h) / (sum z phi)^2,   w_0 = 1, w_h = 2,
 * Z(h) = sum_k z_k z_(k+h) (known exactly), R(h) the residual's autocovariance at lag h,
 * estimated from every pair of the run, h up to the SVF's 5 time constants 1 / (zeta wc)
 * (at most IDENT_INR_LAGS frames): hundreds of pairs per lag, so the std is nearly exact and
 * error / std a unit normal, tails included (a std from twenty 0.5 s blocks' sums has far
 * fewer degrees of freedom: its error / std has a t's heavy tails, docs/identification.md).
 * Called before each ident_inertia_update with the excitation that acted over the frame that
 * update closes; est and sd are the IV ones from the first 0.5 s of excited updates on
 * (before, the least-squares ones, as live values). */
void ident_inertia_instrument(struct ident_inertia *e, scalar_t u);

/* A torque modelled from identified parameters carries their error into the estimate: with
 * d the modelled torque's derivative (axis' N m) in a parameter p, passed before each
 * ident_inertia_update, d I / d p = I sum z d_f / sum z y (d_f: d through the torque's own
 * filter), which ident_inertia_sens_rel returns as (d I / I) / d p (0 before the IV
 * estimate, or without d). Linear in d: one pass, no second estimator. */
void ident_inertia_sensitivity(struct ident_inertia *e, scalar_t d);
float ident_inertia_sens_rel(struct ident_inertia *e);
/* The IV ratio of the sums so far into *i0, for ident.c's residual; false (*i0 kept) while
 * sum z phi is 0 or the ratio is not finite. */
bool ident_inertia_ratio_sc(const struct ident_inertia *e, scalar_t *i0);

/* Acceptance of an inertia, relative to the vehicle's own scale m l^2 (mass, arm length)
 * rather than to a nominal inertia that may be far off: a body whose mass sits within the
 * rotor circle has I <= m l^2 about any axis through its centre, and a multirotor's frame,
 * battery and rotors keep it above a small fraction of it, so the accepted range is
 * [IDENT_INR_LO, IDENT_INR_HI] x m l^2 (bounds returned in lo/hi for the message).
 * When the relative std is too large, *raise is the factor by which the excitation
 * amplitude must grow to reach rsd_max (the std falls as 1 / amplitude; the time needed
 * instead is raise^2 as long: std ~ 1 / sqrt(T)); 1 otherwise. */
#define IDENT_INR_LO 0.01f
#define IDENT_INR_HI 2.0f
enum ident_verdict ident_inertia_accept(float est, float sd, float mass_kg, float arm_l_m, float rsd_max, float *lo,
					float *hi, float *raise);

/* ---------------------------------------------------------------- validation */
/* y (measured) against y_hat (model): NE = RMS(y - y_hat) / RMS(y),
 * fit % = 100 (1 - ||y - y_hat|| / ||y - mean(y)||). The sums are of the deviations from
 * the first sample y0 (shifted data: sum y^2 and the sum of squared deviations from the
 * mean follow without cancellation), ident_sum_t; no division per sample. */
struct ident_fit {
	uint32_t n;         /* samples */
	scalar_t y0;        /* the first sample */
	ident_sum_t s1, s2; /* sum (y - y0), sum (y - y0)^2 */
	ident_sum_t sse;    /* sum (y - y_hat)^2 */
};

void ident_fit_init(struct ident_fit *v);
void ident_fit_add(struct ident_fit *v, scalar_t y, scalar_t y_hat);
float ident_fit_ne(const struct ident_fit *v);
float ident_fit_pct(const struct ident_fit *v);

/* ---------------------------------------------------------------- acceptance */
enum ident_verdict {
	IDENT_ACCEPT = 0,
	IDENT_NOT_FINITE,   /* estimate or std not finite (texts: short, for STATUSTEXT) */
	IDENT_OUT_OF_RANGE, /* outside [0.25, 4] x nominal */
	IDENT_UNCERTAIN,    /* relative std >= rsd_max (or no data) */
};

#define IDENT_RANGE_LO 0.25f
#define IDENT_RANGE_HI 4.0f

enum ident_verdict ident_accept(float est, float sd, float nominal, float rsd_max);
const char *ident_verdict_text(enum ident_verdict v);

#endif /* OCTO_IDENT_H */
