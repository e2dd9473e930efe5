/* mixer_setup.c - the mixer's set-up, in float32 at a parameter change (not in the 90 Hz
 * step): Gamma_o from the geometry, its pseudo-inverse by a QR of its rows, the facets of the
 * attainable set; see mixer.h. The allocation that uses them is mixer.c. */
#include "mixer.h"
#include "fbits.h"

#include "mixer_tol.h"

#define NR MIXER_N_ROTORS
#define NA MIXER_N_AXES

/* ================================================================ set-up (float32) */

/* |x|: the sign bit cleared (no soft-float compare on cores without FPU) */
static float absf(float x) { return fabsf(x); }

/* sum_k a[k sa] b[k sb], k = 0..n-1, in that order: one routine for the set-up's dot
 * products (each inline loop is a few soft-float calls more on cores without FPU) */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
static float
dotf(const float *a, int sa, const float *b, int sb, int n)
{
	float acc = 0.0f;
	for (int k = 0; k < n; k++)
		acc += a[k * sa] * b[k * sb];
	return acc;
}

/* Gram-Schmidt step: x (length 8) minus its projection on the orthonormal columns 0..nb-1 of
 * q, twice (the second pass removes what rounding left); c[k] = the coefficient taken off
 * along column k. Returns |x|^2 after. */
static float ortho(const float q[NR][NR], int nb, float x[NR], float c[NR])
{
	for (int k = 0; k < nb; k++)
		c[k] = 0.0f;
	for (int pass = 0; pass < 2; pass++)
		for (int k = 0; k < nb; k++) {
			float d = dotf(&q[0][k], NR, x, 1, NR);
			c[k] += d;
			for (int j = 0; j < NR; j++)
				x[j] -= d * q[j][k];
		}
	return dotf(x, 1, x, 1, NR);
}

/* Inverse of a 4x4 matrix by Gauss-Jordan with partial pivoting; returns |det|. */
static float inv4(const float m[4][4], float out[4][4])
{
	float a[4][8];
	for (int i = 0; i < 4; i++) {
		for (int j = 0; j < 4; j++) {
			a[i][j] = m[i][j];
			a[i][4 + j] = 0.0f;
		}
		a[i][4 + i] = 1.0f;
	}
	float det = 1.0f;
	for (int c = 0; c < 4; c++) {
		int piv = c;
		for (int r = c + 1; r < 4; r++)
			if (absf(a[r][c]) > absf(a[piv][c]))
				piv = r;
		if (fb_abs_bits(a[piv][c]) == 0u) /* +-0 */
			return 0.0f;
		for (int j = 0; j < 8; j++) { /* rows c and piv swapped (nothing when the same) */
			float t = a[c][j];
			a[c][j] = a[piv][j];
			a[piv][j] = t;
		}
		float pv = a[c][c];
		det *= pv;
		for (int j = 0; j < 8; j++)
			a[c][j] /= pv;
		for (int r = 0; r < 4; r++) {
			if (r == c)
				continue;
			float f = a[r][c];
			for (int j = 0; j < 8; j++)
				a[r][j] -= f * a[c][j];
		}
	}
	for (int i = 0; i < 4; i++)
		for (int j = 0; j < 4; j++)
			out[i][j] = a[i][4 + j];
	return absf(det);
}

/* unit normal to three 4-vectors, columns a, b, c of g (generalised cross product: n_k is
 * (-1)^k times the 3x3 minor without component k, expanded along a's components over the
 * 2x2 minors of b and c); false if they are dependent */
static bool normal3(const float g[NA][NR], int a, int b, int c, float n[NA])
{
	float mnr[NA][NA]; /* mnr[x][y], x < y: b_x c_y - b_y c_x */
	for (int x = 0; x < NA; x++)
		for (int y = x + 1; y < NA; y++)
			mnr[x][y] = g[x][b] * g[y][c] - g[y][b] * g[x][c];
	for (int k = 0; k < NA; k++) {
		int col[3], m = 0;
		for (int j = 0; j < NA; j++)
			if (j != k)
				col[m++] = j;
		const int x = col[0], y = col[1], z = col[2];
		float d = g[x][a] * mnr[y][z] - g[y][a] * mnr[x][z] + g[z][a] * mnr[x][y];
		n[k] = (k & 1) ? -d : d;
	}
	float nn = dotf(n, 1, n, 1, NA);
	/* generators have entries in [-1, 1]: a normal below 1e-4 means (near) dependence */
	if (nn < 1e-8f)
		return false;
	float inv = 1.0f / sqrtf(nn);
	for (int k = 0; k < NA; k++)
		n[k] *= inv;
	return true;
}

