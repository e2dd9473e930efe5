/* mixer.c - the 90 Hz allocation on scalar_t: the wrench of rotor thrusts, attainability,
 * pseudo-inverse and clip or box-constrained priority allocation; see mixer.h. The
 * set-up that prepares what it uses (float, at a parameter change) is mixer_setup.c. */
#include "mixer.h"

#define NR MIXER_N_ROTORS
#define NA MIXER_N_AXES

#include "mixer_tol.h"

/* Kept out of line for flash: the compiler would inline these at every use (sc_div's zero
 * test and sc_clamp's two compares are calls of their own on a core without FPU), and
 * preimage's locals would crowd the registers of its caller; scaled_rp and
 * attainable_scaled have several callers. A call costs little beside a division or a
 * clamp. */
#if defined(__GNUC__)
#define MIX_NOINLINE static __attribute__((noinline))
#else
#define MIX_NOINLINE static
#endif

/* a / b; the fixed build returns a at once for b = 1 (what sc_div gives, exactly) */
MIX_NOINLINE scalar_t mdiv(scalar_t a, scalar_t b)
{
#if OCTO_FIXED
	if (b == SC(1))
		return a;
#endif
	return sc_div(a, b);
}
/* Where float is an instruction (an FPU, the host): the step's small helpers inline and its
 * loops over the rotors and axes unrolled (MIX_UNROLL), as their counting, addressing and
 * calls cost as much as their arithmetic; the fixed and soft-float builds keep them out of
 * line and rolled (flash). */
#define MIX_HARD_FLOAT SC_HARD_FLOAT
#if MIX_HARD_FLOAT && defined(__GNUC__)
#define MIX_HOT static inline __attribute__((always_inline))
#else
#define MIX_HOT static
#endif
#define MIX_UNROLL SC_HOT_UNROLL

#if SC_SOFT_FLOAT
/* where float is soft, sc_clamp, sc_max and sc_min are already out of line (scalar.c) */
#define mclamp sc_clamp
#define mmax sc_max
#define mmin sc_min
#elif MIX_HARD_FLOAT
/* with an FPU two compares: inline */
static inline scalar_t mclamp(scalar_t x, scalar_t lo, scalar_t hi) { return sc_clamp(x, lo, hi); }
static inline scalar_t mmax(scalar_t a, scalar_t b) { return sc_max(a, b); }
static inline scalar_t mmin(scalar_t a, scalar_t b) { return sc_min(a, b); }
#else
MIX_NOINLINE scalar_t mclamp(scalar_t x, scalar_t lo, scalar_t hi) { return sc_clamp(x, lo, hi); }
/* max and min inline in the fixed build and with an FPU (a compare instruction) */
static inline scalar_t mmax(scalar_t a, scalar_t b) { return sc_max(a, b); }
static inline scalar_t mmin(scalar_t a, scalar_t b) { return sc_min(a, b); }
#endif

/* x == 0 (either sign): a compare in the fixed build and with an FPU; on a core without FPU
 * the bits of x without its sign all 0, a test of a word, not a soft-float comparison (the
 * same result, NaN included) */
static inline bool mzero(scalar_t x)
{
#if OCTO_FIXED || defined(__ARM_FP)
	return x == SC_ZERO;
#else
	union {
		float f;
		uint32_t u;
	} v = {x};
	return (v.u << 1) == 0u;
#endif
}

/* acc + sum_k a[k |sa|] b[k], k = 0..n-1 (sa < 0: acc - ...), a product at a time in that
 * order: the refinement's sums in one routine (the sign of the stride says which, so that
 * every argument is passed in a register but n) */
MIX_NOINLINE scalar_t mdot(scalar_t acc, const scalar_t *a, int sa, const scalar_t *b, int n)
{
	const bool sub = sa < 0;
	const int st = sub ? -sa : sa;
	for (int k = 0; k < n; k++) {
		scalar_t p = sc_mul(a[k * st], b[k]);
		acc = sub ? sca_sub(acc, p) : sca_add(p, acc);
	}
	return acc;
}

/* v[t] -= d q[t], t = 0..n-1: the Gram-Schmidt updates of the allocation, out of line in the
 * float builds (less flash), inline in the fixed build (its step would pay a call per row) */
#if OCTO_FIXED
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void
maxpy(scalar_t *v, scalar_t d, const scalar_t *q, int n)
#else
MIX_NOINLINE void maxpy(scalar_t *v, scalar_t d, const scalar_t *q, int n)
#endif
{
	for (int t = 0; t < n; t++)
		v[t] = sca_sub(v[t], sc_mul(d, q[t]));
}

static scalar_t dot4(const scalar_t a[NA], const scalar_t b[NA])
{
	scalar_t s = sc_mul(a[0], b[0]);
	s = sc_mac(a[1], b[1], s);
	s = sc_mac(a[2], b[2], s);
	return sc_mac(a[3], b[3], s);
}

/* dot4 inline on hard float: the step's allocation (pinv_alloc, the face, the fallback) */
MIX_HOT scalar_t dot4h(const scalar_t a[NA], const scalar_t b[NA])
{
	scalar_t s = sc_mul(a[0], b[0]);
	s = sc_mac(a[1], b[1], s);
	s = sc_mac(a[2], b[2], s);
	return sc_mac(a[3], b[3], s);
}

/* physical wrench component -> scaled space */
static scalar_t to_scaled(const struct mixer *m, int i, scalar_t v)
{
	return mdiv(sc_mul(sc_sub(v, m->w_lo[i]), m->row_div[i]), m->width);
}

/* g u for an entry g of the row-scaled Gamma S: the fixed build skips the product where g is
 * 0 or +-1 (most of eq. (14)'s entries), the same value (sc_mul(+-1, u) = +-u exactly);
 * inline there, as the test is what it saves */
