/*
 * test_id_result.c - identification results as data (id_result.h): an experiment's
 * results reach the log and the ground-station module as structs whose values are the
 * result parameters', with the run's numbering and the reason codes of the verdicts.
 * The app runs on the stub HAL against a kinematic plant (the height follows the set
 * point, attitude level, rotor thrust k_f times the throttle).
 */
#include <math.h>
#include <string.h>

#include "app.h"
#include "mav.h"
#include "stub_hal.h"
#include "unit.h"

struct idrig {
	struct stub_hal h;
	struct app a;
	struct mav m;
	struct hal_sensor_frame f;
	double t;
};

static struct idrig G; /* large: kept off the stack */

static void step(struct idrig *r)
{
	struct app *a = &r->a;
	struct hal_sensor_frame *f = &r->f;
	bool flying = app_flying(a);
	r->t += 1.0 / 90.0;
	r->h.now_us += 11111u;
	hal_frame_time(f, (uint64_t)llround(r->t * 90.0), (uint64_t)llround(r->t * 1e6));
	f->seq++;
	f->valid = HAL_FRAME_NEEDED | HAL_FRAME_THRUST | HAL_FRAME_TORQUE;
	f->pos_i_m[2] = flying ? fmaxf(sc_to_float(a->guid.z_sp_m), 0.0f) : 0.0f;
	f->vel_i_mps[2] = flying && f->pos_i_m[2] > 0.0f ? sc_to_float(a->guid.vz_ff_mps) : 0.0f;
	for (int j = 0; j < HAL_ROTORS; j++)
		f->rotor_thrust_n[j] = a->p.veh_kf * r->h.thr[j];
	app_on_frame(a, f);
	app_tick(a);
	mav_tick(&r->m, r->h.now_us);
}

static struct idrig *hovering(struct unit_ctx *u)
{
	struct idrig *r = &G;
	memset(r, 0, sizeof *r);
	stub_hal_init(&r->h);
	app_init(&r->a, &r->h.hal);
	mav_init(&r->m, &r->a, &r->h.hal, r->h.now_us);
	r->f.q_ib[0] = 1.0f;
	char why[64];
	for (int i = 0; i < 5; i++)
		step(r);
	CHECK(app_cmd_arm(&r->a, true, false, why, sizeof why) == APP_ACCEPTED);
	CHECK(app_cmd_takeoff(&r->a, 3.0f, APP_ORIGIN_NONE, why, sizeof why) == APP_ACCEPTED);
	for (int i = 0; i < 90 * 60 && r->a.mode != APP_HOLD; i++)
		step(r);
	for (int i = 0; i < 30; i++)
		step(r);
	CHECK(app_hovering(&r->a));
	return r;
}

static float param(const struct app *a, const char *name)
{
	int i = params_find(name, strlen(name));
	return i >= 0 ? params_get(&a->p, (size_t)i) : NAN;
}

/* Experiment `id` flown to its end (at most a minute of plant time). */
static void fly_experiment(struct unit_ctx *u, struct idrig *r, int id)
{
	char why[64] = "";
	CHECK(app_cmd_experiment(&r->a, (float)id, APP_ORIGIN_NONE, why, sizeof why) == APP_IN_PROGRESS);
	for (int i = 0; i < 90 * 60 && r->a.mode == APP_EXPERIMENT; i++)
		step(r);
	CHECK(r->a.mode == APP_HOLD);
}

/* Validation (experiment 2, before any rotor identification): one result, the NE with the
 * fit % in sd's place, accepted, the values of ID_VAL_NE_PRE and ID_VAL_FIT_PRE; the only
 * result of run 1, so index 0, count 1 and run_done. */
UNIT_TEST(id_result_validation_accepted_as_data)
{
	struct idrig *r = hovering(u);
	fly_experiment(u, r, 2);
	CHECK(r->h.n_id_results == 1);
	const struct app_id_result *x = &r->h.id_results[0];
	CHECK(x->param == APP_ID_VAL_NE_BEFORE && x->experiment == 2 && x->rotor == 0);
	CHECK(x->accepted == 1 && x->reason == APP_ID_OK && x->source == APP_ID_SOURCE_THRUST);
	CHECK(x->value == param(&r->a, "ID_VAL_NE_PRE") && x->sd == param(&r->a, "ID_VAL_FIT_PRE"));
	CHECK(x->run_id == 1 && x->index == 0 && x->count == 1 && x->run_done == 1);
	const struct app_id_run *run = app_view(&r->a).id_run;
	CHECK(run->run_id == 1 && run->count == 1 && run->done);
}

/* Inertia Ixx asked to an accuracy no 10 s flight gives (ID_RSD_MAX at its minimum): the
 * estimate comes out rejected with the verdict's code, its value and sd those of ID_IXX_EST
 * and ID_IXX_SD, VEH_IXX unchanged. The second experiment is run 2. */
UNIT_TEST(id_result_inertia_rejection_has_its_reason)
{
	struct idrig *r = hovering(u);
	fly_experiment(u, r, 2);
	int i = params_find("ID_RSD_MAX", 10);
	CHECK(i >= 0 && app_param_write(&r->a, (size_t)i, 0.0001f) == NULL);
	float ixx = r->a.p.veh_ixx;
	fly_experiment(u, r, 3);
	CHECK(r->h.n_id_results == 2);
	const struct app_id_result *x = &r->h.id_results[1];
	CHECK(x->param == APP_ID_IXX && x->experiment == 3);
	CHECK(x->accepted == 0);
	CHECK(x->reason == APP_ID_UNCERTAIN || x->reason == APP_ID_NOT_FINITE || x->reason == APP_ID_OUT_OF_RANGE);
	CHECK(x->value == param(&r->a, "ID_IXX_EST") && x->sd == param(&r->a, "ID_IXX_SD"));
	CHECK(r->a.p.veh_ixx == ixx);
	CHECK(x->run_id == 2 && x->index == 0 && x->count == 1 && x->run_done == 1);
}

/* The core's verdicts and the motor model's causes map onto distinct reason codes. */
UNIT_TEST(id_result_reason_codes_of_the_core)
{
	CHECK(app_id_reason_of_verdict(IDENT_ACCEPT) == APP_ID_OK);
	CHECK(app_id_reason_of_verdict(IDENT_UNCERTAIN) == APP_ID_UNCERTAIN);
	CHECK(app_id_reason_of_verdict(IDENT_OUT_OF_RANGE) == APP_ID_OUT_OF_RANGE);
	CHECK(app_id_reason_of_verdict(IDENT_NOT_FINITE) == APP_ID_NOT_FINITE);
	CHECK(app_id_reason_of_cause(MOTOR_ID_OK) == APP_ID_OK);
	CHECK(app_id_reason_of_cause(MOTOR_ID_ROTOR) == APP_ID_ROTOR);
	CHECK(app_id_reason_of_cause(MOTOR_ID_LAG_REACH) == APP_ID_LAG_REACH);
	CHECK(app_id_reason_of_cause(MOTOR_ID_CURVE) == APP_ID_CURVE);
	for (int c = MOTOR_ID_NO_DATA; c <= MOTOR_ID_LAG_REACH; c++)
		for (int d = c + 1; d <= MOTOR_ID_LAG_REACH; d++)
			CHECK(app_id_reason_of_cause((enum motor_id_cause)c) !=
			      app_id_reason_of_cause((enum motor_id_cause)d));
}