/* Facets of the zonotope of the generators set[0..cnt-1] (scaled space), written to out:
 * one per distinct normal (triples spanning the same hyperplane give one facet). Returns the
 * count, or -1 if more than cap distinct facets exist. */
static int facets_of(const float g[NA][NR], const uint8_t *set, int cnt, struct mixer_facet *out, int cap)
{
	int nf = 0;
	float seen[MIXER_MAX_SUB_FACETS > MIXER_MAX_FACETS ? MIXER_MAX_SUB_FACETS : MIXER_MAX_FACETS][NA];
	for (int a = 0; a < cnt; a++)
		for (int b = a + 1; b < cnt; b++)
			for (int c = b + 1; c < cnt; c++) {
				float n[NA];
				if (!normal3(g, set[a], set[b], set[c], n))
					continue;
				bool dup = false;
				for (int k = 0; k < 2 * nf && !dup; k++) { /* n = +-seen[k / 2] */
					float dmax = 0.0f;
					for (int i = 0; i < NA; i++) {
						float e = absf((k & 1) ? n[i] + seen[k / 2][i] : n[i] - seen[k / 2][i]);
						dmax = e > dmax ? e : dmax;
					}
					dup = dmax < 1e-4f;
				}
				if (dup)
					continue;
				if (nf >= cap)
					return -1;
				float nc = 0.0f, h = 0.0f;
				for (int t = 0; t < cnt; t++) {
					float d = dotf(n, 1, &g[0][set[t]], NR, NA);
					nc += 0.5f * d;
					h += 0.5f * absf(d);
				}
				for (int i = 0; i < NA; i++) {
					seen[nf][i] = n[i];
					out[nf].n[i] = sc_from_float(n[i]);
				}
				out[nf].nc = sc_from_float(nc);
				out[nf].h = sc_from_float(h);
				nf++;
			}
	return nf;
}

void mixer_default_params(struct mixer_params *p)
{
	unsigned char *raw = (unsigned char *)p; /* scale[] 0 (not given), padding too */
	for (size_t k = 0; k < sizeof *p; k++)
		raw[k] = 0;
	p->arm_l_m = SC(0.35);
	p->k_f_n = SC(28.0269);
	p->k_tau_nm = SC(0.3869);
	p->t_min = SC(0);
	p->t_max = SC(1);
	p->rotor_mask = 0xFF;
	p->mode = MIXER_MODE_PRIORITY;
	p->custom_gamma = NULL;
}

/* an effectiveness as used: 0 (not given) is 1, others clamped to [0.1, 4]; out of line
 * (three callers): less flash */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
static scalar_t
scale_used(scalar_t s)
{
	return s == SC_ZERO ? SC(1) : sc_clamp(s, SC(0.1), SC(4));
}

static float scale_of(const struct mixer_params *p, int j) { return sc_to_float(scale_used(p->scale[j])); }

static void build_gamma(struct mixer_design *m, const struct mixer_params *p)
{
	if (p->custom_gamma) {
		for (int i = 0; i < NA; i++)
			for (int j = 0; j < NR; j++)
				m->gamma_f[i][j] = p->custom_gamma[i * NR + j];
	} else {
		const float s = 0.70710678f;
		float l = sc_to_float(p->arm_l_m);
		float kf = sc_to_float(p->k_f_n);
		float k = fb_pos(kf) ? sc_to_float(p->k_tau_nm) / kf : 0.0f;
		/* sign of tau_x per rotor; tau_y's is the same two rotors on */
		static const signed char sx[NR] = {0, -1, -1, -1, 0, 1, 1, 1};
		for (int j = 0; j < NR; j++) {
			float diag = (j & 1) ? s : 1.0f; /* even-numbered rotors 2,4,6,8 at 45 deg */
			m->gamma_f[0][j] = 1.0f;
			m->gamma_f[1][j] = (float)sx[j] * diag * l;
			m->gamma_f[2][j] = (float)sx[(j + 2) % NR] * diag * l;
			m->gamma_f[3][j] = (j & 1) ? -k : k;
		}
	}
	/* effectiveness: columns scaled (the allocation's variable is u_j = f_j / scale_j); a
	 * removed rotor (or a NaN thrust entry) is a zero column, other non-finite entries 0 */
	for (int j = 0; j < NR; j++) {
		float sj = scale_of(p, j);
		for (int i = 0; i < NA; i++)
			m->gamma_f[i][j] *= sj;
		bool gone = !(p->rotor_mask & (1u << j)) || fb_abs_bits(m->gamma_f[0][j]) > 0x7f800000u;
		for (int i = 0; i < NA; i++)
			if (gone || fb_abs_bits(m->gamma_f[i][j]) >= 0x7f800000u)
				m->gamma_f[i][j] = 0.0f;
	}
}

