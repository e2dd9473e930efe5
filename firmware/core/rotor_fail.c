/* rotor_fail.c - see rotor_fail.h. */
#include "rotor_fail.h"

#include <string.h>

#define NR ROTOR_FAIL_ROTORS
#define MIN_JUDGED 4

struct rotor_fail_params rotor_fail_params_default(void)
{
	struct rotor_fail_params p;
	p.ratio_fail = SC(0.6);
	p.ratio_zero = SC(0.1);
	p.share_min = SC(0.3);
	p.g_min = SC(0.02);
	p.hold_s = SC(2.0);
	p.tau_avg_s = SC(0.2);
	p.confirm = 14;   /* 0.16 s at 90 Hz: longer than the lag and delay of any motor the experiments meet */
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
			s->failed &= (uint8_t)~bit;   /* set anew (repaired, or identified again) */
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
	s->avg_primed = false;
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

/* Measured and modelled outputs, low-passed alike (tau_avg): the decision's inputs. */
static void avg_step(struct rotor_fail *s, const scalar_t *meas, const scalar_t *e, scalar_t dt)
{
	if (dt != s->c_avg_dt) {
		s->c_avg_dt = dt;
		s->avg_al = s->p.tau_avg_s > SC_ZERO ? sc_sub(SC(1.0), sc_exp(sc_neg(sc_div(dt, s->p.tau_avg_s))))
						     : SC(1.0);
	}
	for (int j = 0; j < NR; j++) {
		scalar_t mj = meas[j] > SC_ZERO ? meas[j] : SC_ZERO;
		s->mf[j] = s->avg_primed ? sc_add(s->mf[j], sc_mul(s->avg_al, sc_sub(mj, s->mf[j]))) : mj;
		s->ef[j] = s->avg_primed ? sc_add(s->ef[j], sc_mul(s->avg_al, sc_sub(e[j], s->ef[j]))) : e[j];
	}
	s->avg_primed = true;
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
	const scalar_t c = s->m.curve, c1 = sc_sub(SC(1.0), c);
	scalar_t e[NR], g_sum = SC_ZERO, e_sum = SC_ZERO;
	int n_in = 0;
	for (int j = 0; j < NR; j++) {
		e[j] = SC_ZERO;
		if ((s->failed & (1u << j)) || !(s->m.scale[j] > SC_ZERO))
			continue;
		scalar_t u = s->lag[j];
		scalar_t g = sc_add(sc_mul(c1, u), sc_mul(c, sc_mul(u, u)));
		if (!(g > SC_ZERO))
			g = SC_ZERO;
		e[j] = by_thrust ? sc_mul(s->m.scale[j], g) : sc_sqrt(g);
		g_sum = sc_add(g_sum, g);
		e_sum = sc_add(e_sum, e[j]);
		n_in++;
	}
	if (n_in < MIN_JUDGED) {
		clear_streaks(s);
		return out;
	}
	const scalar_t n_sc = sc_from_int(n_in);
	const scalar_t e_floor = sc_mul(s->p.share_min, sc_div(e_sum, n_sc));
	if (sc_div(g_sum, n_sc) < s->p.g_min) {
		clear_streaks(s);
		return out;
	}

	avg_step(s, meas, e, in->dt_s);

	/* measured over modelled, for the rotors judged: raw (the effectiveness found) and
	 * smoothed (the decision) */
	scalar_t r[NR], rs[NR], rj[NR], rsj[NR];
	bool judged[NR];
	int n = 0;
	for (int j = 0; j < NR; j++) {
		judged[j] = e[j] > SC_ZERO && !(e[j] < e_floor) && s->ef[j] > SC_ZERO;
		r[j] = judged[j] ? sc_div(meas[j] > SC_ZERO ? meas[j] : SC_ZERO, e[j]) : SC_ZERO;
		rs[j] = judged[j] ? sc_div(s->mf[j], s->ef[j]) : SC_ZERO;
		if (judged[j]) {
			rj[n] = r[j];
			rsj[n++] = rs[j];
		}
	}
	scalar_t med = n >= MIN_JUDGED ? median(rj, n) : SC_ZERO;
	scalar_t meds = n >= MIN_JUDGED ? median(rsj, n) : SC_ZERO;
	if (!(med > SC_ZERO) || !(meds > SC_ZERO)) {
		clear_streaks(s);
		return out;
	}

	int worst = -1;
	scalar_t worst_q = SC_ZERO;
	for (int j = 0; j < NR; j++) {
		if (!judged[j]) {
			s->streak[j] = 0;
			s->q_sum[j] = SC_ZERO;
			continue;
		}
		scalar_t q = sc_div(r[j], med), qs = sc_div(rs[j], meds);
		if (!by_thrust) {   /* thrust goes with speed^2 */
			q = sc_mul(q, q);
			qs = sc_mul(qs, qs);
		}
		if (qs < s->p.ratio_fail) {
			if (s->streak[j] < UINT8_MAX)
				s->streak[j]++;
			s->q_sum[j] = sc_add(s->q_sum[j], q);
		} else {
			s->streak[j] = 0;
			s->q_sum[j] = SC_ZERO;
		}
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
