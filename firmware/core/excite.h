/*
 * excite.h - seeded, deterministic excitation signals for identification.
 *
 *   EXCITE_UNIFORM    uniform random in [-A, A] (the paper's delta_1 and mu_1), a new
 *                     value every clock_div frames (xorshift32, 15-bit resolution)
 *   EXCITE_PRBS       maximum-length LFSR of order n (2..16, period 2^n - 1 bits),
 *                     +/-A, one bit every clock_div frames
 *   EXCITE_MULTISINE  sum of N (<= EXCITE_MS_MAX) equal-amplitude sines at harmonics
 *                     k_first .. k_first + N - 1 of f0 = frame rate / ms_period_frames,
 *                     Schroeder phases phi_k = -pi k (k - 1) / N (k = 1..N), scaled so
 *                     that its peak over one period (found at init, sampled at the
 *                     frame rate, at most EXCITE_MS_PEAK_SCAN frames) is A
 *
 * Same params and seed give the same sequence in both builds (uniform and PRBS
 * exactly, up to the last bit of the A scaling; multisine within ~1e-4 A). The output
 * is always within [-A, A]. The generator is a pure function of its state and the
 * number of update calls; call excite_update once per frame.
 * Hot path: integer operations, add and mul (plus one div per uniform draw); the
 * multisine uses integer phase accumulators and a polynomial sine (no trig), and
 * restarts its phases every period, so it is exactly periodic.
 */
#ifndef OCTO_EXCITE_H
#define OCTO_EXCITE_H

#include "scalar.h"

#include <stdint.h>

/* the most sines a multisine holds: what the experiments use (inertia: harmonics 4..15, 12) */
#define EXCITE_MS_MAX 12
#define EXCITE_MS_PEAK_SCAN 8192

enum excite_kind {
	EXCITE_OFF = 0,
	EXCITE_UNIFORM = 1,
	EXCITE_PRBS = 2,
	EXCITE_MULTISINE = 3,
};

struct excite_params {
	enum excite_kind kind;
	scalar_t amplitude;        /* A >= 0 (negative is taken as 0) */
	uint32_t clock_div;        /* frames per value / bit (>= 1; 0 is taken as 1) */
	uint32_t seed;             /* any value; 0 is replaced by a fixed nonzero seed */
	uint32_t prbs_order;       /* n in [2, 16] (clamped) */
	uint32_t ms_period_frames; /* multisine period P in frames (>= 4; f0 = frame rate / P) */
	uint32_t ms_count;         /* N sines, 1..EXCITE_MS_MAX (clamped) */
	uint32_t ms_k_first;       /* first harmonic index (>= 1) */
};

struct excite {
	struct excite_params p;
	uint32_t rng;  /* xorshift32 state (uniform) */
	uint32_t lfsr; /* LFSR state (PRBS) */
	uint32_t lfsr_taps;
	uint32_t count;                /* frames since the value was drawn (multisine: frame in period) */
	scalar_t value;                /* current held value (uniform, PRBS) */
	uint32_t phase[EXCITE_MS_MAX]; /* multisine phases, 2^32 = one turn */
	uint32_t dphase1;              /* phase step per frame of harmonic 1 (sine k: ms_k_first + k times it) */
	scalar_t ms_scale;             /* A / (N * peak of the normalised sum) */
	/* multisine, between frames (excite_prepare): the phases' move after the last sample
	 * (EXCITE_MS_*), then the next sample's normalised sum */
	uint8_t ms_due;
	bool ms_ready; /* ms_next holds the sum at the current phases */
	scalar_t ms_next;
};

/* Sensible defaults: uniform, A = 0.05, clock_div 1, seed 1, PRBS order 9,
 * multisine period 180 frames (f0 = 0.5 Hz at 90 Hz), 8 sines from k = 1. */
struct excite_params excite_params_default(void);

/* Copies (and clamps) params, seeds the generators, computes the multisine scale. */
void excite_init(struct excite *e, const struct excite_params *params);

/* Next sample, in [-A, A] (0 for EXCITE_OFF). */
scalar_t excite_update(struct excite *e);

/* Between frames: the multisine's next sample ready for excite_update (its phases moved and
 * its sum of sines formed), which then only scales it; a no-op for the other kinds and when
 * it is ready. excite_update does it when nobody did: the same sequence either way. */
void excite_prepare(struct excite *e);

/* Period of the sequence in frames: PRBS (2^n - 1) clock_div, multisine P (exactly
 * periodic), 0 for uniform (not periodic) and off. An inline: no flash unless a caller
 * uses it (the firmware does not, the tests do). */
static inline uint32_t excite_period_frames(const struct excite *e)
{
	if (e->p.kind == EXCITE_PRBS)
		return (((uint32_t)1 << e->p.prbs_order) - 1u) * e->p.clock_div;
	return e->p.kind == EXCITE_MULTISINE ? e->p.ms_period_frames : 0u;
}

/* ---------------------------------------------------------------- null-space patterns
 * Rotor patterns (8 entries, rotors 1..8) in the null space of Gamma_o, eq. (14) (thrust,
 * roll, pitch and yaw all cancel, whatever k_f, k_tau and the arm are):
 *   0: [1 0 -1 0 1 0 -1 0]   rotors 1, 5 against 3, 7 (odd rotors: one spin direction)
 *   1: [0 1 0 -1 0 1 0 -1]   rotors 2, 6 against 4, 8 (even rotors)
 *   2: [1 1 -1 -1 1 1 -1 -1] the sum: every rotor moves (offset pattern)
 * Patterns 0 and 1 together cover every rotor; two independent dithers on them give each
 * rotor its own excitation. excite_offset_level cycles +1, 0, -1, 0 every seg_frames, so an
 * offset o times pattern 2 moves each rotor's mean throttle over three levels. */
#define EXCITE_NULL_PATTERNS 3
#define EXCITE_ROTORS 8

/* pattern k (k >= EXCITE_NULL_PATTERNS: zeros) */
void excite_null_pattern(unsigned k, scalar_t out[EXCITE_ROTORS]);

/* +1, 0, -1, 0, ... by blocks of seg_frames (>= 1) frames */
scalar_t excite_offset_level(uint32_t frame, uint32_t seg_frames);

#endif /* OCTO_EXCITE_H */