bool mixer_init(struct mixer *m, const struct mixer_params *p)
{
	struct mixer_design d; /* scratch, dropped on return */
	return mixer_init_design(m, p, &d);
}

/* The pseudo-inverse from the Gram-Schmidt QR of Gamma's rows: Gamma = R^T Q^T with Q
 * (8 x rank) orthonormal (the row space, columns 0..rank-1 of basis) and R (rank x 4), so
 * that Gamma^+ = Q (R^T)^+ = Q (R R^T)^-1 R. A row whose remainder after the earlier ones
 * is below 1e-5 of its own length adds nothing to the rank. Returns the rank. */
static int pseudo_inverse(struct mixer_design *dz, float basis[NR][NR])
{
	float r[NA][NA] = {{0}}, x[NR], cf[NR];
	int rank = 0;
	for (int i = 0; i < NA; i++) {
		for (int j = 0; j < NR; j++)
			x[j] = dz->gamma_f[i][j];
		float n0 = dotf(x, 1, x, 1, NR);
		float n2 = ortho(basis, rank, x, cf);
		for (int k = 0; k < rank; k++)
			r[k][i] = cf[k];
		if (n2 > 1e-10f * n0) {
			float n = sqrtf(n2);
			for (int j = 0; j < NR; j++)
				basis[j][rank] = x[j] / n;
			r[rank++][i] = n;
		}
	}
	float g[NA][NA], gi[NA][NA]; /* R R^T, completed by the identity beyond the rank */
	for (int k = 0; k < NA; k++)
		for (int l = 0; l < NA; l++)
			g[k][l] = dotf(r[k], 1, r[l], 1, NA);
	for (int k = rank; k < NA; k++) /* rows beyond the rank are 0: their diagonal 0 + 1 */
		g[k][k] = 1.0f;
	inv4(g, gi);
	for (int j = 0; j < NR; j++)
		for (int i = 0; i < NA; i++) {
			float acc = 0.0f;
			for (int k = 0; k < rank; k++)
				for (int l = 0; l < rank; l++)
					acc += basis[j][k] * gi[k][l] * r[l][i];
			dz->pinv_f[j][i] = acc;
		}
	return rank;
}

/* Two Newton-Schulz steps P <- 2P - P Gamma P (converge to the Moore-Penrose inverse, also
 * when rank-deficient) polish the float32 result. */
static void polish_pinv(struct mixer_design *dz)
{
	for (int it = 0; it < 2; it++) {
		float e[NA][NA]; /* I - Gamma P */
		for (int i = 0; i < NA; i++)
			for (int k = 0; k < NA; k++)
				e[i][k] = (i == k ? 1.0f : 0.0f) - dotf(dz->gamma_f[i], 1, &dz->pinv_f[0][k], NA, NR);
		for (int j = 0; j < NR; j++) { /* row j of P + P (I - Gamma P) reads only row j of P */
			float np[NA];
			for (int k = 0; k < NA; k++)
				np[k] = dz->pinv_f[j][k] + dotf(dz->pinv_f[j], 1, &e[0][k], NA, NA);
			for (int k = 0; k < NA; k++)
				dz->pinv_f[j][k] = np[k];
		}
	}
}

/* The null space: the row space of Gamma (basis 0..rank-1) completed with unit vectors,
 * Gram-Schmidt, the one with the largest remainder first. */
static void null_space(struct mixer_design *dz, float basis[NR][NR], int rank)
{
	float x[NR], cf[NR];
	int nb = rank;
	while (nb < NR) {
		float best[NR] = {0}, bestn = -1.0f;
		for (int e = 0; e < NR; e++) {
			for (int j = 0; j < NR; j++)
				x[j] = j == e ? 1.0f : 0.0f;
			float n2 = ortho(basis, nb, x, cf);
			if (n2 > bestn) {
				bestn = n2;
				for (int j = 0; j < NR; j++)
					best[j] = x[j];
			}
		}
		float inv = 1.0f / sqrtf(bestn);
		for (int j = 0; j < NR; j++) {
			basis[j][nb] = best[j] * inv;
			dz->null_f[j][nb - rank] = basis[j][nb];
		}
		nb++;
	}
	dz->n_null = (uint8_t)(NR - rank);
}

