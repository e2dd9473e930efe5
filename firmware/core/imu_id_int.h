/*
 * imu_id_int.h - what imu_id.c (the per-frame part, integer in the fixed build) and
 * imu_id_solve.c (the set-up, the grid's refinement and the solve, float) share: the
 * parameters' indices, the sums' sets and kinds, and the functions each calls of the other.
 * For imu_id*.c only, after imu_id.h (not included here: imu_id.c includes this header, and
 * a module's header including back would make the two one cycle).
 */
#ifndef OCTO_IMU_ID_INT_H
#define OCTO_IMU_ID_INT_H

#ifndef OCTO_IMU_ID_H
#error "include imu_id.h before imu_id_int.h"
#endif

#define NP IMU_ID_NP
#define NT IMU_ID_NT
#define P_B 1   /* B: pinned at 0 when the curve is not estimated */
#define P_LA 2  /* A d ln tau (k_f d ln tau when the curve is known) */
#define P_LB 3  /* B d ln tau: pinned with B */
#define P_OFS 4 /* the accelerometer's offset, N */

/* the sums' sets: the records whose members are the kinds of one exponent each (imu_id_q.h) */
enum { S_GX, S_HS, S_BLK, S_XQ };
#define HS_N (sizeof(struct imu_id_hyp) / sizeof(imu_id_sum_t))   /* b, rr, bt, rrt */
#define BLK_N (sizeof(struct imu_id_stat) / sizeof(imu_id_sum_t)) /* g, b, rr, bt, rrt */
_Static_assert(HS_N == 2u * NP && BLK_N == 2u * NP + NT + 2u, "the records hold their sums alone");
#define K_RR (NP - 1u)     /* a hypothesis' rr; its torque's from HS_T */
#define HS_T NP            /* a hypothesis' bt[0] */
#define B_B NT             /* a block's b[0]; rr, bt[0] and rrt follow */
#define B_RR (NT + NP)     /* a block's rr */
#define B_T (NT + NP + 1u) /* a block's bt[0] */

/* the lag whose patterns' responses advance computes: the clusters' hypothesis after the
 * refinement (refine), the grid's centre */
#define CL_LAG (IMU_ID_LAGS / 2u)
#define AGE (IMU_ID_DELAYS - 1u) /* the bank's regressors' age: the filters' input is this old */

/* the exponent of kind k of a set (arr: its exponents), and the forces' and torques' powers
 * of two (0 in the float build, where they are not normalised) */
#if OCTO_FIXED
#define E_OF(m, arr, k) ((int)(m)->arr[k])
static inline int kexp_of(const struct imu_id *m) { return m->kexp; }
static inline int texp_of(const struct imu_id *m) { return m->texp; }
#else
#define E_OF(m, arr, k) 0
static inline int kexp_of(const struct imu_id *m)
{
	(void)m;
	return 0;
}
static inline int texp_of(const struct imu_id *m)
{
	(void)m;
	return 0;
}
#endif

/* imu_id.c: the filters one frame on (advance), the sums of a set restarted */
void imu_id_advance(struct imu_id *m, const imu_id_u_t u_new[IMU_ID_ROTORS], imu_id_x_t s[2][IMU_ID_LAGS]);
void imu_id_restart_sums(struct imu_id *m, unsigned set);
/* imu_id_solve.c: the grid's refinement (between frames, once) */
void imu_id_refine(struct imu_id *m);

#endif /* OCTO_IMU_ID_INT_H */
