/* rotor_fail.c - see rotor_fail.h. */
#include "rotor_fail.h"

#include <string.h>

#define NR ROTOR_FAIL_ROTORS
#define MIN_JUDGED 4

struct rotor_fail_params rotor_fail_params_default(void)
{
	struct rotor_fail_params p;
	p.ratio_fail = SC(0.6);
	p.ratio_fail_excited = SC(0.3);
	p.ratio_zero = SC(0.1);
	p.share_min = SC(0.3);
	p.g_min = SC(0.02);
	p.hold_s = SC(2.0);
	p.confirm = 3;
	return p;
}

void rotor_fail_init(struct rotor_fail *s, const struct rotor_fail_params *p)
{
	memset(s, 0, sizeof *s);
	s->p = *p;
	if (s->p.confirm < 1)
		s->p.confirm = 1;
	for (int j = 0; j < NR; j++)
		s->m.scale[j] = SC(1.0);
}

void rotor_fail_set_model(struct rotor_fail *s, const struct rotor_fail_model *m)
{
	for (int j = 0; j < NR; j++) {
		uint8_t bit = (uint8_t)(1u << j);
		if (!(m->scale[j] > SC_ZERO))
			s->failed |= bit;
		else if ((s->failed & bit) && m->scale[j] != s->m.scale[j])
			s->failed &= (uint8_t)~bit; /* set anew (repaired, or identified again) */
	}
	s->m = *m;
}

/* the median of n values (n <= NR), by insertion sort of a copy */
static scalar_t median(const scalar_t *v, int n)
{
	scalar_t a[NR];
	for (int i = 0; i < n; i++) {
		scalar_t x = v[i];
		int k = i;
		while (k > 0 && a[k - 1] > x) {
			a[k] = a[k - 1];
			k--;
		}
		a[k] = x;
	}
	if (n & 1)
		return a[n / 2];
	return sc_mul(SC(0.5), sc_add(a[n / 2 - 1], a[n / 2]));
}

static void clear_streaks(struct rotor_fail *s)
{
	s->hist_n = 0;
	for (int j = 0; j < NR; j++) {
		s->streak[j] = 0;
		s->q_sum[j] = SC_ZERO;
	}
}

static void lag_step(struct rotor_fail *s, const scalar_t *thr, scalar_t dt)
{
	if (dt != s->c_dt || s->m.tau_lag_s != s->c_tau) {
		s->c_dt = dt;
		s->c_tau = s->m.tau_lag_s;
		s->lag_al = s->c_tau > SC_ZERO ? sc_sub(SC(1.0), sc_exp(sc_neg(sc_div(dt, s->c_tau)))) : SC(1.0);
	}
	for (int j = 0; j < NR; j++) {
		scalar_t t = sc_clamp(thr[j], SC_ZERO, SC(1.0));
		s->lag[j] = s->primed ? sc_add(s->lag[j], sc_mul(s->lag_al, sc_sub(t, s->lag[j]))) : t;
	}
	s->primed = true;
}

/* The frame's lowest modelled outputs into the window; emin gets each rotor's smallest over it. */
static void window_step(struct rotor_fail *s, const scalar_t *e, scalar_t *emin)
{
	for (int j = 0; j < NR; j++)
		s->hist[s->hist_at][j] = e[j];
	s->hist_at = (uint8_t)((s->hist_at + 1u) % ROTOR_FAIL_WINDOW);
	if (s->hist_n < ROTOR_FAIL_WINDOW)
		s->hist_n++;
	for (int j = 0; j < NR; j++) {
		scalar_t m = e[j];
		for (int k = 0; k < s->hist_n; k++)
			if (s->hist[k][j] < m)
				m = s->hist[k][j];
		emin[j] = m;
	}
}

/* Each rotor's modelled output through the lag (e) and the lower of it and the unlagged
 * command's (e_low: g rises with the command, so this is what a motor faster than the model
 * gives as well as a slower one); the sums of g and e over the rotors in service, counted. */
static int model_outputs(const struct rotor_fail *s, const scalar_t *thr, bool by_thrust, scalar_t *e, scalar_t *e_low,
			 scalar_t *g_sum, scalar_t *e_sum)
{
	const scalar_t c = s->m.curve, c1 = sc_sub(SC(1.0), c);
	int n_in = 0;
	for (int j = 0; j < NR; j++) {
		e[j] = e_low[j] = SC_ZERO;
		if ((s->failed & (1u << j)) || !(s->m.scale[j] > SC_ZERO))
			continue;
		scalar_t u = s->lag[j];
		scalar_t g = sc_add(sc_mul(c1, u), sc_mul(c, sc_mul(u, u)));
		if (!(g > SC_ZERO))
			g = SC_ZERO;
		e[j] = by_thrust ? sc_mul(s->m.scale[j], g) : sc_sqrt(g);
		scalar_t ui = sc_clamp(thr[j], SC_ZERO, SC(1.0));
		if (ui < u) {
			scalar_t gi = sc_add(sc_mul(c1, ui), sc_mul(c, sc_mul(ui, ui)));
			gi = gi > SC_ZERO ? gi : SC_ZERO;
			e_low[j] = by_thrust ? sc_mul(s->m.scale[j], gi) : sc_sqrt(gi);
		} else {
			e_low[j] = e[j];
		}
		*g_sum = sc_add(*g_sum, g);
		*e_sum = sc_add(*e_sum, e[j]);
		n_in++;
	}
	return n_in;
}