/* The thrust box [k_f t_min, k_f t_max] and Gamma's rows scaled by their largest entry
 * (gsc, and m->gn in scalar_t). Returns false when the box is empty or a row is zero. */
static bool box_and_rows(struct mixer *m, const struct mixer_params *p, const struct mixer_design *dz,
			 float gsc[NA][NR])
{
	float kf = sc_to_float(p->k_f_n);
	float tmin = sc_to_float(p->t_min), tmax = sc_to_float(p->t_max);
	if (!(tmin >= 0.0f))
		tmin = 0.0f;
	if (!(tmax > tmin))
		tmax = tmin + 1e-3f;
	float flo = kf * tmin, fhi = kf * tmax, width = fhi - flo;
	m->f_lo = sc_from_float(flo);
	m->f_hi = sc_from_float(fhi);
	float rowmax[NA];
	bool rows_ok = width > 0.0f;
	for (int i = 0; i < NA; i++) {
		rowmax[i] = 0.0f;
		float wl = 0.0f;
		for (int j = 0; j < NR; j++) {
			rowmax[i] = absf(dz->gamma_f[i][j]) > rowmax[i] ? absf(dz->gamma_f[i][j]) : rowmax[i];
			if ((fb_abs_bits(dz->gamma_f[0][j]) | fb_abs_bits(dz->gamma_f[1][j]) |
			     fb_abs_bits(dz->gamma_f[2][j]) | fb_abs_bits(dz->gamma_f[3][j])) !=
			    0u) /* an entry not 0 */
				wl += dz->gamma_f[i][j] * flo;
		}
		m->w_lo[i] = sc_from_float(wl);
		if (!fb_pos(rowmax[i])) {
			rows_ok = false;
			rowmax[i] = 1.0f;
		}
		m->row_max[i] = sc_from_float(rowmax[i]);
		m->row_div[i] = sc_from_float(1.0f / rowmax[i]);
		for (int j = 0; j < NR; j++) {
			gsc[i][j] = dz->gamma_f[i][j] / rowmax[i];
			m->gn[i][j] = sc_from_float(gsc[i][j]);
		}
	}
	m->width = sc_from_float(width);
	return rows_ok;
}

/* Every 4 of the na present rotors act[], as a mask over positions t (bit na-1-t): masks in
 * descending order visit them lexicographically; the first of the largest |det| (within
 * 1e-4) wins. Returns its mask (0: none) with its |det| in *det and its inverse in inv. */
static unsigned best_four(float gsc[NA][NR], const uint8_t act[NR], int na, float *det, float inv[4][4])
{
	float bestdet = 0.0f, invs[2][4][4]; /* the best inverse so far (invs[bi]), the next */
	unsigned best = 0;
	int bi = 0;
	for (unsigned mask = (1u << na) - 1u; mask; mask--) {
		float mm[4][4];
		int c = 0;
		uint8_t col[NR]; /* the mask's rotors */
		for (int t = 0; t < na; t++)
			if (mask >> (na - 1 - t) & 1u)
				col[c++] = act[t];
		if (c != 4)
			continue;
		for (int k = 0; k < 16; k++)
			mm[k / 4][k % 4] = gsc[k / 4][col[k % 4]];
		float d = inv4(mm, invs[1 - bi]);
		if (d > bestdet * 1.0001f) {
			bestdet = d;
			best = mask;
			bi = 1 - bi;
		}
	}
	*det = bestdet;
	for (int c = 0; c < 4; c++)
		for (int i = 0; i < NA; i++)
			inv[c][i] = invs[bi][c][i];
	return best;
}

/* The facets of the attainable set of all present rotors, and of what the rotors after each
 * fixed one span (the allocator's sub-problems). Returns false when a table is too small. */
static bool facet_tables(struct mixer *m, float gsc[NA][NR], const uint8_t act[NR], int na)
{
	int nfull = facets_of(gsc, act, na, m->facet, MIXER_MAX_FACETS);
	bool fits = nfull > 0;
	m->n_facets = (uint8_t)(nfull > 0 ? nfull : 0);
	int used = 0;
	for (int st = 0; st + 5 <= na; st++) {
		int cnt = na - st - 1; /* generators left after fixing order[st] */
		m->sub_first[st] = (uint8_t)used;
		m->sub_n[st] = 0;
		if (cnt > 4) {
			int k = facets_of(gsc, &m->order[st + 1], cnt, &m->sub[used], MIXER_MAX_SUB_FACETS - used);
			if (k < 0) {
				fits = false;
				break;
			}
			m->sub_n[st] = (uint8_t)k;
			used += k;
		}
	}
	return fits;
}

