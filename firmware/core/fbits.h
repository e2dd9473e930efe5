/*
 * fbits.h - tests of a float by its bits, for the float code off the 90 Hz path (the
 * *_setup.c files, motor_id_solve.c). On a core without FPU (Cortex-M0) every float
 * comparison is a library call; these are tests of one word, with the same results,
 * NaN and -0 included. With an FPU the comparisons are the compiler's own. Where float is
 * not 32 bits (the float64 reference build of motor_id's sources, float defined as double)
 * the bit tests fall back to the comparisons.
 */
#ifndef OCTO_FBITS_H
#define OCTO_FBITS_H

#include <stdbool.h>
#include <stdint.h>

/* the bits of x (its first 32 where float is wider: used only where it is 32 bits) */
static inline uint32_t fb_bits(float x)
{
	union {
		float f;
		uint32_t u;
	} v = {x};
	return v.u;
}

/* the bits with the sign cleared: above 0x7f800000 for NaN, from it on for what is not finite */
static inline uint32_t fb_abs_bits(float x) { return fb_bits(x) & 0x7fffffffu; }

#define FB_FLOAT32 (sizeof(float) == sizeof(uint32_t))
/* the sign tests below by bits where no FPU compares */
#if defined(__ARM_FP)
#define FB_BY_BITS 0
#else
#define FB_BY_BITS FB_FLOAT32
#endif

/* isfinite(x): the exponent not all ones (infinity or NaN); by bits on every core (even
 * with an FPU it is two comparisons) */
static inline bool fb_finite(float x)
{
	return FB_FLOAT32 ? (fb_bits(x) & 0x7f800000u) != 0x7f800000u : (x - x == x - x);
}

/* x > 0: above +0, at most +infinity (not NaN) */
static inline bool fb_pos(float x) { return FB_BY_BITS ? fb_bits(x) - 1u < 0x7f800000u : x > 0.0f; }

/* x < 0: above -0, at most -infinity (not NaN) */
static inline bool fb_neg(float x) { return FB_BY_BITS ? fb_bits(x) - 0x80000001u < 0x7f800000u : x < 0.0f; }

/* x == 0 (+0 or -0) */
static inline bool fb_zero(float x) { return FB_BY_BITS ? fb_bits(x) << 1 == 0u : x == 0.0f; }

#endif /* OCTO_FBITS_H */
