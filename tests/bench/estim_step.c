/*
 * estim_step.c - instructions of the identification's estimators alone on Cortex-M, for
 * `make bench` (tests/bench/bench.py): where the fixed build's experiment step goes.
 * Counted calls (one bench_mark_begin/end pair each, in this order):
 *   N_RLS x rls_update of the rotor experiment's RLS (1 parameter, outputs f and tau),
 *   N_RLS x rls_update of its lag check (2 parameters, 1 output),
 *   N_ROT x ident_rotor_update + ident_rotor_process (delay, lag and the three RLS of one
 *           rotor: the step's part and its RLS updates between frames),
 *   N_INR x ident_inertia_update + ident_inertia_process with its instrument (the SVFs, the
 *           IV sums; the RLS between frames),
 *   N_MID x motor_id_step + motor_id_process (the joint rotor-model estimator's frame: every
 *           rotor, 15 hypotheses; its refinements between frames are not counted),
 *   1 x motor_id_solve (between frames, at the end),
 *   N_IMU x imu_id_step + imu_id_process (the collective model from the accelerometer: the
 *           step stores the frame, the bank of delay and lag hypotheses takes it between
 *           frames; the grid's refinement, once, at IMU_ID_FREEZE of the planned frames, then
 *           the clusters' sums each frame),
 *   1 x imu_id_solve (between frames, at the end),
 *   N_IMU x the same frames with the ESCs' torques read (imu_id_cfg.torque).
 * The inputs are a PRBS throttle through a 40 ms lag with 1 % noise (the values do not
 * change the count much: no data-dependent loops but the fixed build's normalisation).
 * Prints "estim: KEY VALUE" lines.
 */
#include <stdio.h>

#include "bench_mark.h"
#include "excite.h"
#include "ident.h"
#include "imu_id.h"
#include "motor_id.h"
#include "rls.h"

#define N_RLS 200
#define N_ROT 200
#define N_MID 200
#define N_INR 200
#define N_IMU 400

static uint32_t rng = 777u;
static float urand(void) /* [-1, 1) */
{
	rng ^= rng << 13;
	rng ^= rng >> 17;
	rng ^= rng << 5;
	return (float)(rng >> 8) * (2.0f / 16777216.0f) - 1.0f;
}

/* global: the compiler cannot see through it across the markers */
struct rls R1, R2;
struct ident_rotor ROT;
struct motor_id MID;
struct motor_id_result MRES;
struct ident_inertia INR;
struct imu_id IMU;
struct imu_id_result IRES;

/* N_IMU counted frames of imu_id (after 90 still ones) on the 8 rotors' collective model:
 * hovering at 0.45 through a 40 ms lag and one frame's delay, the force m a_z with 1 % noise
 * (and with tq the reaction torques' sum, k_tau / k_f = 0.014 of it), a collective square
 * wave of 1 s and the two null-space dithers */
static void imu_run(const struct imu_id_cfg *ic, const scalar_t thr0[IMU_ID_ROTORS], float cmd[IMU_ID_ROTORS],
		    float sj[IMU_ID_ROTORS], bool tq)
{
	float sd[IMU_ID_ROTORS], dc = 0.0f, d1 = 0.0f, d2 = 0.0f;
	for (int j = 0; j < IMU_ID_ROTORS; j++)
		sd[j] = 0.45f;
	imu_id_init(&IMU, ic, thr0);
	for (int k = 0; k < 90 + N_IMU; k++) {
		bool exc = k >= 90;
		if (exc && k % 9 == 0) {
			d1 = urand() < 0.0f ? -0.04f : 0.04f;
			d2 = urand() < 0.0f ? -0.04f : 0.04f;
		}
		if (exc && k % 45 == 0)
			dc = dc > 0.0f ? -0.05f : 0.05f;
		scalar_t tp[IMU_ID_ROTORS];
		float fz = 0.0f;
		for (int j = 0; j < IMU_ID_ROTORS; j++) {
			tp[j] = sc_from_float(cmd[j]);
			fz += 28.0f * sj[j];
			sj[j] += 0.24f * (sd[j] - sj[j]);
			sd[j] = cmd[j]; /* one frame's delay */
			cmd[j] = exc ? 0.45f + dc + d1 * ic->pat[0][j] + d2 * ic->pat[1][j] : 0.45f;
		}
		fz *= 1.0f + 0.01f * urand();
		float t = tq ? 0.014f * fz * (1.0f + 0.01f * urand()) : 0.0f;
		if (exc)
			bench_mark_begin();
		imu_id_step(&IMU, tp, sc_from_float(fz), sc_from_float(fz), 0, sc_from_float(t), exc);
		imu_id_process(&IMU);
		if (exc)
			bench_mark_end();
	}
}

