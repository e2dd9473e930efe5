/*
 * vec3.h - 3-vectors of scalar_t (static inline, no state).
 *
 * Frames are not part of the type: name them in variables (rate_b, r_i).
 * Every function is total: in the Q16.16 build results saturate (scalar.h).
 */
#ifndef OCTO_VEC3_H
#define OCTO_VEC3_H

#include "scalar.h"

struct vec3 {
	scalar_t x, y, z;
};

/* (x, y, z) */
static inline struct vec3 vec3_make(scalar_t x, scalar_t y, scalar_t z)
{
	struct vec3 r = {x, y, z};
	return r;
}

/* 0 vector */
static inline struct vec3 vec3_zero(void) { return vec3_make(SC_ZERO, SC_ZERO, SC_ZERO); }

/* a + b */
static inline struct vec3 vec3_add(struct vec3 a, struct vec3 b)
{
	return vec3_make(sc_add(a.x, b.x), sc_add(a.y, b.y), sc_add(a.z, b.z));
}

/* a - b */
static inline struct vec3 vec3_sub(struct vec3 a, struct vec3 b)
{
	return vec3_make(sc_sub(a.x, b.x), sc_sub(a.y, b.y), sc_sub(a.z, b.z));
}

/* k * a */
static inline struct vec3 vec3_scale(struct vec3 a, scalar_t k)
{
	return vec3_make(sc_mul(a.x, k), sc_mul(a.y, k), sc_mul(a.z, k));
}

/* element-wise product a .* b (e.g. diagonal inertia times rate) */
static inline struct vec3 vec3_mul(struct vec3 a, struct vec3 b)
{
	return vec3_make(sc_mul(a.x, b.x), sc_mul(a.y, b.y), sc_mul(a.z, b.z));
}

/* a . b */
static inline scalar_t vec3_dot(struct vec3 a, struct vec3 b)
{
	return sc_add(sc_add(sc_mul(a.x, b.x), sc_mul(a.y, b.y)), sc_mul(a.z, b.z));
}

/* a x b */
static inline struct vec3 vec3_cross(struct vec3 a, struct vec3 b)
{
	return vec3_make(sc_sub(sc_mul(a.y, b.z), sc_mul(a.z, b.y)), sc_sub(sc_mul(a.z, b.x), sc_mul(a.x, b.z)),
			 sc_sub(sc_mul(a.x, b.y), sc_mul(a.y, b.x)));
}

/* |a| (Euclidean norm) */
static inline scalar_t vec3_norm(struct vec3 a) { return sc_sqrt(vec3_dot(a, a)); }

/* each component clamped to [-lim, +lim] (lim per axis, >= 0) */
static inline struct vec3 vec3_clamp_abs(struct vec3 a, struct vec3 lim)
{
	return vec3_make(sc_clamp(a.x, sc_neg(lim.x), lim.x), sc_clamp(a.y, sc_neg(lim.y), lim.y),
			 sc_clamp(a.z, sc_neg(lim.z), lim.z));
}

#endif /* OCTO_VEC3_H */