#if OCTO_FIXED && defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline scalar_t
gmul(scalar_t g, scalar_t u)
{
#if OCTO_FIXED
	if (g == SC_ZERO)
		return SC_ZERO;
	if (g == SC(1))
		return u;
	if (g == -SC(1))
		return sc_neg(u);
#endif
	return sc_mul(g, u);
}

/* s / row_div[i] (row_div > 0 by the set-up): with an FPU the division instruction itself,
 * the same quotient as sc_div's for a nonzero divisor */
#if MIX_HARD_FLOAT
#define mdiv_row(a, b) ((a) / (b))
#else
#define mdiv_row(a, b) mdiv((a), (b))
#endif

/* the physical wrench of u (Gamma S u) */
static void wrench_u(const struct mixer *m, const scalar_t u[NR], scalar_t wrench[NA])
{
	scalar_t uu[NR]; /* in locals: the stores to wrench cannot change them */
	MIX_UNROLL
	for (int j = 0; j < NR; j++)
		uu[j] = u[j];
	MIX_UNROLL
	for (int i = 0; i < NA; i++) {
		scalar_t s = SC_ZERO;
		MIX_UNROLL
		for (int j = 0; j < NR; j++)
			s = sca_add(gmul(m->gn[i][j], uu[j]), s);
		wrench[i] = mdiv_row(s, m->row_div[i]);
	}
}

void mixer_wrench(const struct mixer *m, const scalar_t f_n[NR], scalar_t wrench[NA])
{
	scalar_t u[NR];
	for (int j = 0; j < NR; j++)
		u[j] = mdiv(f_n[j], m->p.scale[j]); /* x / 1 = x in both builds */
	wrench_u(m, u, wrench);
}

/* 1 / n[0] and 1 / n[3] of each facet (0 where |n| <= EPS_S: independent of that axis) for the
 * interval searches of one saturated allocation: formed once per saturated step (2 divisions
 * per facet, on its stack) rather than kept in the caller's struct mixer */
struct facet_recips {
	scalar_t inv[2][MIXER_MAX_FACETS]; /* [0] thrust, [1] yaw */
};

static void facet_recips(const struct mixer *m, struct facet_recips *rc)
{
	for (int k = 0; k < m->n_facets; k++)
		for (int a = 0; a < 2; a++) {
			scalar_t s = m->facet[k].n[a ? 3 : 0];
			rc->inv[a][k] = sc_abs(s) > EPS_S ? mdiv(SC(1), s) : SC_ZERO;
		}
}

/* The facet test with tolerance tol (scaled units; negative: an inner margin) and, with invs
 * (1 / n[ax] of each facet as facet_recips forms them), the interval iv = [lo, hi] of the
 * offset t along axis ax (0 thrust, 3 yaw), within the [l, h] given in iv, such that
 * w + t e_ax passes it; false if empty (iv untouched then). invs NULL: the test of w alone
 * (l <= h given). Works on t directly (not on t / demand) so that huge demands lose no
 * resolution. The interval in and out of one array: fewer arguments on the stack. */
static bool facet_scan(const struct mixer *m, const scalar_t w[NA], const scalar_t *invs, int ax, scalar_t tol,
		       scalar_t iv[2])
{
	scalar_t l = iv[0], h = iv[1];
	for (int k = 0; k < m->n_facets; k++) {
		const struct mixer_facet *fc = &m->facet[k];
		scalar_t q = sc_sub(dot4(fc->n, w), fc->nc);
		scalar_t s = fc->n[ax], inv = invs ? invs[k] : SC_ZERO, hw = sc_add(fc->h, tol);
		if (mzero(inv)) { /* |n_ax| <= EPS_S: independent of t */
			if (sc_abs(q) > hw)
				return false;
			continue;
		}
		/* -hw <= q + t s <= hw */
		scalar_t a = sc_mul(sc_sub(sc_neg(hw), q), inv), b = sc_mul(sc_sub(hw, q), inv);
		if (s < 0) {
			scalar_t t = a;
			a = b;
			b = t;
		}
		l = mmax(l, a);
		h = mmin(h, b);
		if (l > h)
			return false;
	}
	iv[0] = l;
	iv[1] = h;
	return l <= h;
}

MIX_NOINLINE bool attainable_scaled(const struct mixer *m, const scalar_t w[NA], scalar_t tol)
{
	scalar_t iv[2] = {SC_ZERO, SC_ZERO};
	return facet_scan(m, w, NULL, 0, tol, iv);
}

bool mixer_attainable(const struct mixer *m, const scalar_t wrench[NA], scalar_t tol)
{
	if (!m->alloc_ok)
		return false;
	scalar_t w[NA];
	for (int i = 0; i < NA; i++)
		w[i] = to_scaled(m, i, wrench[i]);
	return attainable_scaled(m, w, tol);
}

/* Interval iv of the scaled thrust w[0] such that w is attainable with the inner margin, other
 * components fixed. Returns false if empty. */
static bool thrust_interval(const struct mixer *m, const struct facet_recips *rc, const scalar_t w[NA], scalar_t iv[2])
{
	const scalar_t w0[NA] = {SC_ZERO, w[1], w[2], w[3]};
	iv[0] = SC_MAX_NEG;
	iv[1] = SC_MAX;
	return facet_scan(m, w0, rc->inv[0], 0, sc_neg(TOL_IN), iv);
}

/* With w[3] = the scaled zero yaw, the interval iv of yaw offsets t between 0 and dy (the
 * scaled demanded yaw offset) such that w + t e_3 is attainable with the inner margin;
 * false if empty. No yaw demanded: whether w itself is. */
static bool yaw_interval(const struct mixer *m, const struct facet_recips *rc, const scalar_t w[NA], scalar_t dy,
			 scalar_t iv[2])
{
	iv[0] = mmin(SC_ZERO, dy);
	iv[1] = mmax(SC_ZERO, dy);
	return facet_scan(m, w, mzero(dy) ? NULL : rc->inv[1], 3, sc_neg(TOL_IN), iv);
}

