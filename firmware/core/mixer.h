/*
 * mixer.h - Gamma_o mixer, eqs. (11)-(15): [f; tau] <-> rotor thrusts f_j (N).
 *
 * Gamma (4 x 8, eq. 14, or a custom layout) maps rotor thrusts to [f; tau_x; tau_y; tau_z];
 * a rotor cleared in rotor_mask is a zero column; per-rotor effectiveness (scale) scales the
 * columns and the allocation runs on u_j = f_j / scale_j, whose box [k_f t_min, k_f t_max] is
 * the same for every rotor.
 *
 * Set-up (mixer_init, mixer_set_params; off the 90 Hz path, float32 in both builds, results
 * kept as scalar_t): the pseudo-inverse Gamma^+, the null space of Gamma, and the facet tables
 * of the box-constrained allocator. mixer_set_params recomputes only when the geometry changed.
 *
 * Update (mixer_update, 90 Hz, scalar_t only): u = Gamma^+ [f; tau]; if a rotor leaves its
 * box, MIXER_MODE_CLIP clips, MIXER_MODE_PRIORITY allocates exactly within the box with the
 * priority roll/pitch > thrust > yaw (achieved yaw never of the opposite sign), in at most
 * 2 MIXER_ALPHA_ITERS + (n_active - 4) + MIXER_QP_ITERS steps. Without an allocator (rank < 4,
 * fewer than 4 rotors, facet tables too small) PRIORITY clips and sets MIXER_LIMIT_NO_ALLOC.
 * The derivation: docs/identification.md, "Allocation".
 *
 * Accuracy (tests/core/test_mixer.c): float build: Gamma Gamma^+ = I4 to 1e-6; attainable
 * demands reproduced to 2e-4 N thrust, 1e-4 N m roll/pitch, 3e-5 N m yaw. Q16.16 build:
 * 6e-3 N, 2e-3 N m, 2e-4 N m; its Gamma^+ copy times Gamma = I4 to 2e-4.
 */
#ifndef OCTO_MIXER_H
#define OCTO_MIXER_H

#include "scalar.h"

#include <stdbool.h>
#include <stdint.h>

#define MIXER_N_ROTORS 8
#define MIXER_N_AXES 4 /* [f, tau_x, tau_y, tau_z] */
#define MIXER_AXIS_F 0
#define MIXER_AXIS_TX 1
#define MIXER_AXIS_TY 2
#define MIXER_AXIS_TZ 3

/* bisection steps for the roll/pitch scale when even full roll/pitch is unattainable */
#define MIXER_ALPHA_ITERS 20
/* active-set iterations of the refinement towards the minimum-norm feasible allocation */
#define MIXER_QP_ITERS 16
/* Distinct facet normals kept for the attainable set and for the preimage steps: what eq. (14)
 * needs, 26 and 44, also with one or two rotors removed, any arm length, k_tau / k_f and
 * per-rotor scale (the counts depend on which columns are coplanar and, for the preimage
 * steps, on which four rotors come last: 44 is the most over every choice). A layout in general
 * position needs up to C(8,3) = 56 and 35+20+10 = 65: if they do not fit, the priority
 * allocator is disabled for that layout (MIXER_LIMIT_NO_ALLOC, clipping). Each is a facet in
 * the caller's struct mixer. */
#define MIXER_MAX_FACETS 26
#define MIXER_MAX_SUB_FACETS 44

enum mixer_mode {
	MIXER_MODE_CLIP = 0,     /* pseudo-inverse plus clipping (baseline) */
	MIXER_MODE_PRIORITY = 1, /* exact box-constrained allocation, roll/pitch > f > yaw */
};

