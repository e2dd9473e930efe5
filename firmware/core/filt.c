/* filt.c - see filt.h. */
#include "filt.h"

/* ---------------------------------------------------------------- first-order lag */
void filt_lag_init(struct filt_lag *f, scalar_t tau_s, scalar_t dt_s, scalar_t y0)
{
	if (tau_s <= SC_ZERO || dt_s <= SC_ZERO)
		f->alpha = tau_s <= SC_ZERO ? SC(1) : SC_ZERO;
	else
		f->alpha = sc_clamp(sc_sub(SC(1), sc_exp(sc_neg(sc_div(dt_s, tau_s)))), SC_ZERO, SC(1));
	f->y = y0;
}

scalar_t filt_lag_update(struct filt_lag *f, scalar_t x)
{
	if (!sc_isfinite(x))
		return f->y;
	/* sums inline (sca_*): several filters run in every step of the experiments */
	f->y = sca_add(f->y, sc_mul(f->alpha, sca_sub(x, f->y)));
	return f->y;
}

/* ---------------------------------------------------------------- delay line */
void filt_delay_init(struct filt_delay *d, uint32_t n_samples, scalar_t y0)
{
	d->n = n_samples > FILT_DELAY_MAX ? FILT_DELAY_MAX : n_samples;
	d->head = 0;
	for (uint32_t i = 0; i < FILT_DELAY_MAX; i++)
		d->buf[i] = y0;
}

scalar_t filt_delay_update(struct filt_delay *d, scalar_t x)
{
	if (d->n == 0)
		return x;
	/* buf[(head - k) mod MAX] holds x_(-k) for k = 1..MAX; read before overwriting */
	uint32_t n = d->n > FILT_DELAY_MAX ? FILT_DELAY_MAX : d->n;
	uint32_t head = d->head % FILT_DELAY_MAX;
	scalar_t y = d->buf[(head + FILT_DELAY_MAX - n) % FILT_DELAY_MAX];
	d->buf[head] = x;
	d->head = (head + 1u) % FILT_DELAY_MAX;
	return y;
}

/* ---------------------------------------------------------------- state-variable filter
 * x' = A x + B u, A = [0 1; -w^2 -2 zeta w], B = [0; w^2]; trapezoidal rule with
 * h = dt/2: (I - hA) x_k = (I + hA) x_(k-1) + hB (u_k + u_(k-1)). With
 * det = 1 + 2 zeta w h + (w h)^2:
 *   a11 = 1 - 2 b1, a12 = 2h / det, a21 = -2 b2, a22 = (1 - 2 zeta w h - (w h)^2) / det,
 *   b1 = (w h)^2 / det, b2 = h w^2 / det.
 * a11 and a21 are derived from the rounded b1 and b2 so that the DC gain is exactly 1
 * in both builds. */
void filt_svf_init(struct filt_svf *f, scalar_t wc_rps, scalar_t zeta, scalar_t dt_s, scalar_t y0)
{
	scalar_t dt = sc_max(dt_s, SC(1e-4));
	scalar_t w = sc_clamp(wc_rps, sc_div(SC(1e-3), dt), sc_div(SC(2), dt));
	scalar_t z = sc_max(zeta, SC(0.05));
	scalar_t h = sc_mul(dt, SC(0.5));
	scalar_t wh = sc_mul(w, h);
	scalar_t wh2 = sc_mul(wh, wh);
	scalar_t zwh2 = sc_mul(sc_add(z, z), wh);
	scalar_t det = sc_add(sc_add(SC(1), zwh2), wh2);
	f->b1 = sc_div(wh2, det);
	f->b2 = sc_div(sc_mul(wh, w), det);
	f->a11 = sc_sub(SC(1), sc_add(f->b1, f->b1));
	f->a12 = sc_div(sc_add(h, h), det);
	f->a21 = sc_neg(sc_add(f->b2, f->b2));
	f->a22 = sc_div(sc_sub(sc_sub(SC(1), zwh2), wh2), det);
	f->y = y0;
	f->ydot = SC_ZERO;
	f->u_prev = y0;
}

scalar_t filt_svf_update(struct filt_svf *f, scalar_t y)
{
	if (!sc_isfinite(y))
		return f->y;
	/* increment form: x1 += a12 x2 + b1 (u_k + u_(k-1) - 2 x1), and
	 * x2 += (a22 - 1) x2 + b2 (u_k + u_(k-1) - 2 x1); equal to the matrix form with
	 * a11 = 1 - 2 b1, a21 = -2 b2, but the rounding vanishes at rest (exact DC in Q16.16).
	 * Sums inline (sca_*): several filters run in every step of the experiments */
	scalar_t err = sca_sub(sca_add(y, f->u_prev), sca_add(f->y, f->y));
	scalar_t y1 = sca_add(f->y, sca_add(sc_mul(f->a12, f->ydot), sc_mul(f->b1, err)));
	scalar_t y2 = sca_add(f->ydot, sca_add(sc_mul(sca_sub(f->a22, SC(1)), f->ydot), sc_mul(f->b2, err)));
	f->y = y1;
	f->ydot = y2;
	f->u_prev = y;
	return y1;
}