int main(void)
{
	struct rls_config c;
	rls_default_config(&c);
	c.n_outputs = 2;
	c.p0 = 1e6f;
	c.theta0[0][0] = 25.0f;
	c.theta0[1][0] = 0.35f;
	rls_init(&R1, &c);
	c.n_params = 2;
	c.n_outputs = 1;
	c.theta0[0][1] = 0.0f;
	rls_init(&R2, &c);
	float s = 0.45f, thr = 0.45f;
	for (int k = 0; k < N_RLS; k++) {
		if (k % 9 == 0)
			thr = 0.45f + (urand() < 0.0f ? -0.06f : 0.06f);
		s += 0.24f * (thr - s);
		scalar_t phi[2] = {sc_from_float(s), sc_from_float(0.1f * (thr - s))};
		scalar_t y[2] = {sc_from_float(28.0f * s * (1.0f + 0.01f * urand())),
				 sc_from_float(0.39f * s * (1.0f + 0.01f * urand()))};
		bench_mark_begin();
		rls_update(&R1, phi, y, true);
		bench_mark_end();
	}
	for (int k = 0; k < N_RLS; k++) {
		if (k % 9 == 0)
			thr = 0.45f + (urand() < 0.0f ? -0.06f : 0.06f);
		s += 0.24f * (thr - s);
		scalar_t phi[2] = {sc_from_float(s), sc_from_float(0.1f * (thr - s))};
		scalar_t y = sc_from_float(28.0f * s * (1.0f + 0.01f * urand()));
		bench_mark_begin();
		rls_update(&R2, phi, &y, true);
		bench_mark_end();
	}
	struct ident_rotor_cfg rc = {0};
	rc.dt_s = SC(1.0 / 90.0);
	rc.mot_tau_s = SC(0.04);
	rc.delay_frames = 1;
	rc.curve = SC(0.3);
	rc.thr0 = SC(0.45);
	rc.kf0 = 25.0f;
	rc.ktau0 = 0.35f;
	ident_rotor_init(&ROT, &rc);
	for (int k = 0; k < N_ROT; k++) {
		if (k % 9 == 0)
			thr = 0.45f + (urand() < 0.0f ? -0.06f : 0.06f);
		s += 0.24f * (thr - s);
		scalar_t f = sc_from_float(28.0f * s * (1.0f + 0.01f * urand()));
		scalar_t t = sc_from_float(0.39f * s * (1.0f + 0.01f * urand()));
		bench_mark_begin();
		ident_rotor_update(&ROT, sc_from_float(thr), f, t, true);
		ident_rotor_process(&ROT);
		bench_mark_end();
	}
	/* inertia about x: a PRBS torque on a 0.06 kg m^2 body with a rate damper, 1 % noise */
	scalar_t in3[3] = {SC(0.06), SC(0.07), SC(0.1)}, zero[3] = {0, 0, 0};
	ident_inertia_init(&INR, 0, SC(25.0), SC(0.7), SC(1.0 / 90.0), SC(0.53), in3, zero, zero);
	float w = 0.0f, u = 0.0f;
	for (int k = 0; k < N_INR; k++) {
		if (k % 9 == 0)
			u = urand() < 0.0f ? -0.3f : 0.3f;
		float tq = u - 0.24f * w;
		w += tq / 0.06f / 90.0f;
		scalar_t tb[3] = {sc_from_float(tq * (1.0f + 0.01f * urand())), 0, 0};
		scalar_t wb[3] = {sc_from_float(w + 0.005f * urand()), sc_from_float(0.01f * urand()),
				  sc_from_float(0.01f * urand())};
		bench_mark_begin();
		ident_inertia_instrument(&INR, sc_from_float(u));
		ident_inertia_update(&INR, tb, wb, true);
		ident_inertia_process(&INR);
		bench_mark_end();
	}
	/* the motor model: 8 rotors dithered on the null-space patterns through a 40 ms lag,
	 * 1 s still first (not counted) */
	struct motor_id_cfg mc = {.dt_s = SC(1.0 / 90.0),
				  .tau0_s = 0.03f,
				  .kf0 = 25.0f,
				  .curve0 = 0.0f,
				  .est_curve = true,
				  .n_frames = N_MID};
	scalar_t thr0[MOTOR_ID_ROTORS];
	float sj[MOTOR_ID_ROTORS], cmd[MOTOR_ID_ROTORS];
	for (int j = 0; j < MOTOR_ID_ROTORS; j++) {
		thr0[j] = SC(0.45);
		sj[j] = cmd[j] = 0.45f;
	}
	motor_id_init(&MID, &mc, thr0);
	static const float p1[8] = {1, 0, -1, 0, 1, 0, -1, 0}, p2[8] = {0, 1, 0, -1, 0, 1, 0, -1};
	float d1 = 0.0f, d2 = 0.0f;
	for (int k = 0; k < 90 + N_MID; k++) {
		bool exc = k >= 90;
		if (exc && k % 9 == 0) {
			d1 = urand() < 0.0f ? -0.04f : 0.04f;
			d2 = urand() < 0.0f ? -0.04f : 0.04f;
		}
		scalar_t tp[MOTOR_ID_ROTORS], f[MOTOR_ID_ROTORS], t[MOTOR_ID_ROTORS];
		for (int j = 0; j < MOTOR_ID_ROTORS; j++) {
			tp[j] = sc_from_float(cmd[j]);
			f[j] = sc_from_float(28.0f * sj[j] * (1.0f + 0.01f * urand()));
			t[j] = sc_from_float(0.39f * sj[j] * (1.0f + 0.01f * urand()));
			sj[j] += 0.24f * (cmd[j] - sj[j]);
			cmd[j] = exc ? 0.45f + d1 * p1[j] + d2 * p2[j] : 0.45f;
		}
		if (exc)
			bench_mark_begin();
		motor_id_step(&MID, tp, f, t, exc);
		motor_id_process(&MID);
		if (exc)
			bench_mark_end();
		motor_id_refine(&MID);
	}
	bench_mark_begin();
	motor_id_solve(&MID, 1.3f, &MRES);
	bench_mark_end();
	/* the IMU's collective model: 8 rotors hovering at 0.45 through a 40 ms lag and one
	 * frame's delay, the force m a_z with 1 % noise, a collective square wave of 1 s and the
	 * two null-space dithers; 1 s still first (not counted); the planned frames put the
	 * refinement at about a tenth of the counted ones */
	struct imu_id_cfg ic = {.dt_s = 1.0f / 90.0f,
				.mass_kg = 10.27f, /* 28 N x 8 x 0.45 / g */
				.g = 9.81f,
				.kf0 = 25.0f,
				.curve0 = 0.0f,
				.est_curve = true,
				.n_frames = N_IMU / 2,
				.block_frames = 90};
	for (int j = 0; j < IMU_ID_ROTORS; j++) {
		scalar_t pp[2][EXCITE_ROTORS];
		excite_null_pattern(0, pp[0]);
		excite_null_pattern(1, pp[1]);
		ic.scale[j] = 1.0f;
		ic.pat[0][j] = sc_to_float(pp[0][j]);
		ic.pat[1][j] = sc_to_float(pp[1][j]);
		thr0[j] = SC(0.45);
		sj[j] = cmd[j] = 0.45f;
	}
	imu_run(&ic, thr0, cmd, sj, false);
	bench_mark_begin();
	imu_id_solve(&IMU, 3.0f, &IRES);
	bench_mark_end();
	/* the same with the ESCs' torques read (k_tau beside k_f: the torque's sums too) */
	ic.torque = true;
	for (int j = 0; j < IMU_ID_ROTORS; j++)
		sj[j] = cmd[j] = 0.45f;
	imu_run(&ic, thr0, cmd, sj, true);
	printf("estim: rls_1x2 %d\n", N_RLS);
	printf("estim: rls_2x1 %d\n", N_RLS);
	printf("estim: ident_rotor %d\n", N_ROT);
	printf("estim: ident_inertia %d\n", N_INR);
	printf("estim: motor_id %d\n", N_MID);
	printf("estim: motor_id_solve 1\n");
	printf("estim: motor_id_kf %.4f\n", (double)MRES.kf);
	printf("estim: imu_id %d\n", N_IMU);
	printf("estim: imu_id_solve 1\n");
	printf("estim: imu_id_kf %.4f cause %d\n", (double)IRES.kf, (int)IRES.cause);
	printf("estim: imu_id_tq %d\n", N_IMU);
	printf("estim: kf %.4f\n", (double)rls_estimate_f(&R1, 0, 0));
	printf("estim: done\n");
	return 0;
}
