/* boundary.c - see boundary.h. */
#include "boundary.h"

void bnd_frame_in(struct boundary *b, const struct hal_sensor_frame *f)
{
#if OCTO_FIXED
	struct bnd_frame *s = &b->fs;
	for (int i = 0; i < 4; i++)
		s->q_ib[i] = sc_from_float(f->q_ib[i]);
	for (int i = 0; i < 3; i++) {
		s->rate_b_rps[i] = sc_from_float(f->rate_b_rps[i]);
		s->pos_i_m[i] = sc_from_float(f->pos_i_m[i]);
		s->vel_i_mps[i] = sc_from_float(f->vel_i_mps[i]);
	}
	for (int j = 0; j < HAL_ROTORS; j++)
		s->rotor_thrust_n[j] = sc_from_float(f->rotor_thrust_n[j]);
#else
	(void)b;
	(void)f;
#endif
}

void bnd_torque_in(struct boundary *b, const struct hal_sensor_frame *f)
{
#if OCTO_FIXED
	for (int j = 0; j < HAL_ROTORS; j++)
		b->fs.rotor_torque_nm[j] = sc_from_float(f->rotor_torque_nm[j]);
#else
	(void)b;
	(void)f;
#endif
}

/* A dither gives the rotors a few values and their negations (the rotor experiment: two
 * magnitudes per step), and a Q16.16 value and its negation convert to floats of opposite
 * sign: each magnitude is converted once (the last two kept). */
void bnd_excitation_to_float(float out[HAL_ROTORS], const scalar_t d[HAL_ROTORS])
{
#if OCTO_FIXED
	uint32_t m0 = 0u, m1 = 0u;
	float f0 = 0.0f, f1 = 0.0f;
	for (int j = 0; j < HAL_ROTORS; j++) {
		scalar_t v = d[j];
		uint32_t m = v < 0 ? 0u - (uint32_t)v : (uint32_t)v;
		float f;
		if (m == m0) {
			f = f0;
		} else if (m == m1) {
			f = f1;
		} else if (m > (uint32_t)INT32_MAX) {   /* INT32_MIN: no positive twin */
			out[j] = sc_to_float(v);
			continue;
		} else {
			f = sc_to_float((scalar_t)m);
			m1 = m0;
			f1 = f0;
			m0 = m;
			f0 = f;
		}
		out[j] = v < 0 ? -f : f;
	}
#else
	for (int j = 0; j < HAL_ROTORS; j++)
		out[j] = d[j];
#endif
}
