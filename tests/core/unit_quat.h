/*
 * unit_quat.h - attitudes the core's tests build (test code, not firmware): the core keeps
 * only what the firmware calls (quat.h), the tests make their set points and vehicle
 * attitudes here.
 */
#ifndef OCTO_UNIT_QUAT_H
#define OCTO_UNIT_QUAT_H

#include <math.h>

#include "quat.h"

/* [1, 0, 0, 0] */
static inline struct quat tq_identity(void)
{
	struct quat q = {SC(1), SC_ZERO, SC_ZERO, SC_ZERO};
	return q;
}

/* Euler Z-Y-X (roll, pitch, yaw in rad, quat.h) -> q_b2i, as the firmware makes its set
 * points: quat_from_euler_yh with the yaw's half-angle trigonometry */
static inline struct quat tq_from_euler(scalar_t roll, scalar_t pitch, scalar_t yaw)
{
	return quat_from_euler_yh(roll, pitch, quat_yaw_half(yaw));
}

/* rotation of angle |rv| (rad) about rv / |rv| (rv in rad, double), rounded to scalars */
static inline struct quat tq_from_rotvec(double x, double y, double z)
{
	double a = sqrt(x * x + y * y + z * z), k = a > 0 ? sin(a / 2) / a : 0.5;
	struct quat q = {sc_from_float((float)cos(a / 2)), sc_from_float((float)(k * x)), sc_from_float((float)(k * y)),
			 sc_from_float((float)(k * z))};
	return q;
}

#endif /* OCTO_UNIT_QUAT_H */
