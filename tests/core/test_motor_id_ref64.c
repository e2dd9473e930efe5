/* test_motor_id_ref64.c - the float64 reference of test_motor_id_ref.c (motor_id_ref64.h): the
 * estimator's own sources, float build, compiled here with float as double (the same
 * algorithm, every float operation and libm call in double precision). No tests of its own. */
#include "motor_id_ref64.h"

#if MID64_HAVE
#undef OCTO_FIXED
#define OCTO_FIXED 0
#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#define float double
#define expf exp
#define logf log
#define sqrtf sqrt
#define powf pow
#define fmaxf fmax
#define fabsf fabs
#define sinf sin
#define cosf cos
#define asinf asin
#define atan2f atan2
#define motor_id_init ref64_motor_id_init
#define motor_id_step ref64_motor_id_step
#define motor_id_process ref64_motor_id_process
#define motor_id_hold ref64_motor_id_hold
#define motor_id_refine ref64_motor_id_refine
#define motor_id_white_pause ref64_motor_id_white_pause
#define motor_id_solve ref64_motor_id_solve
#define motor_id_cause_text ref64_motor_id_cause_text
#define motor_id_cause_remedy ref64_motor_id_cause_remedy

#include "motor_id.c"
#include "motor_id_solve.c"

static struct motor_id M64;

void mid64_init(const struct mid64_cfg *c, const double thr0[8])
{
	struct motor_id_cfg cfg = {.dt_s = c->dt_s,
				   .tau0_s = c->tau0_s,
				   .kf0 = c->kf0,
				   .curve0 = c->curve0,
				   .est_curve = c->est_curve,
				   .n_frames = c->n_frames,
				   .fix_delay = c->fix_delay,
				   .delay_fr = c->delay_fr};
	motor_id_init(&M64, &cfg, thr0);
}

void mid64_step(const double thr_prev[8], const double f[8], const double tq[8], bool excited)
{
	motor_id_step(&M64, thr_prev, f, tq, excited);
}

void mid64_hold(const double thr_prev[8]) { motor_id_hold(&M64, thr_prev); }
void mid64_refine(void) { motor_id_refine(&M64); }
unsigned mid64_size(void) { return (unsigned)sizeof M64; }

void mid64_solve(double ne_max, struct mid64_res *r)
{
	struct motor_id_result x;
	motor_id_process(&M64);
	motor_id_solve(&M64, ne_max, &x);
	r->delay = x.delay;
	r->free_delay = x.free_delay;
	r->n = x.n;
	r->tau = x.tau;
	r->tau_sd = x.tau_sd;
	r->kf = x.kf;
	r->kf_sd = x.kf_sd;
	r->ktau = x.ktau;
	r->curve = x.curve;
	for (int j = 0; j < 8; j++)
		r->scale[j] = x.scale[j];
	r->delay_margin = x.delay_margin;
	r->white_ok = x.white_ok;
	r->white_have = x.white_have;
	r->cause = (int)x.cause;
	r->cause_rotor = x.cause_rotor;
}
#endif