/* tighten [lo, hi] with the constraint -hw <= q - u s <= hw (u is the unknown) */
static void narrow(scalar_t q, scalar_t s, scalar_t hw, scalar_t *lo, scalar_t *hi)
{
	if (sc_abs(s) <= EPS_S)
		return;
	scalar_t a = mdiv(sc_sub(q, hw), s), b = mdiv(sc_add(q, hw), s);
	if (s < 0) {
		scalar_t t = a;
		a = b;
		b = t;
	}
	*lo = mmax(*lo, a);
	*hi = mmin(*hi, b);
}

/* Orthonormal basis (rows q[0..r-1], length nf) of the row space of G_F (the 4 rows of gn
 * restricted to the free rotors, bnd 0, which it lists in fr[0..*nf-1]) by modified
 * Gram-Schmidt; lt[k][m] = q_m . row_k, piv[m] = row that produced q_m. Returns r. */
static int row_basis(const struct mixer *m, const int8_t bnd[NR], int fr[NR], int *nfp, scalar_t q[NA][NR],
		     scalar_t lt[NA][NA], int piv[NA])
{
	int r = 0, nf = 0;
	for (int t = 0; t < m->n_active; t++)
		if (bnd[m->order[t]] == 0)
			fr[nf++] = m->order[t];
	*nfp = nf;
	for (int k = 0; k < NA; k++) {
		scalar_t v[NR];
		for (int t = 0; t < nf; t++)
			v[t] = m->gn[k][fr[t]];
		for (int i = 0; i < NA; i++)
			lt[k][i] = SC_ZERO;
		for (int pass = 0; pass < 2; pass++)
			for (int i = 0; i < r; i++) {
				scalar_t d = mdot(SC_ZERO, q[i], 1, v, nf);
				lt[k][i] = sc_add(lt[k][i], d);
				maxpy(v, d, q[i], nf);
			}
		scalar_t n2 = mdot(SC_ZERO, v, 1, v, nf);
		if (n2 <= EPS_GS)
			continue;
		scalar_t nrm = sc_sqrt(n2), inv = mdiv(SC(1), nrm);
		for (int t = 0; t < nf; t++)
			q[r][t] = sc_mul(v[t], inv);
		lt[k][r] = nrm;
		piv[r] = k;
		r++;
	}
	return r;
}

/* u clamped to the box [0, 1] of the scaled space */
static scalar_t clamp01(scalar_t u) { return mclamp(u, SC_ZERO, SC(1)); }

/* Active-set refinement (at most MIXER_QP_ITERS iterations) from the feasible u towards the
 * unique minimiser of |u - uref| subject to gn u = w, 0 <= u <= 1: every iterate stays in the
 * box and moves only in the null space of the free columns, so gn u = w is kept; a last
 * minimum-norm correction on the free rotors removes rounding drift. */
static int refine(const struct mixer *m, const scalar_t w[NA], const scalar_t uref[NR], scalar_t u[NR])
{
	const int na = m->n_active;
	int8_t bnd[NR]; /* 0 free, -1 at 0, +1 at 1 */
	for (int t = 0; t < na; t++) {
		int j = m->order[t];
		bnd[j] = u[j] <= SC_ZERO ? -1 : (u[j] >= SC(1) ? 1 : 0);
	}
	scalar_t q[NA][NR], lt[NA][NA];
	int piv[NA], fr[NR], nf, r, it = 0;
	for (;;) {
		/* the basis of the current face: also what the final correction uses when the
		 * loop ends here (at the optimum or after MIXER_QP_ITERS iterations) */
		r = row_basis(m, bnd, fr, &nf, q, lt, piv);
		if (it == MIXER_QP_ITERS)
			break;
		/* p = projection of (uref - u)_F onto null(G_F) */
		scalar_t p[NR], c[NA], pmax = SC_ZERO;
		for (int t = 0; t < nf; t++)
			p[t] = sc_sub(uref[fr[t]], u[fr[t]]);
		for (int i = 0; i < r; i++)
			c[i] = mdot(SC_ZERO, q[i], 1, p, nf);
		for (int i = 0; i < r; i++)
			maxpy(p, c[i], q[i], nf);
		for (int t = 0; t < nf; t++)
			pmax = mmax(pmax, sc_abs(p[t]));
		if (pmax > EPS_P) {
			scalar_t step = SC(1);
			int blk = -1;
			for (int t = 0; t < nf; t++) {
				scalar_t lim;
				if (p[t] < -EPS_P)
					lim = sc_neg(u[fr[t]]);
				else if (p[t] > EPS_P)
					lim = sc_sub(SC(1), u[fr[t]]);
				else
					continue;
				lim = mdiv(lim, p[t]);
				if (lim < step) {
					step = mmax(lim, SC_ZERO);
					blk = t;
				}
			}
			for (int t = 0; t < nf; t++)
				u[fr[t]] = clamp01(sc_add(u[fr[t]], sc_mul(step, p[t])));
			if (blk >= 0) {
				int j = fr[blk];
				bnd[j] = p[blk] < 0 ? -1 : 1;
				u[j] = bnd[j] < 0 ? SC_ZERO : SC(1);
			}
			it++;
			continue;
		}
		/* stationary on this face: multipliers lambda from G_F^T lambda = g_F (g = u - uref),
		 * i.e. L^T lambda = Q g_F = -c (c = Q (uref - u)_F from above, u unchanged since:
		 * the same values as summing Q g_F, in float up to the sign of a zero, which the
		 * test against EPS_MU > 0 below cannot see), back substitution over the basis rows */
		scalar_t lam[NA] = {SC_ZERO, SC_ZERO, SC_ZERO, SC_ZERO};
		/* (summed over every k: lam[k] is still 0 for k <= piv[i], as piv rises with i, and
		 * acc - x 0 is acc, in float up to the sign of a zero, which EPS_MU cannot see) */
		for (int i = r - 1; i >= 0; i--)
			lam[piv[i]] = mdiv(mdot(sc_neg(c[i]), &lt[0][i], -NA, lam, NA), lt[piv[i]][i]);
		int rel = -1;
		scalar_t worst = EPS_MU;
		for (int t = 0; t < na; t++) {
			int j = m->order[t];
			if (bnd[j] == 0)
				continue;
			scalar_t mu = mdot(sc_sub(u[j], uref[j]), &m->gn[0][j], -NR, lam, NA);
			scalar_t viol = bnd[j] < 0 ? sc_neg(mu) : mu;
			if (viol > worst) {
				worst = viol;
				rel = j;
			}
		}
		if (rel < 0)
			break; /* KKT point: the unique optimum */
		bnd[rel] = 0;
		it++;
	}
	/* minimum-norm correction of the residual on the free rotors: d = Q^T y, L y = w - gn u */
	scalar_t res[NA], y[NA];
	for (int k = 0; k < NA; k++) {
		res[k] = w[k];
		for (int t = 0; t < na; t++)
			res[k] = sc_sub(res[k], sc_mul(m->gn[k][m->order[t]], u[m->order[t]]));
	}
	for (int i = 0; i < r; i++) {
		y[i] = mdiv(mdot(res[piv[i]], lt[piv[i]], -1, y, i), lt[piv[i]][i]);
	}
	for (int t = 0; t < nf; t++) {
		u[fr[t]] = clamp01(sc_add(u[fr[t]], mdot(SC_ZERO, &q[0][t], NR, y, r)));
	}
	return it;
}