/* Limit flags (mixer_output.limits) */
#define MIXER_LIMIT_ROTOR_MIN (1u << 0) /* some rotor at its lower bound */
#define MIXER_LIMIT_ROTOR_MAX (1u << 1) /* some rotor at its upper bound */
#define MIXER_LIMIT_F (1u << 2)         /* total thrust not as demanded */
#define MIXER_LIMIT_TX (1u << 3)        /* roll torque reduced */
#define MIXER_LIMIT_TY (1u << 4)        /* pitch torque reduced */
#define MIXER_LIMIT_TZ (1u << 5)        /* yaw torque reduced */
#define MIXER_LIMIT_NO_ALLOC (1u << 6)  /* priority allocator unavailable: clipped */
#define MIXER_LIMIT_BAD_INPUT (1u << 7) /* non-finite demand (float build): all rotors 0 */

struct mixer_params {
	scalar_t arm_l_m;   /* l, m (> 0) */
	scalar_t k_f_n;     /* k_f, thrust at throttle 1, N (> 0) */
	scalar_t k_tau_nm;  /* k_tau, reaction torque at throttle 1, N m */
	scalar_t t_min;     /* lower throttle bound of every rotor, usually 0 */
	scalar_t t_max;     /* upper throttle bound, usually 1: f_hi = k_f t_max */
	uint8_t rotor_mask; /* bit j set: rotor j+1 present; 0xFF = all eight */
	enum mixer_mode mode;
	/* optional: NULL = eq. (14); else a row-major 4x8 Gamma in physical units (N, N m per N)
	 * for a different layout; it is copied, not kept */
	const float *custom_gamma;
	/* per-rotor effectiveness (see above): 0 (not given) is taken as 1, other values are
	 * clamped to [0.1, 4] (as the throttle map does) */
	scalar_t scale[MIXER_N_ROTORS];
};

/* a facet of the attainable set or of a preimage step's sub-zonotope */
struct mixer_facet {
	scalar_t n[MIXER_N_AXES]; /* unit normal in the row-scaled space */
	scalar_t nc;              /* n . centre of its zonotope */
	scalar_t h;               /* half-width: 1/2 sum |n . g_j| over its generators */
};

/* The float32 results of the set-up that the 90 Hz path does not use: mixer_init computes
 * them in a scratch on its stack and drops them; mixer_init_design hands them to the caller
 * (tests, tools). */
struct mixer_design {
	float gamma_f[MIXER_N_AXES][MIXER_N_ROTORS];  /* Gamma S (per unit of u), float */
	float pinv_f[MIXER_N_ROTORS][MIXER_N_AXES];   /* (Gamma S)^+, float */
	float null_f[MIXER_N_ROTORS][MIXER_N_ROTORS]; /* null-space basis: columns 0..n_null-1 */
	uint8_t rank;
	uint8_t n_null;
};

/* What the 90 Hz path reads (and the parameters, to see what changed): the caller keeps it.
 * The small fields come first: short load offsets on Thumb (bytes within 31, words within
 * 124 of the start), which keeps the allocator's code small on Cortex-M0. */
struct mixer {
	uint8_t rank;
	uint8_t n_active;
	uint8_t present; /* bit j: rotor j+1 has a nonzero column */
	uint8_t n_facets;
	bool alloc_ok;
	bool custom;                   /* built from custom_gamma */
	uint8_t order[MIXER_N_ROTORS]; /* present rotors; the last 4 are independent */
	/* the preimage's steps 0..n_active-5 (at most 4): facets of the suffix set after each */
	uint8_t sub_n[MIXER_N_ROTORS - 4];
	uint8_t sub_first[MIXER_N_ROTORS - 4];
	/* the step's fallback along the pseudo-inverse's thrust ([0]) and yaw ([1]) columns: bit j
	 * of col_up / col_dn when present rotor j moves up / down along it, of col_fix when it
	 * does not move (|entry| <= the slopes' threshold) */
	uint8_t col_up[2], col_dn[2], col_fix[2];

