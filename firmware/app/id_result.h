/*
 * id_result.h - an identification result as data: the quantity, its estimate and sd,
 * accepted or not with a reason code, the measurements it rests on, and its place in
 * its run. The experiment fills the quantity's part; the app numbers the run and
 * posts each result as an outbox event (APP_EV_ID_RESULT) and to the log. The codes
 * are those of the MAVLink dialect's OCTO_ID_PARAM, OCTO_ID_REASON and OCTO_ID_SOURCE
 * (mav.c checks them; docs/mavlink.md lists them), without the dialect's headers.
 */
#ifndef OCTO_APP_ID_RESULT_H
#define OCTO_APP_ID_RESULT_H

#include <stdbool.h>
#include <stdint.h>

#include "ident.h"
#include "motor_id.h"

enum app_id_param {
	APP_ID_KF = 1,
	APP_ID_KTAU,
	APP_ID_IXX,
	APP_ID_IYY,
	APP_ID_IZZ,
	APP_ID_MOT_TAU,
	APP_ID_DELAY_FR,
	APP_ID_MOT_CURVE,
	APP_ID_MOT_SCALE, /* the rotor field names the rotor */
	APP_ID_KF_PLAIN,
	APP_ID_KTAU_PLAIN,
	APP_ID_KTAU_OVER_IZZ,
	APP_ID_VAL_NE_BEFORE, /* sd holds the fit % */
	APP_ID_VAL_NE_AFTER,
};

enum app_id_reason {
	APP_ID_OK = 0,
	APP_ID_NOT_FINITE,
	APP_ID_OUT_OF_RANGE,
	APP_ID_UNCERTAIN,
	APP_ID_PARTNER_REJECTED,
	APP_ID_LAG_OFF,
	APP_ID_NO_DATA,
	APP_ID_NOISE_UNKNOWN,
	APP_ID_LAG_RANGE,
	APP_ID_DELAY_RANGE,
	APP_ID_DELAY_AMBIGUOUS,
	APP_ID_CURVE,
	APP_ID_ROTOR,
	APP_ID_MODEL,
	APP_ID_DELAY_GIVEN,
	APP_ID_LEVEL,
	APP_ID_COLOURED,
	APP_ID_LAG_REACH,
	APP_ID_NOT_IDENTIFIABLE,
	APP_ID_AUXILIARY,
	APP_ID_ABORTED,
};

enum app_id_source {
	APP_ID_SOURCE_UNKNOWN = 0,
	APP_ID_SOURCE_THRUST = 1,     /* each rotor's measured thrust and reaction torque */
	APP_ID_SOURCE_IMU = 2,        /* gyro, accelerometer, throttles sent, mass and geometry */
	APP_ID_SOURCE_IMU_RPM = 3,    /* the IMU and each rotor's speed */
	APP_ID_SOURCE_IMU_RPM_TQ = 4, /* those and each rotor's shaft torque (ESC current) */
};

struct app_id_result {
	uint16_t run_id;      /* experiment commands since boot (the app sets it) */
	uint8_t index, count; /* within the run; count: published so far (the app) */
	uint8_t run_done;     /* 1: the run has ended, count is its total (the app) */
	uint8_t experiment;   /* the phase: 1 rotor, 2 validation, 3-5 inertia x, y, z */
	uint8_t param;        /* enum app_id_param */
	uint8_t rotor;        /* 1..8 for APP_ID_MOT_SCALE, else 0 */
	uint8_t accepted;     /* 1: applied to the vehicle's parameters */
	uint8_t source;       /* enum app_id_source */
	uint16_t reason;      /* enum app_id_reason (APP_ID_OK when accepted) */
	float value, sd;      /* sd NaN when none is defined */
};

/* The results of the last run, as published (a request for them is answered from here). */
#define APP_ID_RUN_MAX 32
struct app_id_run {
	uint16_t run_id; /* 0: no run yet */
	uint8_t count;
	bool done;
	struct app_id_result r[APP_ID_RUN_MAX];
};

/* The reason code of an estimator's verdict and of the motor model's cause. */
enum app_id_reason app_id_reason_of_verdict(enum ident_verdict v);
enum app_id_reason app_id_reason_of_cause(enum motor_id_cause c);

#endif /* OCTO_APP_ID_RESULT_H */