/* Exact preimage: u in [0,1]^8 with gn u = w (w attainable), see mixer.h step e. */
MIX_NOINLINE int preimage(const struct mixer *m, const scalar_t w[NA], scalar_t u[NR])
{
	scalar_t uref[NR], r[NA];
	for (int j = 0; j < NR; j++) {
		/* row j of the pseudo-inverse in the scaled space */
		scalar_t pn[NA];
		for (int i = 0; i < NA; i++)
			pn[i] = sc_mul(m->pinv[j][i], m->row_max[i]);
		uref[j] = dot4(pn, w);
		u[j] = SC_ZERO;
	}
	for (int i = 0; i < NA; i++)
		r[i] = w[i];
	const int na = m->n_active;
	int st;
	for (st = 0; st + 4 < na; st++) {
		int j = m->order[st];
		scalar_t g[NA] = {m->gn[0][j], m->gn[1][j], m->gn[2][j], m->gn[3][j]};
		scalar_t lo = SC_ZERO, hi = SC(1);
		/* the last step's rest is the invertible tail: u_tail = T r - u T g in [0, 1]^4,
		 * i.e. 0 <= tr - u tg <= 1 <=> -1/2 <= (tr - 1/2) - u tg <= 1/2 per row of T: the
		 * same constraint as a facet with normal T_c, n.c = 1/2, h = 1/2 */
		const bool tail = st + 5 == na;
		int cnt = tail ? 4 : m->sub_n[st];
		for (int k = 0; k < cnt; k++) {
			const scalar_t *n;
			scalar_t nc = SC(0.5), h = SC(0.5);
			if (tail) {
				n = m->tail_inv[k];
			} else {
				const struct mixer_facet *fc = &m->sub[m->sub_first[st] + k];
				n = fc->n;
				nc = fc->nc;
				h = fc->h;
			}
			narrow(sc_sub(dot4(n, r), nc), dot4(n, g), h, &lo, &hi);
		}
		scalar_t x;
		if (lo <= hi)
			x = mclamp(uref[j], lo, hi);
		else /* numerically empty: the nearest point of the two bounds */
			x = clamp01(sc_add(sc_mul(lo, SC(0.5)), sc_mul(hi, SC(0.5))));
		u[j] = x;
		maxpy(r, x, g, NA);
	}
	for (int c = 0; c < 4; c++)
		u[m->order[na - 4 + c]] = clamp01(dot4(m->tail_inv[c], r));

	/* move along the null space (u - uref) back towards the pseudo-inverse solution */
	scalar_t theta = SC_ZERO;
	for (int t = 0; t < na; t++) {
		int j = m->order[t];
		scalar_t d = sc_sub(u[j], uref[j]);
		const bool below = uref[j] < SC_ZERO && d > 0;
		if (below || (uref[j] > SC(1) && d < 0))
			theta = mmax(theta, mdiv(below ? sc_neg(uref[j]) : sc_sub(SC(1), uref[j]), d));
	}
	if (theta < SC(1)) {
		for (int t = 0; t < na; t++) {
			int j = m->order[t];
			scalar_t d = sc_sub(u[j], uref[j]);
			u[j] = clamp01(sc_add(uref[j], sc_mul(theta, d)));
		}
	}
	return st + refine(m, w, uref, u);
}

/* the limit flag of each axis of [f, tau_x, tau_y, tau_z] */
static const uint32_t axis_limit[NA] = {MIXER_LIMIT_F, MIXER_LIMIT_TX, MIXER_LIMIT_TY, MIXER_LIMIT_TZ};

/* w[1], w[2]: the scaled roll and pitch of a times the demanded ones */
MIX_NOINLINE void scaled_rp(const struct mixer *m, const scalar_t demand[NA], scalar_t a, scalar_t w[NA])
{
	w[1] = to_scaled(m, 1, sc_mul(a, demand[1]));
	w[2] = to_scaled(m, 2, sc_mul(a, demand[2]));
}

/* Steps 3a-d (mixer.h) for a demand whose pseudo-inverse allocation leaves the box: the
 * attainable target w (scaled space), the axis flags in *limp; returns the bisection steps,
 * or -1 when zero torque is unattainable (not a usable layout). Out of line, so that its
 * stack (the facet reciprocals) and preimage's are not held at the same time. */