	/* hot-path data, scalar_t; everything of the allocation is in u (f_j / scale_j) */
	scalar_t f_lo, f_hi;                         /* box of u, N (rotor j's thrust: scale_j times it) */
	scalar_t width;                              /* f_hi - f_lo (physical wrench per unit of scaled
					    * wrench: width row_max) */
	scalar_t row_max[MIXER_N_AXES];              /* max_j |Gamma_ij|: pinv times it (column i) is the
					    * pseudo-inverse in the scaled space */
	scalar_t row_div[MIXER_N_AXES];              /* 1 / max_j |Gamma_ij| */
	scalar_t w_lo[MIXER_N_AXES];                 /* physical wrench with every present rotor at u = f_lo */
	struct mixer_params p;                       /* copy (custom_gamma set to NULL after copying; scale as
					* used: 0 replaced by 1, clamped) */
	scalar_t pinv[MIXER_N_ROTORS][MIXER_N_AXES]; /* (Gamma S)^+ (physical wrench -> u) */
	scalar_t gn[MIXER_N_AXES][MIXER_N_ROTORS];   /* row-scaled Gamma S, entries in [-1, 1] */
	scalar_t tail_inv[4][MIXER_N_AXES];          /* inverse of the last 4 scaled columns */
	struct mixer_facet facet[MIXER_MAX_FACETS];
	struct mixer_facet sub[MIXER_MAX_SUB_FACETS];
};

struct mixer_output {
	scalar_t f_n[MIXER_N_ROTORS];    /* rotor thrust commands, N, in scale_j [f_lo, f_hi] (0 if absent) */
	scalar_t demanded[MIXER_N_AXES]; /* [f, tau_x, tau_y, tau_z] as given */
	scalar_t achieved[MIXER_N_AXES]; /* Gamma * f_n */
	uint32_t limits;                 /* MIXER_LIMIT_* */
	uint8_t rotor_at_min;            /* bit j: rotor j+1 at its lower bound */
	uint8_t rotor_at_max;            /* bit j: rotor j+1 at its upper bound */
	uint8_t steps;                   /* bisection + preimage + active-set steps used */
};

/* The frame-budgeted allocation (the 90 Hz step's): the exact priority allocation above
 * costs many steps' worth when the demand saturates, so the step does a bounded part and the
 * exact search runs between frames.
 *   mixer_step (in the step): eq. (15); in the box that is the allocation (exact). Outside it,
 *     the face of the last exact allocation (its rotors at a bound kept there, the free ones
 *     moved by the minimum-norm solution of their columns, axes it could not meet held at what
 *     it achieved) applied to this demand: exact whenever this demand lies on that face, as
 *     it does while a saturation evolves from frame to frame. When the face does not fit the
 *     box (the first saturated frame, a jump): the bounded fallback along the pseudo-inverse's
 *     axis columns (yaw to zero, the nearest thrust that fits, then as much yaw as fits; when
 *     no thrust fits the roll/pitch, the largest share of it that fits, no yaw). The saturated demand is kept for:
 *   mixer_refresh (between frames): the exact priority allocation of that demand (as
 *     mixer_update) and its face for the next steps. Nothing to do after an unsaturated step.
 * Per step: at most three line scans over the rotors beyond eq. (15), no iteration; the axis
 * flags compare achieved and demanded (as clipping does); out->steps = the fallback's line
 * scans (0 on the face, 2 or 3). A held demand is allocated as mixer_update allocates it
 * from the step after its refresh on (tests/core/test_mixer.c). */
enum mixer_path {
	MIXER_PATH_PINV = 0,        /* eq. (15) in the box, or a non-finite demand */
	MIXER_PATH_FACE = 1,        /* the last exact allocation's face */
	MIXER_PATH_FALLBACK = 2,    /* the bounded fallback: thrust, then yaw */
	MIXER_PATH_FALLBACK_RP = 3, /* the bounded fallback: roll/pitch scaled, no yaw */
	MIXER_PATH_CLIP = 4,        /* clipped (CLIP mode, or no allocator) */
};

