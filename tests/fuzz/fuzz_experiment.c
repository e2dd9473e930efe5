/*
 * fuzz_experiment.c - libFuzzer harness of the identification experiments themselves:
 * exp_start -> exp_step every frame (the estimators of firmware/core/ident.h and
 * motor_id.h on the frame's measured thrusts, torques and rates) -> exp_turn and the
 * results applied between frames -> exp_pump, as the app runs them in APP_EXPERIMENT,
 * without having to fly there through MAVLink first. Built twice: float and fixed point
 * (OCTO_FIXED=1, the core in integer Q formats).
 *
 * Input:
 *   byte 0       the experiment: 1 + byte % 6 (1 rotor, 2 validation, 3-5 inertia, 6 all)
 *   byte 1       m: the low 3 bits are the number of parameter records that follow
 *   m records    [n][n bytes: a parameter's name][float32 LE]: params_set (an unknown name
 *                or a refused value changes nothing)
 *   then records [kind][len][len bytes]
 *     kind % 4 = 0..2: one frame; the bytes overwrite the hovering vehicle's frame from
 *                      its rates on (the floats of struct hal_sensor_frame)
 *     kind % 4 = 3:    (kind / 4 + 1) x 64 frames of the simple plant below, the bytes'
 *                      first one scaling its thrust (a vehicle heavier or lighter than
 *                      modelled)
 * The simple plant: every rotor's measured thrust and reaction torque follow the
 * throttle sent on the previous frame (k_f, k_tau the nominal values times a scale),
 * rates zero. Checks: every output of exp_step is finite, and so is every result.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "experiment.h"
#include "params.h"

#define MAX_FRAMES 12000 /* about 130 s of flight: the sequence's first phases */

static struct experiment ex;
static struct app_params prm;
static struct hal_sensor_frame fr;
static scalar_t thr[HAL_ROTORS], rotor_f[HAL_ROTORS]; /* scalars, as the app keeps them */
static float wrench[4];
static long frames;

static void check_finite(const scalar_t *v, size_t n)
{
	for (size_t i = 0; i < n; i++)
		if (!isfinite(sc_to_float(v[i])))
			abort();
}

/* one exp_step as the app runs it (step.c); false when the experiment has ended */
static bool step(void)
{
	exp_turn(&ex, &prm);
	for (int i = 0; i < ex.n_results; i++) {
		if (!isfinite(ex.results[i].value))
			abort();
		if (ex.results[i].param_index >= 0)
			params_set(&prm, (size_t)ex.results[i].param_index, ex.results[i].value);
	}
	ex.n_results = 0;
	fr.seq++;
	fr.t_s += 1.0 / 90.0;
	/* the frame's measurements as scalars, as the app converts them once per frame */
	scalar_t f[HAL_ROTORS], tq[HAL_ROTORS], w[3];
	for (int j = 0; j < HAL_ROTORS; j++) {
		f[j] = sc_from_float(fr.rotor_thrust_n[j]);
		tq[j] = sc_from_float(fr.rotor_torque_nm[j]);
	}
	for (int i = 0; i < 3; i++)
		w[i] = sc_from_float(fr.rate_b_rps[i]);
	struct exp_input in = {&fr, f, tq, w, 1.0f / 90.0f, &prm, wrench, rotor_f, thr, 1.0f / 90.0f};
	struct exp_output out;
	memset(&out, 0, sizeof out);
	enum exp_state st = exp_step(&ex, &in, &out);
	check_finite(&out.f_delta, 1);
	check_finite(out.tau_delta, 3);
	check_finite(out.thr_delta, HAL_ROTORS);
	for (int j = 0; j < HAL_ROTORS; j++)
		thr[j] = sc_add(SC(0.5), out.thr_delta[j]);
	exp_pump(&ex);
	if (strnlen(ex.msg, sizeof ex.msg) >= sizeof ex.msg) /* a status line is NUL-terminated */
		abort();
	ex.msg[0] = 0; /* sent, as the app's tick sends it */
	frames++;
	return st == EXP_RUNNING && frames < MAX_FRAMES;
}

/* the simple plant's frame: thrusts and torques of the throttles sent on the previous frame */
static void plant_frame(float scale)
{
	for (int j = 0; j < HAL_ROTORS; j++) {
		float t = sc_to_float(thr[j]);
		fr.rotor_thrust_n[j] = scale * prm.veh_kf * t;
		fr.rotor_torque_nm[j] = scale * prm.veh_ktau * t;
		fr.thr_cmd_echo[j] = t;
	}
	memset(fr.rate_b_rps, 0, sizeof fr.rate_b_rps);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (size < 2)
		return 0;
	params_defaults(&prm);
	memset(&ex, 0, sizeof ex);
	memset(&fr, 0, sizeof fr);
	fr.valid = HAL_FRAME_NEEDED | HAL_FRAME_THRUST | HAL_FRAME_TORQUE;
	fr.q_ib[0] = 1.0f;
	fr.pos_i_m[2] = 10.0f;
	for (int j = 0; j < HAL_ROTORS; j++) {
		thr[j] = SC(0.5);
		rotor_f[j] = sc_from_float(prm.veh_mass * 9.81f / HAL_ROTORS);
	}
	wrench[0] = prm.veh_mass * 9.81f;
	wrench[1] = wrench[2] = wrench[3] = 0.0f;
	frames = 0;
	int id = 1 + data[0] % 6;
	size_t pos = 2;
	for (unsigned m = data[1] & 7u; m > 0 && pos < size && pos + 1u + data[pos] + 4u <= size; m--) {
		size_t n = data[pos];
		int idx = params_find((const char *)data + pos + 1, n < 16 ? n : 16);
		float v;
		memcpy(&v, data + pos + 1 + n, sizeof v);
		if (idx >= 0)
			params_set(&prm, (size_t)idx, v);
		pos += 1 + n + 4;
	}
	char why[96];
	/* the source: bit 3 of the second byte (the IMU source reads the accelerometer) */
	enum exp_source src = (data[1] & 8u) ? EXP_SRC_IMU : EXP_SRC_THRUST;
	if (exp_start(&ex, id, &prm, src, why, sizeof why) != 0)
		return 0;
	plant_frame(1.0f);
	bool running = true;
	while (running && pos + 2 <= size) {
		uint8_t kind = data[pos], n = data[pos + 1];
		pos += 2;
		size_t len = n < size - pos ? n : size - pos;
		const uint8_t *b = data + pos;
		pos += len;
		if (kind % 4u == 3u) {
			float scale = len ? 0.5f + (float)b[0] / 128.0f : 1.0f;
			for (long k = 0; running && k < (long)(kind / 4u + 1u) * 64; k++) {
				plant_frame(scale);
				running = step();
			}
			continue;
		}
		plant_frame(1.0f);
		size_t off = offsetof(struct hal_sensor_frame, rate_b_rps);
		size_t room = offsetof(struct hal_sensor_frame, lat_deg) - off;
		memcpy((uint8_t *)&fr + off, b, len < room ? len : room);
		running = step();
	}
	return 0;
}