MIX_NOINLINE int target(const struct mixer *m, const scalar_t demand[NA], scalar_t w[NA], uint32_t *limp)
{
	scalar_t wd[NA];
	for (int i = 0; i < NA; i++)
		w[i] = wd[i] = to_scaled(m, i, demand[i]);
	int steps = 0;
	uint32_t lim = 0;
	if (!attainable_scaled(m, wd, TOL_ATT)) {
		struct facet_recips rc;
		facet_recips(m, &rc);
		/* b. roll/pitch scale alpha with zero yaw, thrust free */
		scalar_t yaw0 = to_scaled(m, 3, SC_ZERO);
		scalar_t th[2], alpha = SC(1); /* the thrust interval */
		w[3] = yaw0;
		if (!thrust_interval(m, &rc, w, th)) {
			scalar_t a_lo = SC_ZERO, a_hi = SC(1);
			scaled_rp(m, demand, a_lo, w);
			if (!thrust_interval(m, &rc, w, th))
				return -1;
			for (int it = 0; it < MIXER_ALPHA_ITERS; it++) {
				scalar_t mid = sc_mul(sc_add(a_lo, a_hi), SC(0.5));
				scalar_t iv[2];
				scaled_rp(m, demand, mid, w);
				if (thrust_interval(m, &rc, w, iv))
					a_lo = mid;
				else
					a_hi = mid;
				steps++;
			}
			alpha = a_lo;
			scaled_rp(m, demand, alpha, w);
			thrust_interval(m, &rc, w, th);
			if (!mzero(demand[1]))
				lim |= MIXER_LIMIT_TX;
			if (!mzero(demand[2]))
				lim |= MIXER_LIMIT_TY;
		}
		/* c. thrust nearest to the demand for which some yaw beta tau_z, beta in [0, 1],
		 * is attainable: exact when the demanded thrust itself or the zero-yaw slice
		 * allows it, else MIXER_ALPHA_ITERS bisection steps towards the demand */
		scalar_t dy = sc_sub(wd[3], yaw0), dy_dem = dy, yb[2];
		w[0] = mclamp(wd[0], th[0], th[1]); /* attainable with beta = 0 */
		if (alpha < SC(1)) {
			/* roll/pitch saturated: no room is left for yaw; thrust from the zero-yaw slice */
			dy = SC_ZERO;
			if (w[0] != wd[0])
				lim |= MIXER_LIMIT_F;
		} else if (w[0] != wd[0]) {
			scalar_t ok_f = w[0];
			w[0] = wd[0];
			if (!yaw_interval(m, &rc, w, dy, yb)) {
				scalar_t bad_f = wd[0];
				for (int it = 0; it < MIXER_ALPHA_ITERS; it++) {
					w[0] = sc_add(sc_mul(ok_f, SC(0.5)), sc_mul(bad_f, SC(0.5)));
					if (yaw_interval(m, &rc, w, dy, yb))
						ok_f = w[0];
					else
						bad_f = w[0];
					steps++;
				}
				w[0] = ok_f;
				lim |= MIXER_LIMIT_F;
			}
		}
		/* d. yaw: the largest part of the demanded yaw attainable at that thrust (between
		 * zero and the demand: no yaw reversal) */
		scalar_t ty = SC_ZERO;
		if (!mzero(dy) && yaw_interval(m, &rc, w, dy, yb))
			ty = dy > 0 ? yb[1] : yb[0];
		if (ty != dy_dem && !mzero(demand[3]))
			lim |= MIXER_LIMIT_TZ;
		w[3] = sc_add(yaw0, ty);
	}
	*limp = lim;
	return steps;
}

/* Steps 3a-e: the rotors' u (N) in out->f_n, the axis flags in out->limits, out->steps.
 * False (out untouched) when zero torque is unattainable: the caller clips. */
static bool priority(const struct mixer *m, const scalar_t demand[NA], struct mixer_output *out)
{
	scalar_t w[NA];
	uint32_t lim;
	int steps = target(m, demand, w, &lim);
	if (steps < 0)
		return false;
	/* e. */
	scalar_t u[NR];
	steps += preimage(m, w, u);
	for (int j = 0; j < NR; j++)
		out->f_n[j] = (m->present & (1u << j)) ? sc_add(m->f_lo, sc_mul(u[j], m->width)) : SC_ZERO;
	out->limits |= lim;
	out->steps = (uint8_t)steps;
	return true;
}

#if OCTO_FIXED
/* The products pinv[j][i] demand[i] of eq. (15). sc_mul is odd in each argument (it rounds
 * the magnitude), so rotors whose entry in column i has the same magnitude share one
 * product up to its sign: a symmetric layout such as eq. (14) has one or two magnitudes per
 * column. Each column keeps its last two magnitudes and their products. */
static void pinv_products(const struct mixer *m, const scalar_t demand[NA], scalar_t pin[NR][NA])
{
	for (int i = 0; i < NA; i++) {
		scalar_t mag[2] = {SC_ZERO, SC_ZERO}, prod[2] = {SC_ZERO, SC_ZERO};
		for (int j = 0; j < NR; j++) {
			scalar_t p = m->pinv[j][i], a = p < 0 ? -p : p, t; /* p > INT32_MIN */
			if (a == mag[0]) {
				t = prod[0];
			} else if (a == mag[1]) {
				t = prod[1];
			} else {
				t = sc_mul(a, demand[i]);
				mag[1] = mag[0];
				prod[1] = prod[0];
				mag[0] = a;
				prod[0] = t;
			}
			pin[j][i] = p < 0 ? sc_neg(t) : t;
		}
	}
}
#endif