struct mixer_warm {
	bool valid;   /* u_ex, t_ex, map, held: mixer_refresh's for the current mixer */
	bool pending; /* the last mixer_step saturated: demand waits for mixer_refresh */
	uint8_t held; /* bit i: axis i of [f, tau_x, tau_y, tau_z] was limited in the exact allocation */
	uint8_t path; /* enum mixer_path of the last mixer_step */
	bool full;    /* the face's free columns span the wrench (else it serves only its own wrench) */
	scalar_t demand[MIXER_N_AXES];              /* the last saturated demand */
	scalar_t t_ex[MIXER_N_AXES];                /* the wrench the exact allocation achieved */
	scalar_t u_ex[MIXER_N_ROTORS];              /* its u_j = f_j / scale_j, N (0 if absent) */
	scalar_t map[MIXER_N_ROTORS][MIXER_N_AXES]; /* du (N) per wrench change on its face (0: at a bound) */
};

/* Defaults: the paper's vehicle (l = 0.35 m, k_f = 28.0269 N, k_tau = 0.3869 N m), throttle
 * [0, 1], all rotors, PRIORITY. */
void mixer_default_params(struct mixer_params *p);

/* Builds Gamma, the pseudo-inverse, null space and allocator data. Returns true when Gamma
 * has full row rank 4 (false: the pseudo-inverse is still the Moore-Penrose one of the
 * rank-deficient Gamma; the priority allocator is disabled). */
bool mixer_init(struct mixer *m, const struct mixer_params *p);

/* mixer_init, also writing the float32 design (Gamma, Gamma^+, null space) to *d. */
bool mixer_init_design(struct mixer *m, const struct mixer_params *p, struct mixer_design *d);

/* Recomputes (mixer_init) only if a parameter that enters Gamma or the box changed (always
 * with custom_gamma); a mode change alone is applied without recomputation. Call it whenever
 * VEH_ARM_L, VEH_KF, VEH_KTAU or MOT_SCALEj change; cheap when nothing did. Returns the
 * rank-4 status. */
bool mixer_set_params(struct mixer *m, const struct mixer_params *p);

/* demand = [f (N), tau_x, tau_y, tau_z (N m)] -> out. Never fails. */
void mixer_update(const struct mixer *m, const scalar_t demand[MIXER_N_AXES], struct mixer_output *out);

/* No face: the next saturated mixer_step falls back (call it when the mixer was rebuilt). */
void mixer_warm_reset(struct mixer_warm *s);

/* The step's allocation (see struct mixer_warm): bounded, never fails. */
void mixer_step(const struct mixer *m, struct mixer_warm *s, const scalar_t demand[MIXER_N_AXES],
		struct mixer_output *out);

/* Between frames: the exact allocation of the last saturated step's demand and its face;
 * returns at once when that step was not saturated. */
void mixer_refresh(const struct mixer *m, struct mixer_warm *s);

/* What the allocation cut, by axis and direction, for the controllers' anti-windup: bit k
 * (axis k of [f, tau_x, tau_y, tau_z]) of *short_pos when an axis the mixer flagged
 * (MIXER_LIMIT_F, _TX, _TY, _TZ) got less than its demand, of *short_neg when it got more. */
void mixer_shortfall(const struct mixer_output *out, uint8_t *short_pos, uint8_t *short_neg);

/* wrench[i] = sum_j Gamma[i][j] f_n[j]: the geometry's wrench of physical rotor thrusts f_n
 * (N; e.g. measured ones), physical units, scalar_t */
void mixer_wrench(const struct mixer *m, const scalar_t f_n[MIXER_N_ROTORS], scalar_t wrench[MIXER_N_AXES]);

/* Exact attainability test of a physical wrench (facet test, tolerance tol in scaled units;
 * false if the allocator is unavailable). */
bool mixer_attainable(const struct mixer *m, const scalar_t wrench[MIXER_N_AXES], scalar_t tol);

#endif /* OCTO_MIXER_H */
