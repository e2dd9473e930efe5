/* motor_id_ref64.h - the joint rotor-model estimator (firmware/core/motor_id*.c) built in
 * double precision (test_motor_id_ref64.c: the float build's source with float as double),
 * the reference of test_motor_id_ref.c. One instance; plain double interface (no scalar_t). */
#ifndef OCTO_MOTOR_ID_REF64_H
#define OCTO_MOTOR_ID_REF64_H

#include <stdbool.h>
#include <stdint.h>

/* Cortex-M0's test image has no RAM for a second, double, estimator (9 KB) */
#if defined(__ARM_ARCH_6M__)
#define MID64_HAVE 0
#else
#define MID64_HAVE 1
#endif

struct mid64_cfg {
	double dt_s, tau0_s, kf0, curve0;
	bool est_curve, fix_delay;
	uint32_t n_frames, delay_fr;
};

struct mid64_res {
	uint32_t delay, free_delay, n;
	double tau, tau_sd, kf, kf_sd, ktau, curve, scale[8], delay_margin;
	bool white_ok, white_have;
	int cause, cause_rotor;
};

void mid64_init(const struct mid64_cfg *c, const double thr0[8]);
void mid64_step(const double thr_prev[8], const double f[8], const double tq[8], bool excited);
void mid64_hold(const double thr_prev[8]);
void mid64_refine(void);
void mid64_solve(double ne_max, struct mid64_res *r);
/* sizeof the double build's struct motor_id */
unsigned mid64_size(void);

#endif /* OCTO_MOTOR_ID_REF64_H */
