/* id_result.c - the reason codes of the core's verdicts (see id_result.h). */
#include "id_result.h"

enum app_id_reason app_id_reason_of_verdict(enum ident_verdict v)
{
	switch (v) {
	case IDENT_ACCEPT: return APP_ID_OK;
	case IDENT_NOT_FINITE: return APP_ID_NOT_FINITE;
	case IDENT_OUT_OF_RANGE: return APP_ID_OUT_OF_RANGE;
	case IDENT_UNCERTAIN: return APP_ID_UNCERTAIN;
	}
	return APP_ID_NOT_FINITE;
}

enum app_id_reason app_id_reason_of_cause(enum motor_id_cause c)
{
	switch (c) {
	case MOTOR_ID_OK: return APP_ID_OK;
	case MOTOR_ID_NO_DATA: return APP_ID_NO_DATA;
	case MOTOR_ID_NOISE_UNKNOWN: return APP_ID_NOISE_UNKNOWN;
	case MOTOR_ID_LAG_RANGE: return APP_ID_LAG_RANGE;
	case MOTOR_ID_DELAY_RANGE: return APP_ID_DELAY_RANGE;
	case MOTOR_ID_DELAY_AMBIGUOUS: return APP_ID_DELAY_AMBIGUOUS;
	case MOTOR_ID_CURVE: return APP_ID_CURVE;
	case MOTOR_ID_ROTOR: return APP_ID_ROTOR;
	case MOTOR_ID_MODEL: return APP_ID_MODEL;
	case MOTOR_ID_DELAY_GIVEN: return APP_ID_DELAY_GIVEN;
	case MOTOR_ID_LEVEL: return APP_ID_LEVEL;
	case MOTOR_ID_COLOURED: return APP_ID_COLOURED;
	case MOTOR_ID_LAG_REACH: return APP_ID_LAG_REACH;
	}
	return APP_ID_MODEL;
}
