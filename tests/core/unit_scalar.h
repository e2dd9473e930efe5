/*
 * unit_scalar.h - what the core's tests share about scalar_t and double references.
 * Test code, not firmware: double is fine here.
 */
#ifndef OCTO_UNIT_SCALAR_H
#define OCTO_UNIT_SCALAR_H

#include <string.h>

#include "scalar.h"

/* The exact value of a scalar as double (not rounded through float in the Q16.16 build). */
static inline double d(scalar_t a)
{
#if OCTO_FIXED
	return (double)a / 65536.0;
#else
	return (double)a;
#endif
}

/* Reference Hamilton product r = a b of quaternions [w, x, y, z] in double (r may alias). */
static inline void dq_mul(const double a[4], const double b[4], double r[4])
{
	double t[4];
	t[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
	t[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
	t[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
	t[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
	memcpy(r, t, sizeof t);
}

#endif
