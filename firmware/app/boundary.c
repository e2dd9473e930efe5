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
