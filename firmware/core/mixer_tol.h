/* mixer_tol.h - tolerances shared by the mixer's set-up (mixer_setup.c) and its
 * allocation (mixer.c); internal to those two files. */
#ifndef OCTO_MIXER_TOL_H
#define OCTO_MIXER_TOL_H

#include "scalar.h"

/* tolerances of the allocator, in scaled units (1 = one rotor's full thrust range) */
#if OCTO_FIXED
#define TOL_ATT ((scalar_t)16) /* 2.4e-4 in scaled units */
#define TOL_IN ((scalar_t)24)  /* inner margin of the priority steps: 3.7e-4 */
#define EPS_S ((scalar_t)64)   /* 1e-3: slopes below are treated as zero */
#define TOL_FLAG_REL SC(0.001)
#define EPS_GS ((scalar_t)16) /* squared residual norm below which a row is dependent */
#define EPS_P ((scalar_t)8)
#define EPS_MU ((scalar_t)32)
#else
#define TOL_ATT SC(3e-6)
#define TOL_IN SC(3e-6)
#define EPS_S SC(1e-6)
#define TOL_FLAG_REL SC(1e-5)
#define EPS_GS SC(1e-8)
#define EPS_P SC(1e-7)
#define EPS_MU SC(1e-6)
#endif

#endif /* OCTO_MIXER_TOL_H */
