/* log.c - one record of the log table (log.h) from the app's parts. */
#include "log.h"

#include "boundary.h"
#include "env_kf.h"
#include "experiment.h"
#include "guidance.h"
#include "hal.h"
#include "mixer.h"
#include "params.h"

/* Float arrays by assignment, not memcpy: the library call costs more than the copy for
 * these few words on Cortex-M0 (alignment checks, a loop, no inlining). copy4n loads four
 * words before it stores them, which the compiler keeps as a plain copy (a loop of single
 * copies it would turn back into a memcpy call). */
static inline void copy3(float d[3], const float s[3])
{
	d[0] = s[0];
	d[1] = s[1];
	d[2] = s[2];
}

static inline void copy4n(float *restrict d, const float *restrict s, int n)
{
	for (int i = 0; i < n; i += 4) {
		float x0 = s[i], x1 = s[i + 1], x2 = s[i + 2], x3 = s[i + 3];
		d[i] = x0;
		d[i + 1] = x1;
		d[i + 2] = x2;
		d[i + 3] = x3;
	}
}

#define LOG_LEN(field) (sizeof((struct app_log_frame *)0)->field / sizeof(float))
_Static_assert(LOG_LEN(q) == 4 && LOG_LEN(rotor_thrust) == HAL_ROTORS && LOG_LEN(rotor_torque) == HAL_ROTORS &&
		       LOG_LEN(rotor_speed) == HAL_ROTORS && LOG_LEN(throttle) == HAL_ROTORS &&
		       LOG_LEN(est) == EXP_MAX_EST && LOG_LEN(est_sd) == EXP_MAX_EST && HAL_ROTORS % 4 == 0 &&
		       EXP_MAX_EST % 4 == 0,
	       "the log's arrays are copied whole, four floats at a time");

void log_fill(struct app_log_frame *l, const struct log_src *s)
{
	const struct hal_sensor_frame *f = s->fr;
	/* the platform serialises the record field by field, so padding is not cleared */
	l->seq = f->seq;
	l->t = f->t_s;
	l->dt = s->stepped ? s->dt : 0.0f;
	l->stepped = s->stepped;
	l->armed = s->armed;
	l->link_ok = s->link_ok;
	l->mode = s->mode;
	l->valid = (int32_t)f->valid;
	copy4n(l->q, f->q_ib, 4);
	copy3(l->rate_b, f->rate_b_rps);
	copy3(l->pos_i, f->pos_i_m);
	copy3(l->vel_i, f->vel_i_mps);
	copy4n(l->rotor_thrust, f->rotor_thrust_n, HAL_ROTORS);
	copy4n(l->rotor_torque, f->rotor_torque_nm, HAL_ROTORS);
	copy3(l->accel_b, f->accel_b_g);
	copy4n(l->rotor_speed, f->rotor_speed_rps, HAL_ROTORS);
	l->z_sp = bnd_log_sp(s->bnd, 0, s->guid->z_sp_m);
	l->vz_ff = bnd_log_sp(s->bnd, 1, s->guid->vz_ff_mps);
	l->pos_sp[0] = bnd_log_sp(s->bnd, 2, s->guid->pos_sp_m[0]);
	l->pos_sp[1] = bnd_log_sp(s->bnd, 3, s->guid->pos_sp_m[1]);
	l->f_dem = s->wrench_dem[0];
	for (int i = 0; i < 3; i++)
		l->tau_dem[i] = s->wrench_dem[i + 1];
	l->f_alloc = sc_to_float(s->mix_out->achieved[0]);
	for (int i = 0; i < 3; i++)
		l->tau_alloc[i] = sc_to_float(s->mix_out->achieved[i + 1]);
	bnd_excitation_to_float(l->excitation, s->excitation);
	copy4n(l->throttle, s->thr, HAL_ROTORS);
	l->att_flags = (int32_t)s->att_flags;
	l->alt_flags = (int32_t)s->alt_flags;
	l->mix_flags = (int32_t)s->mix_out->limits;
	l->thr_clamped = (int32_t)s->thr_clamped;
	const struct experiment *e = s->exp;
	l->exp_id = (int8_t)(s->experiment ? e->id : 0);
	l->exp_phase = (int8_t)e->phase;
	l->exp_progress = e->progress;
	copy4n(l->est, e->est, EXP_MAX_EST);
	copy4n(l->est_sd, e->est_sd, EXP_MAX_EST);
	l->kf = s->p->veh_kf;
	l->ktau = s->p->veh_ktau;
	l->inertia[0] = s->p->veh_ixx;
	l->inertia[1] = s->p->veh_iyy;
	l->inertia[2] = s->p->veh_izz;
	l->mass = s->p->veh_mass;
	if (!env_kf_estimate(s->kf, f->t_s, &l->kft, &l->kft_sd))
		l->kft = l->kft_sd = 0.0f;
}
