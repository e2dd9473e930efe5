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
	p.env_tau_s = SC(0.1);
	p.gain_tau_s = SC(0.3);
	p.hold_s = SC(2.0);
	p.q_work = SC(0.8);
	p.noise_tau_s = SC(0.5);
	p.confirm = 3;
	p.confirm_max = 30;
	return p;
}

void rotor_fail_init(struct rotor_fail *s, const struct rotor_fail_params *p)
{
	memset(s, 0, sizeof *s);
	s->p = *p;
	if (s->p.confirm < 1)
		s->p.confirm = 1;
	if (s->p.confirm_max < s->p.confirm)
		s->p.confirm_max = s->p.confirm;
	if (!(s->p.share_min > SC_ZERO)) /* a rotor judged has a positive output */
		s->p.share_min = SC(0.01);
	if (!(s->p.g_min > SC_ZERO))
		s->p.g_min = SC(0.001);
	s->rf_speed = sc_sqrt(s->p.ratio_fail);
	s->rf_speed_exc = sc_sqrt(s->p.ratio_fail_excited);
	s->n_lp = -1;
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

static void clear_streaks(struct rotor_fail *s)
{
	if (s->streaking)
		memset(s->streak, 0, sizeof s->streak);
	s->streaking = 0;
}

/* 1 - e^(-dt/tau): the step of a first-order lag (1 without one) */
static scalar_t lag_coef(scalar_t dt, scalar_t tau)
{
	return tau > SC_ZERO ? sc_sub(SC(1.0), sc_exp(sc_neg(sc_div(dt, tau)))) : SC(1.0);
}

/* The frame's modelled outputs: what the model gives (e) and the sums over the rotors in
 * service, counted. */
struct model_frame {
	scalar_t e[NR];
	scalar_t g_sum, e_sum, m_sum;
	int n_in;
};

/* One frame of the lag filter and, with measurements (meas), of the model: each rotor's
 * output through the lag (e) and its lower envelope, which takes the lower of e and the
 * unlagged command's output (g rises with the command: what a motor faster than the model
 * gives too) at once when lower and approaches it at env_al when higher, so that
 * env <= e. g(T) = T (c1 + c T). A rotor out of service has e = env = 0. */
static void model_step(struct rotor_fail *s, const scalar_t *thr, const scalar_t *meas, bool by_thrust, bool env_new,
		       scalar_t al, scalar_t env_al, struct model_frame *f)
{
	const scalar_t c = s->m.curve, c1 = sc_sub(SC(1.0), c);
	const unsigned svc = meas ? (uint8_t)~s->failed : 0u; /* bit j: rotor j modelled */
	scalar_t g_sum = SC_ZERO, e_sum = SC_ZERO, m_sum = SC_ZERO;
	int n_in = 0;
	if (env_new) /* above any output: the first one taken */
		for (int j = 0; j < NR; j++)
			s->env[j] = SC_MAX;
	for (int j = 0; j < NR; j++) {
		const scalar_t t = thr[j], u = sc_add(s->lag[j], sc_mul(al, sc_sub(t, s->lag[j])));
		s->lag[j] = u;
		if (!((svc >> j) & 1u)) {
			f->e[j] = s->env[j] = SC_ZERO;
			continue;
		}
		const scalar_t g = sc_mul(u, sc_add(c1, sc_mul(c, u)));
		const scalar_t gl = t < u ? sc_mul(t, sc_add(c1, sc_mul(c, t))) : g;
		scalar_t e, x;
		if (by_thrust) {
			e = sc_mul(s->m.scale[j], g);
			x = sc_mul(s->m.scale[j], gl);
		} else {
			e = sc_sqrt(g);
			x = gl < g ? sc_sqrt(gl) : e;
		}
		const scalar_t v = s->env[j];
		s->env[j] = x < v ? x : sc_add(v, sc_mul(env_al, sc_sub(x, v)));
		f->e[j] = e;
		g_sum = sc_add(g_sum, g);
		e_sum = sc_add(e_sum, e);
		m_sum = sc_add(m_sum, meas[j]);
		n_in++;
	}
	f->g_sum = g_sum;
	f->e_sum = e_sum;
	f->m_sum = m_sum;
	f->n_in = n_in;
}

/* The measurement noise (header: "Measurement noise"); restart: the frame follows missing
 * ones or a new source (no change is taken). */
static void noise_step(struct rotor_fail *s, const scalar_t *meas, const struct model_frame *f, bool restart)
{
	if (!meas) {
		s->prev_ok = false;
		return;
	}
	if (s->prev_ok && !restart && f->n_in > 0 && s->m_lp > SC_ZERO && s->e_lp > SC_ZERO) {
		scalar_t sum = SC_ZERO;
		for (int j = 0; j < NR; j++)
			if (f->e[j] > SC_ZERO)
				sum = sc_add(sum, sc_abs(sc_sub(sc_mul(sc_sub(meas[j], s->m_prev[j]), s->e_lp),
								sc_mul(s->m_lp, sc_sub(f->e[j], s->e_prev[j])))));
		s->noise = s->noise_ok ? sc_add(s->noise, sc_mul(s->noise_al, sc_sub(sum, s->noise))) : sum;
		s->noise_ok = true;
	}
	for (int j = 0; j < NR; j++) {
		s->m_prev[j] = meas[j];
		s->e_prev[j] = f->e[j];
	}
	s->prev_ok = true;
}

/* The frames in a row a failing rotor needs (header: "Measurement noise"), as a scalar:
 * r = s_q / margin, s_q = sd_me k / E (twice that for the speed), E the low-passed modelled
 * sum. */
static scalar_t streak_need(const struct rotor_fail *s, scalar_t sd_me, scalar_t k, bool by_thrust, scalar_t margin)
{
	const scalar_t n0 = sc_from_int(s->p.confirm);
	if (!(sd_me > SC_ZERO) || !(margin > SC_ZERO))
		return n0;
	scalar_t sq = sc_div(sc_mul(sd_me, k), s->e_lp);
	if (!by_thrust)
		sq = sc_add(sq, sq);
	const scalar_t r = sc_div(sq, margin);
	const scalar_t add = r <= SC(0.25)  ? SC_ZERO
			     : r <= SC(1.0) ? sc_mul(SC(9.3333333), sc_sub(r, SC(0.25)))
					    : sc_add(SC(7.0), sc_mul(SC(3.5), sc_sub(r, SC(1.0))));
	const scalar_t room = sc_from_int((int32_t)s->p.confirm_max - (int32_t)s->p.confirm);
	return sc_add(n0, add < room ? add : room);
}

/* The failing rotors' streaks (the others' end): q_j = (m_j E') / (e_j M'), the sums without
 * the failing rotors; the rotor whose streak reached `confirm` with the lowest mean q, or -1. */
static int streaks_step(struct rotor_fail *s, const scalar_t *meas, bool by_thrust, const struct model_frame *f,
			uint8_t failing, scalar_t lim, scalar_t *q_mean)
{
	/* the noise's sd in units of m_j E: sqrt(pi) / 2 of its mean change, over the rotors */
	const scalar_t sd_me =
		s->noise_ok && f->n_in > 0 ? sc_div(sc_mul(SC(0.88622693), s->noise), sc_from_int(f->n_in)) : SC_ZERO;
	const scalar_t margin = sc_sub(s->p.q_work, lim);
	scalar_t m_o = f->m_sum, e_o = f->e_sum;
	for (int j = 0; j < NR; j++)
		if (failing & (1u << j)) {
			m_o = sc_sub(m_o, meas[j]);
			e_o = sc_sub(e_o, f->e[j]);
		}
	if (!(m_o > SC_ZERO) || !(e_o > SC_ZERO)) {
		clear_streaks(s);
		return -1;
	}
	int worst = -1;
	for (int j = 0; j < NR; j++) {
		const uint8_t bit = (uint8_t)(1u << j);
		if (!(failing & bit)) {
			s->streak[j] = 0;
			continue;
		}
		const scalar_t mj = meas[j] > SC_ZERO ? meas[j] : SC_ZERO;
		/* q_j = m_j k, k = E' / (e_j M'); the noise of m_j E in q: sd_me k / E */
		const scalar_t k = sc_div(e_o, sc_mul(f->e[j], m_o));
		scalar_t q = sc_mul(mj, k);
		if (!by_thrust) /* thrust goes with speed^2 */
			q = sc_mul(q, q);
		s->q_sum[j] = s->streak[j] > 0 ? sc_add(s->q_sum[j], q) : q;
		if (s->streak[j] < UINT8_MAX)
			s->streak[j]++;
		if (sc_from_int(s->streak[j]) >= streak_need(s, sd_me, k, by_thrust, margin)) {
			scalar_t qm = sc_div(s->q_sum[j], sc_from_int(s->streak[j]));
			if (worst < 0 || qm < *q_mean) {
				worst = j;
				*q_mean = qm;
			}
		}
	}
	s->streaking = failing;
	return worst;
}

struct rotor_fail_output rotor_fail_step(struct rotor_fail *s, const struct rotor_fail_input *in)
{
	struct rotor_fail_output out = {-1, SC_ZERO, ROTOR_FAIL_SRC_NONE, false};
	if (s->holding) {
		s->hold_left_s = sc_sub(s->hold_left_s, in->dt_s);
		if (!(s->hold_left_s > SC_ZERO)) {
			s->holding = false;
			out.land = true;
		}
	}
	/* the coefficients, again only when the period or the model's lag changes; no time: the
	 * lag and the envelope hold */
	scalar_t al = SC_ZERO, env_al = SC_ZERO, gain_al = SC_ZERO;
	if (in->dt_s > SC_ZERO) {
		if (in->dt_s != s->c_dt || s->m.tau_lag_s != s->c_tau) {
			s->c_dt = in->dt_s;
			s->c_tau = s->m.tau_lag_s;
			s->lag_al = lag_coef(s->c_dt, s->c_tau);
			s->env_al = lag_coef(s->c_dt, s->p.env_tau_s);
			s->gain_al = lag_coef(s->c_dt, s->p.gain_tau_s);
			s->noise_al = lag_coef(s->c_dt, s->p.noise_tau_s);
		}
		al = s->lag_al;
		env_al = s->env_al;
		gain_al = s->gain_al;
	}
	if (!s->primed) {
		memcpy(s->lag, in->thr, sizeof s->lag);
		s->primed = true;
	}

	/* the lag, the modelled outputs and their envelope, kept whether judged or not (a new
	 * envelope when the source changes: thrusts and speeds are not compared) */
	const bool by_thrust = in->thrust_n != NULL;
	const scalar_t *meas = by_thrust ? in->thrust_n : in->speed_rps;
	const uint8_t src = (uint8_t)(by_thrust ? ROTOR_FAIL_SRC_THRUST
				      : meas    ? ROTOR_FAIL_SRC_SPEED
						: ROTOR_FAIL_SRC_NONE);
	struct model_frame f;
	const bool env_new = s->env_src != src;
	model_step(s, in->thr, meas, by_thrust, env_new, al, env_al, &f);
	s->env_src = src;
	/* the sums' low-pass, started anew with a new source or another set of rotors */
	if (env_new || f.n_in != s->n_lp) {
		s->m_lp = f.m_sum;
		s->e_lp = f.e_sum;
		s->n_lp = (int8_t)f.n_in;
	} else {
		s->m_lp = sc_add(s->m_lp, sc_mul(gain_al, sc_sub(f.m_sum, s->m_lp)));
		s->e_lp = sc_add(s->e_lp, sc_mul(gain_al, sc_sub(f.e_sum, s->e_lp)));
	}
	noise_step(s, meas, &f, env_new || in->gap);
	const scalar_t n_sc = sc_from_int(f.n_in);
	if (!meas || !in->judge || in->gap || f.n_in < MIN_JUDGED || f.g_sum < sc_mul(s->p.g_min, n_sc) ||
	    !(s->m_lp > SC_ZERO) || !(s->e_lp > SC_ZERO)) {
		clear_streaks(s);
		return out;
	}

	/* the rotors judged (envelope at least share_min of the mean: env_j n >= share_min E) and
	 * failing among them: m_j E < lim env_j M, M and E low-passed */
	const scalar_t lim = by_thrust ? (in->excited ? s->p.ratio_fail_excited : s->p.ratio_fail)
				       : (in->excited ? s->rf_speed_exc : s->rf_speed);
	const scalar_t floor_n = sc_mul(s->p.share_min, f.e_sum), lim_m = sc_mul(lim, s->m_lp);
	uint8_t failing = 0;
	int n = 0;
	for (int j = 0; j < NR; j++) {
		if (sc_mul(s->env[j], n_sc) < floor_n) /* judged: env > 0, so e >= env > 0 */
			continue;
		n++;
		if (sc_mul(meas[j], s->e_lp) < sc_mul(lim_m, s->env[j]))
			failing |= (uint8_t)(1u << j);
	}
	if (n < MIN_JUDGED || !failing) {
		clear_streaks(s);
		return out;
	}
	scalar_t worst_q = SC_ZERO;
	const scalar_t lim_q = in->excited ? s->p.ratio_fail_excited : s->p.ratio_fail;
	const int worst = streaks_step(s, meas, by_thrust, &f, failing, lim_q, &worst_q);
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
