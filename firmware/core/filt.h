/*
 * filt.h - small discrete filters: first-order lag, integer delay line, and a
 * second-order state-variable filter (SVF) that gives a low-passed signal and its
 * derivative without differentiating (for derivative-free regression: pass torque
 * and body rate through the SAME SVF and regress tau_f on d/dt(omega_f)).
 *
 * All coefficients are computed at init (init may use exp/trig via scalar.h); the
 * update functions use only add and mul. Caller-owned state, no failure: out-of-range
 * arguments are clamped as documented; a non-finite input sample (float build) is
 * ignored by the lag and the SVF (the state and output stay as they were).
 */
#ifndef OCTO_FILT_H
#define OCTO_FILT_H

#include "scalar.h"

#include <stdint.h>

/* ---------------------------------------------------------------- first-order lag
 * y_k = y_(k-1) + alpha (x_k - y_(k-1)),  alpha = 1 - exp(-dt / tau)
 * exact (zero-order hold) discretisation of tau y' + y = x for x constant over each
 * step; tau <= 0 gives alpha = 1 (pass-through). */
struct filt_lag {
	scalar_t alpha;
	scalar_t y;
};

void filt_lag_init(struct filt_lag *f, scalar_t tau_s, scalar_t dt_s, scalar_t y0);
/* returns the new output */
scalar_t filt_lag_update(struct filt_lag *f, scalar_t x);

/* ---------------------------------------------------------------- delay line
 * y_k = x_(k - n) for an integer delay n in [0, FILT_DELAY_MAX] samples (clamped);
 * before n samples have been pushed the output is the initial value. */
#define FILT_DELAY_MAX 16

struct filt_delay {
	scalar_t buf[FILT_DELAY_MAX];
	uint32_t n;    /* delay in samples */
	uint32_t head; /* next write position */
};

void filt_delay_init(struct filt_delay *d, uint32_t n_samples, scalar_t y0);
/* pushes x, returns x delayed by n samples */
scalar_t filt_delay_update(struct filt_delay *d, scalar_t x);

/* ---------------------------------------------------------------- state-variable filter
 * H(s) = wc^2 / (s^2 + 2 zeta wc s + wc^2): y_f = H y and y_f_dot = s H y.
 * Discretised with the bilinear (trapezoidal) rule on the state [y_f, y_f_dot]:
 * unconditionally stable for any wc, dt > 0, DC gain exactly 1, and
 * y_f(k) - y_f(k-1) = dt/2 (y_f_dot(k) + y_f_dot(k-1)) exactly, so y_f_dot is the
 * derivative of y_f in the discrete sense. wc is clamped to [1e-3 / dt, 2 / dt]
 * (frequency warping is visible above ~0.3 / dt). Delay of the low-pass at low
 * frequency: 2 zeta / wc.
 * Q16.16: rounding leaves a dead zone at rest: y_f may stop up to ~20 LSB (3e-4) from a
 * constant input for wc = 1 rad/s, ~8 LSB for 5 rad/s, ~2 LSB for 30 rad/s at 90 Hz,
 * with y_f_dot within ~1e-3 of 0. */
struct filt_svf {
	scalar_t a11, a12, a21, a22; /* state transition */
	scalar_t b1, b2;             /* input gain on (u_k + u_(k-1)) */
	scalar_t y, ydot;            /* state: y_f, y_f_dot */
	scalar_t u_prev;
};

/* coefficients for wc, zeta, dt; the state at rest at y0 (y_f = y0, y_f_dot = 0) */
void filt_svf_init(struct filt_svf *f, scalar_t wc_rps, scalar_t zeta, scalar_t dt_s, scalar_t y0);
/* pushes y, updates f->y (y_f) and f->ydot (y_f_dot); returns y_f */
scalar_t filt_svf_update(struct filt_svf *f, scalar_t y);

#endif /* OCTO_FILT_H */