struct rotor_fail_output rotor_fail_step(struct rotor_fail *s, const struct rotor_fail_input *in)
{
	struct rotor_fail_output out = {-1, SC_ZERO, ROTOR_FAIL_SRC_NONE, false};
	if (in->dt_s > SC_ZERO)
		lag_step(s, in->thr, in->dt_s);
	if (s->holding) {
		s->hold_left_s = sc_sub(s->hold_left_s, in->dt_s);
		if (!(s->hold_left_s > SC_ZERO)) {
			s->holding = false;
			out.land = true;
		}
	}
	const bool by_thrust = in->thrust_n != NULL;
	const scalar_t *meas = by_thrust ? in->thrust_n : in->speed_rps;
	if (!in->judge || !meas || !s->primed) {
		clear_streaks(s);
		return out;
	}

	/* the modelled output of each rotor still in service */
	scalar_t e[NR], e_low[NR], g_sum = SC_ZERO, e_sum = SC_ZERO;
	const int n_in = model_outputs(s, in->thr, by_thrust, e, e_low, &g_sum, &e_sum);
	if (n_in < MIN_JUDGED) {
		clear_streaks(s);
		return out;
	}
	const scalar_t n_sc = sc_from_int(n_in);
	const scalar_t e_floor = sc_div(sc_mul(s->p.share_min, e_sum), n_sc);
	if (g_sum < sc_mul(s->p.g_min, n_sc)) {
		clear_streaks(s);
		return out;
	}

	scalar_t emin[NR];
	window_step(s, e_low, emin);

	/* the plain ratios and their median (k_f, or the speed at full throttle: the same for every
	 * rotor, and the centre of the ratios however the excitation moves them) */
	scalar_t r[NR], rj[NR];
	bool judged[NR];
	int n = 0;
	for (int j = 0; j < NR; j++) {
		judged[j] = e[j] > SC_ZERO && !(emin[j] < e_floor);
		r[j] = judged[j] ? sc_div(meas[j] > SC_ZERO ? meas[j] : SC_ZERO, e[j]) : SC_ZERO;
		if (judged[j])
			rj[n++] = r[j];
	}
	const scalar_t med = n >= MIN_JUDGED ? median(rj, n) : SC_ZERO;
	if (!(med > SC_ZERO)) {
		clear_streaks(s);
		return out;
	}
	/* the decision: measured against the window's smallest modelled output, scaled by the
	 * median (with the speeds, q_j is the ratio squared: below ratio_fail when the ratio is
	 * below its root) */
	const scalar_t fail = in->excited ? s->p.ratio_fail_excited : s->p.ratio_fail;
	const scalar_t lim = sc_mul(by_thrust ? fail : sc_sqrt(fail), med);
	bool failing[NR];
	for (int j = 0; j < NR; j++)
		failing[j] = judged[j] && meas[j] < sc_mul(lim, emin[j]);

	int worst = -1;
	scalar_t worst_q = SC_ZERO;
	for (int j = 0; j < NR; j++) {
		if (!failing[j]) {
			s->streak[j] = 0;
			s->q_sum[j] = SC_ZERO;
			continue;
		}
		scalar_t q = sc_div(r[j], med);
		if (!by_thrust) /* thrust goes with speed^2 */
			q = sc_mul(q, q);
		if (s->streak[j] < UINT8_MAX)
			s->streak[j]++;
		s->q_sum[j] = sc_add(s->q_sum[j], q);
		if (s->streak[j] >= s->p.confirm) {
			scalar_t qm = sc_div(s->q_sum[j], sc_from_int(s->streak[j]));
			if (worst < 0 || qm < worst_q) {
				worst = j;
				worst_q = qm;
			}
		}
	}
	if (worst < 0)
		return out;

	scalar_t sc_new = sc_mul(s->m.scale[worst], sc_clamp(worst_q, SC_ZERO, SC(1.0)));
	if (sc_new < s->p.ratio_zero)
		sc_new = SC_ZERO;
	s->m.scale[worst] = sc_new;
	s->failed |= (uint8_t)(1u << worst);
	clear_streaks(s);
	s->holding = true;
	s->hold_left_s = s->p.hold_s;
	out.rotor = worst;
	out.scale = sc_new;
	out.source = by_thrust ? ROTOR_FAIL_SRC_THRUST : ROTOR_FAIL_SRC_SPEED;
	return out;
}