/* 1. eq. (15) into out->f_n (u, N); out->demanded, limits and steps set. Returns 0 for a
 * non-finite demand (every rotor 0, flagged), 1 when u is in the box, 2 when it is not. */
static int pinv_alloc(const struct mixer *m, const scalar_t demand[NA], struct mixer_output *out)
{
	out->limits = 0;
	out->steps = 0;
	bool finite = true;
	/* the demand in locals: the stores to out cannot change them */
	const scalar_t d[NA] = {demand[0], demand[1], demand[2], demand[3]};
	MIX_UNROLL
	for (int i = 0; i < NA; i++) {
		out->demanded[i] = d[i];
		finite = finite && sc_isfinite(d[i]);
	}
	if (!finite) {
		MIX_UNROLL
		for (int j = 0; j < NR; j++)
			out->f_n[j] = SC_ZERO;
		out->limits = MIXER_LIMIT_BAD_INPUT;
		return 0;
	}
	bool inside = true;
#if OCTO_FIXED
	scalar_t pin[NR][NA];
	pinv_products(m, d, pin);
#endif
	const scalar_t lo = m->f_lo, hi = m->f_hi;
	const unsigned present = m->present;
	MIX_UNROLL
	for (int j = 0; j < NR; j++) {
#if OCTO_FIXED
		scalar_t f = pin[j][0];
		for (int i = 1; i < NA; i++)
			f = sc_add(pin[j][i], f);
#else
		scalar_t f = dot4h(m->pinv[j], d);
#endif
		if (!(present & (1u << j)))
			f = SC_ZERO;
		else if (f < lo || f > hi)
			inside = false;
		out->f_n[j] = f;
	}
	return inside ? 1 : 2;
}

/* every present rotor's u (N) clamped to the box */
static void clip_box(const struct mixer *m, scalar_t f_n[NR])
{
	const scalar_t lo = m->f_lo, hi = m->f_hi;
	const unsigned present = m->present;
	MIX_UNROLL
	for (int j = 0; j < NR; j++)
		if (present & (1u << j))
			f_n[j] = mclamp(f_n[j], lo, hi);
}

/* out->f_n holds u: the achieved wrench and the bound flags from it, then f_j = scale_j u_j;
 * cmp: the axis flags from comparing achieved and demanded (clipping, mixer_step) */
static void finish(const struct mixer *m, struct mixer_output *out, bool cmp)
{
	wrench_u(m, out->f_n, out->achieved);
	unsigned at_min = 0, at_max = 0;
	/* a rotor within 4 inner margins of a bound counts as at the bound */
	const scalar_t at_tol = sc_mul(m->width, 4 * TOL_IN);
	const scalar_t at_lo = sc_add(m->f_lo, at_tol), at_hi = sc_sub(m->f_hi, at_tol);
	const unsigned present = m->present;
	MIX_UNROLL
	for (int j = 0; j < NR; j++) {
		const scalar_t u = out->f_n[j];
		if (present & (1u << j)) {
			if (u <= at_lo)
				at_min |= 1u << j;
			if (u >= at_hi)
				at_max |= 1u << j;
		}
		out->f_n[j] = gmul(m->p.scale[j], u);
	}
	out->rotor_at_min = (uint8_t)at_min;
	out->rotor_at_max = (uint8_t)at_max;
	if (at_min)
		out->limits |= MIXER_LIMIT_ROTOR_MIN;
	if (at_max)
		out->limits |= MIXER_LIMIT_ROTOR_MAX;
	/* flags of axes whose achieved value differs from the demand by more than the margin
	 * times the physical wrench per unit of scaled wrench */
	if (!cmp)
		return;
	MIX_UNROLL
	for (int i = 0; i < NA; i++) {
		scalar_t tol = sc_mul(sc_mul(m->width, m->row_max[i]), TOL_FLAG_REL);
		if (sc_abs(sc_sub(out->achieved[i], out->demanded[i])) > tol)
			out->limits |= axis_limit[i];
	}
}

void mixer_update(const struct mixer *m, const scalar_t demand[NA], struct mixer_output *out)
{
	bool clip = false;
	if (pinv_alloc(m, demand, out) == 2) {
		/* 3. by mode; PRIORITY with the allocator unavailable (or unusable) clips */
		clip = m->p.mode != MIXER_MODE_PRIORITY;
		if (!clip && !(m->alloc_ok && priority(m, demand, out))) {
			out->limits |= MIXER_LIMIT_NO_ALLOC;
			clip = true;
		}
		if (clip)
			clip_box(m, out->f_n);
	}
	finish(m, out, clip);
}

/* ---------------------------------------------------------------- frame-budgeted allocation */

void mixer_warm_reset(struct mixer_warm *s)
{
	s->valid = false;
	s->pending = false;
	s->held = 0;
	s->path = MIXER_PATH_PINV;
}

/* a / b for b known nonzero: with an FPU the division instruction itself (sc_div only adds
 * the zero test), else mdiv */
#if !OCTO_FIXED && defined(__ARM_FP)
#define mdiv_nz(a, b) ((a) / (b))
#else
#define mdiv_nz(a, b) mdiv((a), (b))
#endif

/* The s nearest to s0 within [lo, hi] such that u + s c keeps every present rotor in the box
 * widened by slack (N; one inner margin: the caller clips the rounding; its negative: an
 * inner margin); false if there is none. One division per rotor. */
static bool line_fit(const struct mixer *m, const scalar_t u[NR], const scalar_t c[NR], scalar_t lo, scalar_t hi,
		     scalar_t s0, scalar_t slack, scalar_t *s)
{
	const scalar_t blo = sc_sub(m->f_lo, slack), bhi = sc_add(m->f_hi, slack);
	MIX_UNROLL
	for (int j = 0; j < NR; j++) {
		if (!(m->present & (1u << j)))
			continue;
		if (sc_abs(c[j]) <= EPS_S) { /* the rotor does not move along c */
			if (u[j] < blo || u[j] > bhi)
				return false;
			continue;
		}
		scalar_t a = mdiv_nz(sc_sub(blo, u[j]), c[j]), b = mdiv_nz(sc_sub(bhi, u[j]), c[j]);
		if (c[j] < 0) {
			scalar_t t = a;
			a = b;
			b = t;
		}
		lo = mmax(lo, a);
		hi = mmin(hi, b);
	}
	if (lo > hi)
		return false;
	*s = mclamp(s0, lo, hi);
	return true;
}