/* The allocator: present rotors, the best-conditioned 4 of them last, its inverse and the
 * facet tables; m->alloc_ok when all of it exists. */
static void allocator(struct mixer *m, const struct mixer_design *dz, float gsc[NA][NR], int rank, bool rows_ok)
{
	uint8_t act[NR];
	int na = 0;
	for (int j = 0; j < NR; j++) {
		if (dotf(&dz->gamma_f[0][j], NR, &dz->gamma_f[0][j], NR, NA) > 0.0f) {
			act[na++] = (uint8_t)j;
			m->present |= (uint8_t)(1u << j);
		}
	}
	m->n_active = (uint8_t)na;
	m->alloc_ok = false;
	if (rank != NA || na < NA || !rows_ok)
		return;
	float bestdet, inv[4][4];
	unsigned best = best_four(gsc, act, na, &bestdet, inv);
	if (!(bestdet > 1e-4f))
		return;
	int no = 0; /* the others in order, then the best 4 */
	for (int pass = 0; pass < 2; pass++)
		for (int t = 0; t < na; t++)
			if ((best >> (na - 1 - t) & 1u) == (unsigned)pass)
				m->order[no++] = act[t];
	for (int c = 0; c < 4; c++)
		for (int i = 0; i < NA; i++)
			m->tail_inv[c][i] = sc_from_float(inv[c][i]);
	m->alloc_ok = facet_tables(m, gsc, act, na);
}

bool mixer_init_design(struct mixer *m, const struct mixer_params *p, struct mixer_design *dz)
{
	unsigned char *raw = (unsigned char *)m; /* zero the caller's structs without a template */
	for (size_t b = 0; b < sizeof *m; b++)
		raw[b] = 0;
	raw = (unsigned char *)dz;
	for (size_t b = 0; b < sizeof *dz; b++)
		raw[b] = 0;
	m->p = *p;
	m->p.custom_gamma = NULL;
	m->custom = p->custom_gamma != NULL;
	build_gamma(dz, p);
	for (int j = 0; j < NR; j++)
		m->p.scale[j] = scale_used(p->scale[j]);

	float basis[NR][NR]; /* columns: the row space of Gamma, then the null space */
	int rank = pseudo_inverse(dz, basis);
	m->rank = (uint8_t)rank;
	dz->rank = (uint8_t)rank;
	polish_pinv(dz);
	null_space(dz, basis, rank);
	for (int j = 0; j < NR; j++)
		for (int i = 0; i < NA; i++)
			m->pinv[j][i] = sc_from_float(dz->pinv_f[j][i]);

	float gsc[NA][NR];
	bool rows_ok = box_and_rows(m, p, dz, gsc);
	allocator(m, dz, gsc, rank, rows_ok);
	for (int k = 0; k < 2; k++) { /* the fallback's columns: thrust (0) and yaw (3) */
		unsigned up = 0, dn = 0, fix = 0;
		for (int j = 0; j < NR; j++) {
			scalar_t c = m->pinv[j][k ? 3 : 0];
			if (!(m->present & (1u << j)))
				continue;
			if (sc_abs(c) <= EPS_S)
				fix |= 1u << j;
			else if (c < SC_ZERO)
				dn |= 1u << j;
			else
				up |= 1u << j;
		}
		m->col_up[k] = (uint8_t)up;
		m->col_dn[k] = (uint8_t)dn;
		m->col_fix[k] = (uint8_t)fix;
	}
	return rank == NA;
}

static bool same_geometry(const struct mixer *m, const struct mixer_params *b)
{
	const struct mixer_params *a = &m->p;
	for (int j = 0; j < NR; j++)
		if (a->scale[j] != scale_used(b->scale[j]))
			return false;
	return a->arm_l_m == b->arm_l_m && a->k_f_n == b->k_f_n && a->k_tau_nm == b->k_tau_nm && a->t_min == b->t_min &&
	       a->t_max == b->t_max && a->rotor_mask == b->rotor_mask && !m->custom && b->custom_gamma == NULL;
}

bool mixer_set_params(struct mixer *m, const struct mixer_params *p)
{
	if (same_geometry(m, p)) {
		m->p.mode = p->mode;
		return m->rank == NA;
	}
	return mixer_init(m, p);
}

/* ================================================================ 90 Hz path (scalar_t) */