/* line_fit along column ax (k 0: thrust, ax 0; k 1: yaw, ax 3) of the pseudo-inverse, its
 * rotors sorted at the set-up (col_up, col_dn, col_fix): the same quotients and bounds in
 * the same order, without the column's copy and its per-rotor tests */
static bool line_fit_col(const struct mixer *m, const scalar_t u[NR], int k, scalar_t lo, scalar_t hi, scalar_t s0,
			 scalar_t slack, scalar_t *s)
{
	const int ax = k ? 3 : 0;
	const unsigned up = m->col_up[k], dn = m->col_dn[k], fix = m->col_fix[k];
	const scalar_t blo = sc_sub(m->f_lo, slack), bhi = sc_add(m->f_hi, slack);
	MIX_UNROLL
	for (int j = 0; j < NR; j++) {
		const unsigned bit = 1u << j;
		if (up & bit) {
			const scalar_t c = m->pinv[j][ax];
			lo = mmax(lo, mdiv_nz(sc_sub(blo, u[j]), c));
			hi = mmin(hi, mdiv_nz(sc_sub(bhi, u[j]), c));
		} else if (dn & bit) {
			const scalar_t c = m->pinv[j][ax];
			lo = mmax(lo, mdiv_nz(sc_sub(bhi, u[j]), c));
			hi = mmin(hi, mdiv_nz(sc_sub(blo, u[j]), c));
		} else if ((fix & bit) && (u[j] < blo || u[j] > bhi)) {
			return false;
		}
	}
	if (lo > hi)
		return false;
	*s = mclamp(s0, lo, hi);
	return true;
}

/* u += s (column ax of the pseudo-inverse) on the present rotors */
static void line_move_col(const struct mixer *m, scalar_t u[NR], int ax, scalar_t s)
{
	const unsigned present = m->present;
	MIX_UNROLL
	for (int j = 0; j < NR; j++)
		if (present & (1u << j))
			u[j] = sc_mac(s, m->pinv[j][ax], u[j]);
}

/* u += s c */
static void line_move(scalar_t u[NR], const scalar_t c[NR], scalar_t s)
{
	MIX_UNROLL
	for (int j = 0; j < NR; j++)
		u[j] = sc_mac(s, c[j], u[j]);
}

/* c = column ax of the pseudo-inverse times v (0 for absent rotors): the u change of v on
 * that axis alone */
static void pinv_col(const struct mixer *m, int ax, scalar_t v, scalar_t c[NR])
{
	MIX_UNROLL
	for (int j = 0; j < NR; j++)
		c[j] = (m->present & (1u << j)) ? sc_mul(m->pinv[j][ax], v) : SC_ZERO;
}

/* The bounded fallback (u, N, written), with the priority roll/pitch > thrust > yaw along
 * the pseudo-inverse's axis columns: the demand without yaw, the thrust change nearest to none
 * that fits, then as much of the demanded yaw as fits (never of the opposite sign). When no
 * thrust fits the roll/pitch: without roll/pitch the nearest thrust that fits, then the
 * largest share of the demanded roll/pitch that fits there, no yaw. The demand is first
 * limited to 16 times the attainable set's extent per axis (huge demands lose no resolution
 * to cancellation). Returns the path (MIXER_PATH_FALLBACK or _FALLBACK_RP). */
static int fallback(const struct mixer *m, const scalar_t demand[NA], scalar_t u[NR])
{
	scalar_t dm[NA], c[NR], s;
	MIX_UNROLL
	for (int i = 0; i < NA; i++) {
		scalar_t ext = sc_mul(sc_mul(m->width, m->row_max[i]), SC(16));
		dm[i] = mclamp(demand[i], sc_sub(m->w_lo[i], ext), sc_add(m->w_lo[i], ext));
	}
	const scalar_t dy = dm[3], slack = sc_mul(m->width, TOL_IN);
	dm[3] = SC_ZERO;
	MIX_UNROLL
	for (int j = 0; j < NR; j++)
		u[j] = (m->present & (1u << j)) ? dot4h(m->pinv[j], dm) : SC_ZERO;
	if (line_fit_col(m, u, 0, SC_MAX_NEG, SC_MAX, SC_ZERO, slack, &s)) {
		line_move_col(m, u, 0, s);
		if (line_fit_col(m, u, 1, mmin(SC_ZERO, dy), mmax(SC_ZERO, dy), dy, slack, &s))
			line_move_col(m, u, 3, s);
		clip_box(m, u);
		return MIXER_PATH_FALLBACK;
	}
	/* c: the roll/pitch part of u; u: the thrust alone */
	pinv_col(m, 1, dm[1], c);
	const unsigned present = m->present;
	MIX_UNROLL
	for (int j = 0; j < NR; j++) {
		const bool on = (present & (1u << j)) != 0;
		c[j] = on ? sc_mac(m->pinv[j][2], dm[2], c[j]) : SC_ZERO;
		u[j] = sc_mul(on ? m->pinv[j][0] : SC_ZERO, dm[0]);
	}
	if (line_fit_col(m, u, 0, SC_MAX_NEG, SC_MAX, SC_ZERO, slack, &s)) {
		line_move_col(m, u, 0, s);
		/* within an inner margin: nothing left for the clip to unbalance */
		if (line_fit(m, u, c, SC_ZERO, SC(1), SC(1), sc_neg(slack), &s))
			line_move(u, c, s);
	}
	clip_box(m, u);
	return MIXER_PATH_FALLBACK_RP;
}

void mixer_step(const struct mixer *m, struct mixer_warm *s, const scalar_t demand[NA], struct mixer_output *out)
{
	int r = pinv_alloc(m, demand, out);
	s->pending = false;
	s->path = MIXER_PATH_PINV;
	if (r != 2) {
		/* in the box (or not finite): the exact allocation itself; a face found for an
		 * earlier saturation is stale from here on */
		s->valid = false;
		finish(m, out, false);
		return;
	}
	if (m->p.mode != MIXER_MODE_PRIORITY || !m->alloc_ok) {
		if (m->p.mode == MIXER_MODE_PRIORITY)
			out->limits |= MIXER_LIMIT_NO_ALLOC;
		s->path = MIXER_PATH_CLIP;
		clip_box(m, out->f_n);
		finish(m, out, true);
		return;
	}
	MIX_UNROLL
	for (int i = 0; i < NA; i++)
		s->demand[i] = demand[i];
	s->pending = true;
	if (s->valid) {
		/* the exact allocation's face moved to this demand: axes it could not meet held
		 * at what it achieved (yaw between zero and the demand), the others as demanded */
		scalar_t d[NA], u[NR];
		MIX_UNROLL
		for (int i = 0; i < NA; i++) {
			scalar_t t = (((unsigned)s->held >> (unsigned)i) & 1u) ? s->t_ex[i] : demand[i];
			if (i == 3)
				t = mclamp(t, mmin(SC_ZERO, demand[3]), mmax(SC_ZERO, demand[3]));
			d[i] = sc_sub(t, s->t_ex[i]);
		}
		const scalar_t slack = sc_mul(m->width, TOL_IN);
		const scalar_t blo = sc_sub(m->f_lo, slack), bhi = sc_add(m->f_hi, slack);
		/* a face whose free columns do not span the wrench moves nothing exactly */
		bool fits = true;
		if (!s->full) {
			MIX_UNROLL
			for (int i = 0; i < NA; i++) /* within the flags' margin of its own wrench */
				fits = fits && sc_abs(d[i]) <= sc_mul(sc_mul(m->width, m->row_max[i]), TOL_FLAG_REL);
		}
		MIX_UNROLL
		for (int j = 0; j < NR; j++) {
			u[j] = sc_add(s->u_ex[j], dot4h(s->map[j], d));
			fits = fits && u[j] >= blo && u[j] <= bhi;
		}
		if (fits) {
			MIX_UNROLL
			for (int j = 0; j < NR; j++)
				out->f_n[j] = u[j];
			clip_box(m, out->f_n);
			s->path = MIXER_PATH_FACE;
			finish(m, out, true);
			return;
		}
	}
	s->path = (uint8_t)fallback(m, demand, out->f_n);
	out->steps = s->path == MIXER_PATH_FALLBACK ? 2 : 3;
	finish(m, out, true);
}

void mixer_refresh(const struct mixer *m, struct mixer_warm *s)
{
	if (!s->pending)
		return;
	s->pending = false;
	s->valid = false;
	scalar_t w[NA], u[NR];
	uint32_t lim;
	if (!m->alloc_ok || m->p.mode != MIXER_MODE_PRIORITY || target(m, s->demand, w, &lim) < 0)
		return;
	preimage(m, w, u);
	/* its face: the rotors within an inner margin of a bound stay there, the others move by
	 * the minimum-norm solution of the free columns, G_F^+ (basis q, lt, piv as refine's) */
	int8_t bnd[NR];
	for (int j = 0; j < NR; j++)
		bnd[j] = u[j] <= TOL_IN ? -1 : (u[j] >= sc_sub(SC(1), TOL_IN) ? 1 : 0);
	scalar_t q[NA][NR], lt[NA][NA];
	int piv[NA], fr[NR], nf;
	int r = row_basis(m, bnd, fr, &nf, q, lt, piv);
	for (int j = 0; j < NR; j++)
		for (int a = 0; a < NA; a++)
			s->map[j][a] = SC_ZERO;
	for (int a = 0; a < NA; a++) {
		/* column a: L y = e_a (scaled), du_F = Q^T y; per physical unit: times row_div[a]
		 * (scaled wrench per physical is row_div / width, u in N is width times scaled) */
		scalar_t y[NA];
		for (int i = 0; i < r; i++) {
			scalar_t e = piv[i] == a ? SC(1) : SC_ZERO;
			y[i] = mdiv(mdot(e, lt[piv[i]], -1, y, i), lt[piv[i]][i]);
		}
		for (int t = 0; t < nf; t++)
			s->map[fr[t]][a] = sc_mul(mdot(SC_ZERO, &q[0][t], NR, y, r), m->row_div[a]);
	}
	for (int j = 0; j < NR; j++)
		s->u_ex[j] = (m->present & (1u << j)) ? sc_add(m->f_lo, sc_mul(clamp01(u[j]), m->width)) : SC_ZERO;
	wrench_u(m, s->u_ex, s->t_ex);
	unsigned held = 0;
	for (int i = 0; i < NA; i++)
		if (lim & axis_limit[i])
			held |= 1u << i;
	s->held = (uint8_t)held;
	s->full = r == NA;
	s->valid = true;
}

void mixer_shortfall(const struct mixer_output *out, uint8_t *short_pos, uint8_t *short_neg)
{
	unsigned pos = 0, neg = 0;
	for (unsigned k = 0; k < NA; k++) {
		if (!(out->limits & axis_limit[k]))
			continue;
		if (out->achieved[k] < out->demanded[k])
			pos |= 1u << k;
		else if (out->achieved[k] > out->demanded[k])
			neg |= 1u << k;
	}
	*short_pos = (uint8_t)pos;
	*short_neg = (uint8_t)neg;
}
