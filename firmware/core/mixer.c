/* mixer.c - Gamma_o mixer, pseudo-inverse and priority allocator; see mixer.h. */
#include "mixer.h"

#define NR MIXER_N_ROTORS
#define NA MIXER_N_AXES

/* tolerances of the allocator, in scaled units (1 = one rotor's full thrust range) */
#if OCTO_FIXED
#define TOL_ATT ((scalar_t)16)      /* 2.4e-4 in scaled units */
#define TOL_IN  ((scalar_t)24)      /* inner margin of the priority steps: 3.7e-4 */
#define EPS_S   ((scalar_t)64)      /* 1e-3: slopes below are treated as zero */
#define TOL_FLAG_REL SC(0.001)
#define EPS_GS  ((scalar_t)16)      /* squared residual norm below which a row is dependent */
#define EPS_P   ((scalar_t)8)
#define EPS_MU  ((scalar_t)32)
#else
#define TOL_ATT SC(3e-6)
#define TOL_IN  SC(3e-6)
#define EPS_S   SC(1e-6)
#define TOL_FLAG_REL SC(1e-5)
#define EPS_GS  SC(1e-8)
#define EPS_P   SC(1e-7)
#define EPS_MU  SC(1e-6)
#endif

/* ================================================================ set-up (float32) */

static float absf(float x) { return x < 0.0f ? -x : x; }

/* One-sided Jacobi SVD of A (8x4, columns orthogonalised in place): A V = U S.
 * On return a[][k] = U_k s_k, v = V, s = column norms. At most 40 sweeps. */
static void jacobi_svd(float a[NR][NA], float v[NA][NA], float s[NA])
{
	for (int i = 0; i < NA; i++)
		for (int j = 0; j < NA; j++)
			v[i][j] = i == j ? 1.0f : 0.0f;
	for (int sweep = 0; sweep < 40; sweep++) {
		int rotated = 0;
		for (int p = 0; p < NA - 1; p++) {
			for (int q = p + 1; q < NA; q++) {
				float al = 0.0f, be = 0.0f, ga = 0.0f;
				for (int i = 0; i < NR; i++) {
					al += a[i][p] * a[i][p];
					be += a[i][q] * a[i][q];
					ga += a[i][p] * a[i][q];
				}
				if (al <= 0.0f || be <= 0.0f || absf(ga) <= 1e-7f * sqrtf(al * be))
					continue;
				rotated = 1;
				float zeta = (be - al) / (2.0f * ga);
				float t = (zeta >= 0.0f ? 1.0f : -1.0f) / (absf(zeta) + sqrtf(1.0f + zeta * zeta));
				float c = 1.0f / sqrtf(1.0f + t * t), sn = c * t;
				for (int i = 0; i < NR; i++) {
					float x = a[i][p], y = a[i][q];
					a[i][p] = c * x - sn * y;
					a[i][q] = sn * x + c * y;
				}
				for (int i = 0; i < NA; i++) {
					float x = v[i][p], y = v[i][q];
					v[i][p] = c * x - sn * y;
					v[i][q] = sn * x + c * y;
				}
			}
		}
		if (!rotated)
			break;
	}
	for (int k = 0; k < NA; k++) {
		float n2 = 0.0f;
		for (int i = 0; i < NR; i++)
			n2 += a[i][k] * a[i][k];
		s[k] = sqrtf(n2);
	}
}

/* Inverse of a 4x4 matrix by Gauss-Jordan with partial pivoting; returns |det|. */
static float inv4(const float m[4][4], float out[4][4])
{
	float a[4][8];
	for (int i = 0; i < 4; i++)
		for (int j = 0; j < 4; j++) {
			a[i][j] = m[i][j];
			a[i][4 + j] = i == j ? 1.0f : 0.0f;
		}
	float det = 1.0f;
	for (int c = 0; c < 4; c++) {
		int piv = c;
		for (int r = c + 1; r < 4; r++)
			if (absf(a[r][c]) > absf(a[piv][c]))
				piv = r;
		if (a[piv][c] == 0.0f)
			return 0.0f;
		if (piv != c)
			for (int j = 0; j < 8; j++) {
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

static float det3(float a0, float a1, float a2, float b0, float b1, float b2, float c0, float c1, float c2)
{
	return a0 * (b1 * c2 - b2 * c1) - a1 * (b0 * c2 - b2 * c0) + a2 * (b0 * c1 - b1 * c0);
}

/* unit normal to three 4-vectors (generalised cross product); false if they are dependent */
static bool normal3(const float g[NA][NR], int a, int b, int c, float n[NA])
{
	float r[3][NA];
	for (int i = 0; i < NA; i++) {
		r[0][i] = g[i][a];
		r[1][i] = g[i][b];
		r[2][i] = g[i][c];
	}
	float nn = 0.0f;
	for (int k = 0; k < NA; k++) {
		int col[3], m = 0;
		for (int j = 0; j < NA; j++)
			if (j != k)
				col[m++] = j;
		float d = det3(r[0][col[0]], r[0][col[1]], r[0][col[2]],
			       r[1][col[0]], r[1][col[1]], r[1][col[2]],
			       r[2][col[0]], r[2][col[1]], r[2][col[2]]);
		n[k] = (k & 1) ? -d : d;
		nn += n[k] * n[k];
	}
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
static int facets_of(const float g[NA][NR], const uint8_t *set, int cnt, struct mixer_facet *out,
		     struct mixer_subfacet *out_sub, int cap)
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
				for (int k = 0; k < nf && !dup; k++) {
					float dp = 0.0f, dm = 0.0f;
					for (int i = 0; i < NA; i++) {
						dp = absf(n[i] - seen[k][i]) > dp ? absf(n[i] - seen[k][i]) : dp;
						dm = absf(n[i] + seen[k][i]) > dm ? absf(n[i] + seen[k][i]) : dm;
					}
					dup = dp < 1e-4f || dm < 1e-4f;
				}
				if (dup)
					continue;
				if (nf >= cap)
					return -1;
				float nc = 0.0f, h = 0.0f;
				for (int t = 0; t < cnt; t++) {
					float d = 0.0f;
					for (int i = 0; i < NA; i++)
						d += n[i] * g[i][set[t]];
					nc += 0.5f * d;
					h += 0.5f * absf(d);
				}
				for (int i = 0; i < NA; i++)
					seen[nf][i] = n[i];
				if (out_sub) { /* a preimage step's facet: no reciprocals */
					for (int i = 0; i < NA; i++)
						out_sub[nf].n[i] = sc_from_float(n[i]);
					out_sub[nf].nc = sc_from_float(nc);
					out_sub[nf].h = sc_from_float(h);
					nf++;
					continue;
				}
				for (int i = 0; i < NA; i++)
					out[nf].n[i] = sc_from_float(n[i]);
				out[nf].nc = sc_from_float(nc);
				out[nf].h = sc_from_float(h);
				/* reciprocals of the thrust and yaw components (0: treated as zero) */
				scalar_t n0 = out[nf].n[0], n3 = out[nf].n[3];
				out[nf].inv0 = sc_abs(n0) > EPS_S ? sc_from_float(1.0f / sc_to_float(n0)) : SC_ZERO;
				out[nf].inv3 = sc_abs(n3) > EPS_S ? sc_from_float(1.0f / sc_to_float(n3)) : SC_ZERO;
				nf++;
			}
	return nf;
}

void mixer_default_params(struct mixer_params *p)
{
	struct mixer_params d = { 0 };
	d.arm_l_m = SC(0.35);
	d.k_f_n = SC(28.0269);
	d.k_tau_nm = SC(0.3869);
	d.t_min = SC(0);
	d.t_max = SC(1);
	d.rotor_mask = 0xFF;
	d.mode = MIXER_MODE_PRIORITY;
	d.custom_gamma = NULL;
	*p = d;
}

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
		float k = kf > 0.0f ? sc_to_float(p->k_tau_nm) / kf : 0.0f;
		static const float tx[NR] = { 0, -1, -1, -1, 0, 1, 1, 1 };
		static const float ty[NR] = { -1, -1, 0, 1, 1, 1, 0, -1 };
		for (int j = 0; j < NR; j++) {
			float diag = (j & 1) ? s : 1.0f; /* even-numbered rotors 2,4,6,8 at 45 deg */
			m->gamma_f[0][j] = 1.0f;
			m->gamma_f[1][j] = tx[j] * diag * l;
			m->gamma_f[2][j] = ty[j] * diag * l;
			m->gamma_f[3][j] = (j & 1) ? -k : k;
		}
	}
	for (int j = 0; j < NR; j++)
		if (!(p->rotor_mask & (1u << j)) || !(m->gamma_f[0][j] == m->gamma_f[0][j]))
			for (int i = 0; i < NA; i++)
				m->gamma_f[i][j] = 0.0f;
	for (int i = 0; i < NA; i++)
		for (int j = 0; j < NR; j++)
			if (!isfinite(m->gamma_f[i][j]))
				m->gamma_f[i][j] = 0.0f;
}

bool mixer_init(struct mixer *m, const struct mixer_params *p)
{
	struct mixer_design d; /* scratch, dropped on return */
	return mixer_init_design(m, p, &d);
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

	/* ---- pseudo-inverse by one-sided Jacobi SVD of Gamma^T */
	float a[NR][NA], v[NA][NA], s[NA];
	for (int j = 0; j < NR; j++)
		for (int i = 0; i < NA; i++)
			a[j][i] = dz->gamma_f[i][j];
	jacobi_svd(a, v, s);
	int idx[NA] = { 0, 1, 2, 3 };
	for (int i = 0; i < NA; i++) /* sort by singular value, descending */
		for (int j = i + 1; j < NA; j++)
			if (s[idx[j]] > s[idx[i]]) {
				int t = idx[i];
				idx[i] = idx[j];
				idx[j] = t;
			}
	float smax = s[idx[0]];
	float ucol[NR][NA];
	int rank = 0;
	for (int k = 0; k < NA; k++) {
		int c = idx[k];
		dz->sigma_f[k] = s[c];
		if (smax > 0.0f && s[c] > 1e-5f * smax) {
			for (int j = 0; j < NR; j++)
				ucol[j][rank] = a[j][c] / s[c];
			/* pinv += u_k (1/s_k) v_k^T */
			for (int j = 0; j < NR; j++)
				for (int i = 0; i < NA; i++)
					dz->pinv_f[j][i] += ucol[j][rank] / s[c] * v[i][c];
			rank++;
		}
	}
	m->rank = (uint8_t)rank;
	dz->rank = (uint8_t)rank;
	/* two Newton-Schulz steps P <- 2P - P Gamma P (converge to the Moore-Penrose inverse,
	 * also when rank-deficient) polish the float32 SVD result */
	for (int it = 0; it < 2; it++) {
		float gp[NA][NA], np[NR][NA];
		for (int i = 0; i < NA; i++)
			for (int k = 0; k < NA; k++) {
				float acc = 0.0f;
				for (int j = 0; j < NR; j++)
					acc += dz->gamma_f[i][j] * dz->pinv_f[j][k];
				gp[i][k] = acc;
			}
		for (int j = 0; j < NR; j++)
			for (int k = 0; k < NA; k++) {
				float acc = 0.0f; /* (P (I - Gamma P))_jk, then P + that */
				for (int i = 0; i < NA; i++)
					acc += dz->pinv_f[j][i] * ((i == k ? 1.0f : 0.0f) - gp[i][k]);
				np[j][k] = dz->pinv_f[j][k] + acc;
			}
		for (int j = 0; j < NR; j++)
			for (int k = 0; k < NA; k++)
				dz->pinv_f[j][k] = np[j][k];
	}

	/* ---- null space: complete the row space of Gamma (ucol) with unit vectors, Gram-Schmidt */
	float basis[NR][NR];
	int nb = 0;
	for (int k = 0; k < rank; k++)
		for (int j = 0; j < NR; j++)
			basis[j][k] = ucol[j][k];
	nb = rank;
	while (nb < NR) {
		float best[NR] = { 0 }, bestn = -1.0f;
		for (int e = 0; e < NR; e++) {
			float x[NR];
			for (int j = 0; j < NR; j++)
				x[j] = j == e ? 1.0f : 0.0f;
			for (int pass = 0; pass < 2; pass++)
				for (int k = 0; k < nb; k++) {
					float d = 0.0f;
					for (int j = 0; j < NR; j++)
						d += basis[j][k] * x[j];
					for (int j = 0; j < NR; j++)
						x[j] -= d * basis[j][k];
				}
			float n2 = 0.0f;
			for (int j = 0; j < NR; j++)
				n2 += x[j] * x[j];
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

	for (int j = 0; j < NR; j++)
		for (int i = 0; i < NA; i++)
			m->pinv[j][i] = sc_from_float(dz->pinv_f[j][i]);

	/* ---- box and row scaling */
	float kf = sc_to_float(p->k_f_n);
	float tmin = sc_to_float(p->t_min), tmax = sc_to_float(p->t_max);
	if (!(tmin >= 0.0f))
		tmin = 0.0f;
	if (!(tmax > tmin))
		tmax = tmin + 1e-3f;
	float flo = kf * tmin, fhi = kf * tmax, width = fhi - flo;
	m->f_lo = sc_from_float(flo);
	m->f_hi = sc_from_float(fhi);
	float gsc[NA][NR];
	float rowmax[NA];
	bool rows_ok = width > 0.0f;
	for (int i = 0; i < NA; i++) {
		rowmax[i] = 0.0f;
		float wl = 0.0f;
		for (int j = 0; j < NR; j++) {
			rowmax[i] = absf(dz->gamma_f[i][j]) > rowmax[i] ? absf(dz->gamma_f[i][j]) : rowmax[i];
			if (dz->gamma_f[0][j] != 0.0f || dz->gamma_f[1][j] != 0.0f ||
			    dz->gamma_f[2][j] != 0.0f || dz->gamma_f[3][j] != 0.0f)
				wl += dz->gamma_f[i][j] * flo;
		}
		m->w_lo[i] = sc_from_float(wl);
		if (!(rowmax[i] > 0.0f)) {
			rows_ok = false;
			rowmax[i] = 1.0f;
		}
		m->row_div[i] = sc_from_float(1.0f / rowmax[i]);
		m->row_scale[i] = sc_from_float(width * rowmax[i]);
		for (int j = 0; j < NR; j++) {
			gsc[i][j] = dz->gamma_f[i][j] / rowmax[i];
			m->gn[i][j] = sc_from_float(gsc[i][j]);
		}
	}
	m->width = sc_from_float(width);
	/* a rotor within 4 inner margins of a bound counts as at the bound */
	m->at_tol = sc_mul(m->width, sc_mul(SC(4), TOL_IN));
	for (int j = 0; j < NR; j++)
		for (int i = 0; i < NA; i++)
			m->pinv_n[j][i] = sc_from_float(dz->pinv_f[j][i] * rowmax[i]);

	/* ---- allocator: present rotors, the best-conditioned 4 of them last */
	uint8_t act[NR];
	int na = 0;
	for (int j = 0; j < NR; j++) {
		float n2 = 0.0f;
		for (int i = 0; i < NA; i++)
			n2 += dz->gamma_f[i][j] * dz->gamma_f[i][j];
		if (n2 > 0.0f) {
			act[na++] = (uint8_t)j;
			m->present |= (uint8_t)(1u << j);
		}
	}
	m->n_active = (uint8_t)na;
	m->alloc_ok = false;
	if (rank == NA && na >= NA && rows_ok) {
		float bestdet = 0.0f;
		int bt[4] = { 0, 1, 2, 3 };
		for (int a0 = 0; a0 < na; a0++)
			for (int a1 = a0 + 1; a1 < na; a1++)
				for (int a2 = a1 + 1; a2 < na; a2++)
					for (int a3 = a2 + 1; a3 < na; a3++) {
						int t[4] = { a0, a1, a2, a3 };
						float mm[4][4], inv[4][4];
						for (int i = 0; i < NA; i++)
							for (int c = 0; c < 4; c++)
								mm[i][c] = gsc[i][act[t[c]]];
						float d = inv4(mm, inv);
						if (d > bestdet * 1.0001f) {
							bestdet = d;
							for (int c = 0; c < 4; c++)
								bt[c] = t[c];
						}
					}
		if (bestdet > 1e-4f) {
			int no = 0;
			for (int t = 0; t < na; t++)
				if (t != bt[0] && t != bt[1] && t != bt[2] && t != bt[3])
					m->order[no++] = act[t];
			for (int c = 0; c < 4; c++)
				m->order[no++] = act[bt[c]];
			float mm[4][4], inv[4][4];
			for (int i = 0; i < NA; i++)
				for (int c = 0; c < 4; c++)
					mm[i][c] = gsc[i][m->order[na - 4 + c]];
			inv4(mm, inv);
			for (int c = 0; c < 4; c++)
				for (int i = 0; i < NA; i++)
					m->tail_inv[c][i] = sc_from_float(inv[c][i]);
			int nfull = facets_of(gsc, act, na, m->facet, NULL, MIXER_MAX_FACETS);
			bool fits = nfull > 0;
			m->n_facets = (uint8_t)(nfull > 0 ? nfull : 0);
			int used = 0;
			for (int st = 0; st + 5 <= na; st++) {
				int cnt = na - st - 1; /* generators left after fixing order[st] */
				m->sub_first[st] = (uint8_t)used;
				m->sub_n[st] = 0;
				if (cnt > 4) {
					int k = facets_of(gsc, &m->order[st + 1], cnt, NULL, &m->sub[used],
							  MIXER_MAX_SUB_FACETS - used);
					if (k < 0) {
						fits = false;
						break;
					}
					m->sub_n[st] = (uint8_t)k;
					used += k;
				}
			}
			m->alloc_ok = fits;
		}
	}
	return rank == NA;
}

static bool same_geometry(const struct mixer *m, const struct mixer_params *b)
{
	const struct mixer_params *a = &m->p;
	return a->arm_l_m == b->arm_l_m && a->k_f_n == b->k_f_n && a->k_tau_nm == b->k_tau_nm &&
	       a->t_min == b->t_min && a->t_max == b->t_max && a->rotor_mask == b->rotor_mask &&
	       !m->custom && b->custom_gamma == NULL;
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


static scalar_t dot4(const scalar_t a[NA], const scalar_t b[NA])
{
	scalar_t s = sc_mul(a[0], b[0]);
	s = sc_mac(a[1], b[1], s);
	s = sc_mac(a[2], b[2], s);
	return sc_mac(a[3], b[3], s);
}

/* physical wrench component -> scaled space */
static scalar_t to_scaled(const struct mixer *m, int i, scalar_t v)
{
	return sc_div(sc_mul(sc_sub(v, m->w_lo[i]), m->row_div[i]), m->width);
}

void mixer_wrench(const struct mixer *m, const scalar_t f_n[NR], scalar_t wrench[NA])
{
	for (int i = 0; i < NA; i++) {
		scalar_t s = SC_ZERO;
		for (int j = 0; j < NR; j++)
			s = sc_mac(m->gn[i][j], f_n[j], s);
		wrench[i] = sc_div(s, m->row_div[i]);
	}
}

static bool attainable_scaled(const struct mixer *m, const scalar_t w[NA], scalar_t tol)
{
	for (int k = 0; k < m->n_facets; k++) {
		const struct mixer_facet *fc = &m->facet[k];
		scalar_t q = sc_sub(dot4(fc->n, w), fc->nc);
		if (sc_abs(q) > sc_add(fc->h, tol))
			return false;
	}
	return true;
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

/* Interval [lo, hi] of the offset t along axis ax (0 thrust, 3 yaw), within [l, h], such that
 * w + t e_ax is attainable with the inner margin; false if empty (lo, hi untouched then).
 * Works on t directly (not on t / demand) so that huge demands lose no resolution. */
static bool axis_interval(const struct mixer *m, const scalar_t w[NA], int ax, scalar_t l, scalar_t h,
			  scalar_t *lo, scalar_t *hi)
{
	for (int k = 0; k < m->n_facets; k++) {
		const struct mixer_facet *fc = &m->facet[k];
		scalar_t q = sc_sub(dot4(fc->n, w), fc->nc);
		scalar_t s = fc->n[ax], inv = ax == 0 ? fc->inv0 : fc->inv3, hw = sc_sub(fc->h, TOL_IN);
		if (inv == SC_ZERO) { /* |n_ax| <= EPS_S: independent of t */
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
		l = sc_max(l, a);
		h = sc_min(h, b);
		if (l > h)
			return false;
	}
	*lo = l;
	*hi = h;
	return l <= h;
}

/* Interval of the scaled thrust w[0] such that w is attainable, other components fixed.
 * Returns false if empty. */
static bool thrust_interval(const struct mixer *m, const scalar_t w[NA], scalar_t *lo, scalar_t *hi)
{
	const scalar_t w0[NA] = {SC_ZERO, w[1], w[2], w[3]};
	return axis_interval(m, w0, 0, SC_MAX_NEG, SC_MAX, lo, hi);
}

/* With w[3] = the scaled zero yaw, the interval [lo, hi] of yaw offsets t between 0 and dy
 * (the scaled demanded yaw offset) such that w + t e_3 is attainable; false if empty. */
static bool yaw_interval(const struct mixer *m, const scalar_t w[NA], scalar_t dy, scalar_t *lo, scalar_t *hi)
{
	scalar_t l = sc_min(SC_ZERO, dy), h = sc_max(SC_ZERO, dy);
	*lo = l;
	*hi = h;
	if (dy == SC_ZERO) /* no yaw demanded: is w itself attainable (inner margin)? */
		return attainable_scaled(m, w, sc_neg(TOL_IN));
	return axis_interval(m, w, 3, l, h, lo, hi);
}

/* tighten [lo, hi] with the constraint -hw <= q - u s <= hw (u is the unknown) */
static void narrow(scalar_t q, scalar_t s, scalar_t hw, scalar_t *lo, scalar_t *hi)
{
	if (sc_abs(s) <= EPS_S)
		return;
	scalar_t a = sc_div(sc_sub(q, hw), s), b = sc_div(sc_add(q, hw), s);
	if (s < 0) {
		scalar_t t = a;
		a = b;
		b = t;
	}
	*lo = sc_max(*lo, a);
	*hi = sc_min(*hi, b);
}

/* Orthonormal basis (rows q[0..r-1], length nf) of the row space of G_F (the 4 rows of gn
 * restricted to the free rotors fr[0..nf-1]) by modified Gram-Schmidt; lt[k][m] = q_m . row_k,
 * piv[m] = row that produced q_m. Returns r. */
static int row_basis(const struct mixer *m, const int *fr, int nf, scalar_t q[NA][NR],
		     scalar_t lt[NA][NA], int piv[NA])
{
	int r = 0;
	for (int k = 0; k < NA; k++) {
		scalar_t v[NR];
		for (int t = 0; t < nf; t++)
			v[t] = m->gn[k][fr[t]];
		for (int i = 0; i < NA; i++)
			lt[k][i] = SC_ZERO;
		for (int pass = 0; pass < 2; pass++)
			for (int i = 0; i < r; i++) {
				scalar_t d = SC_ZERO;
				for (int t = 0; t < nf; t++)
					d = sc_mac(q[i][t], v[t], d);
				lt[k][i] = sc_add(lt[k][i], d);
				for (int t = 0; t < nf; t++)
					v[t] = sc_sub(v[t], sc_mul(d, q[i][t]));
			}
		scalar_t n2 = SC_ZERO;
		for (int t = 0; t < nf; t++)
			n2 = sc_mac(v[t], v[t], n2);
		if (n2 <= EPS_GS)
			continue;
		scalar_t nrm = sc_sqrt(n2), inv = sc_div(SC(1), nrm);
		for (int t = 0; t < nf; t++)
			q[r][t] = sc_mul(v[t], inv);
		lt[k][r] = nrm;
		piv[r] = k;
		r++;
	}
	return r;
}

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
	int piv[NA], fr[NR], nf = 0, r = 0, it;
	for (it = 0; it < MIXER_QP_ITERS; it++) {
		nf = 0;
		for (int t = 0; t < na; t++)
			if (bnd[m->order[t]] == 0)
				fr[nf++] = m->order[t];
		r = row_basis(m, fr, nf, q, lt, piv);
		/* p = projection of (uref - u)_F onto null(G_F) */
		scalar_t p[NR], c[NA], pmax = SC_ZERO;
		for (int t = 0; t < nf; t++)
			p[t] = sc_sub(uref[fr[t]], u[fr[t]]);
		for (int i = 0; i < r; i++) {
			c[i] = SC_ZERO;
			for (int t = 0; t < nf; t++)
				c[i] = sc_mac(q[i][t], p[t], c[i]);
		}
		for (int i = 0; i < r; i++)
			for (int t = 0; t < nf; t++)
				p[t] = sc_sub(p[t], sc_mul(c[i], q[i][t]));
		for (int t = 0; t < nf; t++)
			pmax = sc_max(pmax, sc_abs(p[t]));
		if (pmax > EPS_P) {
			scalar_t step = SC(1);
			int blk = -1;
			for (int t = 0; t < nf; t++) {
				scalar_t lim;
				if (p[t] < -EPS_P)
					lim = sc_div(sc_neg(u[fr[t]]), p[t]);
				else if (p[t] > EPS_P)
					lim = sc_div(sc_sub(SC(1), u[fr[t]]), p[t]);
				else
					continue;
				if (lim < step) {
					step = sc_max(lim, SC_ZERO);
					blk = t;
				}
			}
			for (int t = 0; t < nf; t++)
				u[fr[t]] = sc_clamp(sc_add(u[fr[t]], sc_mul(step, p[t])), SC_ZERO, SC(1));
			if (blk >= 0) {
				int j = fr[blk];
				bnd[j] = p[blk] < 0 ? -1 : 1;
				u[j] = bnd[j] < 0 ? SC_ZERO : SC(1);
			}
			continue;
		}
		/* stationary on this face: multipliers lambda from G_F^T lambda = g_F (g = u - uref),
		 * i.e. L^T lambda = Q g_F, back substitution over the basis rows */
		scalar_t lam[NA] = { SC_ZERO, SC_ZERO, SC_ZERO, SC_ZERO };
		for (int i = 0; i < r; i++) {
			c[i] = SC_ZERO;
			for (int t = 0; t < nf; t++)
				c[i] = sc_mac(q[i][t], sc_sub(u[fr[t]], uref[fr[t]]), c[i]);
		}
		for (int i = r - 1; i >= 0; i--) {
			scalar_t acc = c[i];
			for (int k = piv[i] + 1; k < NA; k++)
				acc = sc_sub(acc, sc_mul(lt[k][i], lam[k]));
			lam[piv[i]] = sc_div(acc, lt[piv[i]][i]);
		}
		int rel = -1;
		scalar_t worst = EPS_MU;
		for (int t = 0; t < na; t++) {
			int j = m->order[t];
			if (bnd[j] == 0)
				continue;
			scalar_t mu = sc_sub(u[j], uref[j]);
			for (int k = 0; k < NA; k++)
				mu = sc_sub(mu, sc_mul(m->gn[k][j], lam[k]));
			scalar_t viol = bnd[j] < 0 ? sc_neg(mu) : mu;
			if (viol > worst) {
				worst = viol;
				rel = j;
			}
		}
		if (rel < 0)
			break; /* KKT point: the unique optimum */
		bnd[rel] = 0;
	}
	/* minimum-norm correction of the residual on the free rotors: d = Q^T y, L y = w - gn u */
	nf = 0;
	for (int t = 0; t < na; t++)
		if (bnd[m->order[t]] == 0)
			fr[nf++] = m->order[t];
	r = row_basis(m, fr, nf, q, lt, piv);
	scalar_t res[NA], y[NA];
	for (int k = 0; k < NA; k++) {
		res[k] = w[k];
		for (int t = 0; t < na; t++)
			res[k] = sc_sub(res[k], sc_mul(m->gn[k][m->order[t]], u[m->order[t]]));
	}
	for (int i = 0; i < r; i++) {
		scalar_t acc = res[piv[i]];
		for (int k = 0; k < i; k++)
			acc = sc_sub(acc, sc_mul(lt[piv[i]][k], y[k]));
		y[i] = sc_div(acc, lt[piv[i]][i]);
	}
	for (int t = 0; t < nf; t++) {
		scalar_t d = SC_ZERO;
		for (int i = 0; i < r; i++)
			d = sc_mac(q[i][t], y[i], d);
		u[fr[t]] = sc_clamp(sc_add(u[fr[t]], d), SC_ZERO, SC(1));
	}
	return it;
}

/* Exact preimage: u in [0,1]^8 with gn u = w (w attainable), see mixer.h step e. */
static int preimage(const struct mixer *m, const scalar_t w[NA], scalar_t u[NR])
{
	scalar_t uref[NR], r[NA];
	for (int j = 0; j < NR; j++) {
		uref[j] = dot4(m->pinv_n[j], w);
		u[j] = SC_ZERO;
	}
	for (int i = 0; i < NA; i++)
		r[i] = w[i];
	const int na = m->n_active;
	int steps = 0;
	for (int st = 0; st + 4 < na; st++) {
		int j = m->order[st];
		scalar_t g[NA] = { m->gn[0][j], m->gn[1][j], m->gn[2][j], m->gn[3][j] };
		scalar_t lo = SC_ZERO, hi = SC(1);
		if (st + 5 == na) {
			/* the rest is the invertible tail: u_tail = T r - u T g in [0, 1]^4 */
			for (int c = 0; c < 4; c++) {
				scalar_t tr = dot4(m->tail_inv[c], r), tg = dot4(m->tail_inv[c], g);
				/* 0 <= tr - u tg <= 1  <=>  -1/2 <= (tr - 1/2) - u tg <= 1/2 */
				narrow(sc_sub(tr, SC(0.5)), tg, SC(0.5), &lo, &hi);
			}
		} else {
			for (int k = 0; k < m->sub_n[st]; k++) {
				const struct mixer_subfacet *fc = &m->sub[m->sub_first[st] + k];
				narrow(sc_sub(dot4(fc->n, r), fc->nc), dot4(fc->n, g), fc->h, &lo, &hi);
			}
		}
		scalar_t x;
		if (lo <= hi)
			x = sc_clamp(uref[j], lo, hi);
		else /* numerically empty: the nearest point of the two bounds */
			x = sc_clamp(sc_add(sc_mul(lo, SC(0.5)), sc_mul(hi, SC(0.5))), SC_ZERO, SC(1));
		u[j] = x;
		for (int i = 0; i < NA; i++)
			r[i] = sc_sub(r[i], sc_mul(x, g[i]));
		steps++;
	}
	for (int c = 0; c < 4; c++)
		u[m->order[na - 4 + c]] = sc_clamp(dot4(m->tail_inv[c], r), SC_ZERO, SC(1));

	/* move along the null space (u - uref) back towards the pseudo-inverse solution */
	scalar_t theta = SC_ZERO;
	for (int t = 0; t < na; t++) {
		int j = m->order[t];
		scalar_t d = sc_sub(u[j], uref[j]);
		if (uref[j] < SC_ZERO && d > 0)
			theta = sc_max(theta, sc_div(sc_neg(uref[j]), d));
		else if (uref[j] > SC(1) && d < 0)
			theta = sc_max(theta, sc_div(sc_sub(SC(1), uref[j]), d));
	}
	if (theta < SC(1)) {
		for (int t = 0; t < na; t++) {
			int j = m->order[t];
			scalar_t d = sc_sub(u[j], uref[j]);
			u[j] = sc_clamp(sc_add(uref[j], sc_mul(theta, d)), SC_ZERO, SC(1));
		}
	}
	return steps + refine(m, w, uref, u);
}

static void finish(const struct mixer *m, struct mixer_output *out)
{
	mixer_wrench(m, out->f_n, out->achieved);
	out->rotor_at_min = 0;
	out->rotor_at_max = 0;
	for (int j = 0; j < NR; j++) {
		if (!(m->present & (1u << j)))
			continue;
		if (out->f_n[j] <= sc_add(m->f_lo, m->at_tol))
			out->rotor_at_min |= (uint8_t)(1u << j);
		if (out->f_n[j] >= sc_sub(m->f_hi, m->at_tol))
			out->rotor_at_max |= (uint8_t)(1u << j);
	}
	if (out->rotor_at_min)
		out->limits |= MIXER_LIMIT_ROTOR_MIN;
	if (out->rotor_at_max)
		out->limits |= MIXER_LIMIT_ROTOR_MAX;
}

/* flags of axes whose achieved value differs from the demand (CLIP mode) */
static uint32_t axis_flags(const struct mixer *m, const struct mixer_output *out)
{
	static const uint32_t bit[NA] = { MIXER_LIMIT_F, MIXER_LIMIT_TX, MIXER_LIMIT_TY, MIXER_LIMIT_TZ };
	uint32_t f = 0;
	for (int i = 0; i < NA; i++) {
		scalar_t tol = sc_mul(m->row_scale[i], TOL_FLAG_REL);
		if (sc_abs(sc_sub(out->achieved[i], out->demanded[i])) > tol)
			f |= bit[i];
	}
	return f;
}

void mixer_update(const struct mixer *m, const scalar_t demand[NA], struct mixer_output *out)
{
	out->limits = 0;
	out->steps = 0;
	bool finite = true;
	for (int i = 0; i < NA; i++) {
		out->demanded[i] = demand[i];
		finite = finite && sc_isfinite(demand[i]);
	}
	if (!finite) {
		for (int j = 0; j < NR; j++)
			out->f_n[j] = SC_ZERO;
		out->limits = MIXER_LIMIT_BAD_INPUT;
		finish(m, out);
		return;
	}

	/* 1. eq. (15) */
	bool inside = true;
	for (int j = 0; j < NR; j++) {
		out->f_n[j] = dot4(m->pinv[j], demand);
		if (!(m->present & (1u << j))) {
			out->f_n[j] = SC_ZERO;
			continue;
		}
		if (out->f_n[j] < m->f_lo || out->f_n[j] > m->f_hi)
			inside = false;
	}
	if (inside) {
		finish(m, out);
		return;
	}
	if (m->p.mode != MIXER_MODE_PRIORITY || !m->alloc_ok) {
		if (m->p.mode == MIXER_MODE_PRIORITY)
			out->limits |= MIXER_LIMIT_NO_ALLOC;
		for (int j = 0; j < NR; j++)
			if (m->present & (1u << j))
				out->f_n[j] = sc_clamp(out->f_n[j], m->f_lo, m->f_hi);
		finish(m, out);
		out->limits |= axis_flags(m, out);
		return;
	}

	/* 3. priority allocation in the scaled space */
	scalar_t wd[NA], w[NA];
	for (int i = 0; i < NA; i++)
		wd[i] = to_scaled(m, i, demand[i]);
	int steps = 0;
	if (attainable_scaled(m, wd, TOL_ATT)) {
		for (int i = 0; i < NA; i++)
			w[i] = wd[i];
	} else {
		/* b. roll/pitch scale alpha with zero yaw, thrust free */
		scalar_t yaw0 = to_scaled(m, 3, SC_ZERO);
		scalar_t lo, hi, alpha = SC(1);
		w[3] = yaw0;
		w[1] = wd[1];
		w[2] = wd[2];
		if (!thrust_interval(m, w, &lo, &hi)) {
			scalar_t a_lo = SC_ZERO, a_hi = SC(1);
			w[1] = to_scaled(m, 1, SC_ZERO);
			w[2] = to_scaled(m, 2, SC_ZERO);
			if (!thrust_interval(m, w, &lo, &hi)) {
				/* zero torque unattainable: not a usable layout; fall back to clipping */
				for (int j = 0; j < NR; j++)
					if (m->present & (1u << j))
						out->f_n[j] = sc_clamp(out->f_n[j], m->f_lo, m->f_hi);
				finish(m, out);
				out->limits |= axis_flags(m, out) | MIXER_LIMIT_NO_ALLOC;
				return;
			}
			for (int it = 0; it < MIXER_ALPHA_ITERS; it++) {
				scalar_t mid = sc_mul(sc_add(a_lo, a_hi), SC(0.5));
				scalar_t t[NA] = { SC_ZERO, to_scaled(m, 1, sc_mul(mid, demand[1])),
						   to_scaled(m, 2, sc_mul(mid, demand[2])), yaw0 };
				scalar_t l2, h2;
				if (thrust_interval(m, t, &l2, &h2))
					a_lo = mid;
				else
					a_hi = mid;
				steps++;
			}
			alpha = a_lo;
			w[1] = to_scaled(m, 1, sc_mul(alpha, demand[1]));
			w[2] = to_scaled(m, 2, sc_mul(alpha, demand[2]));
			thrust_interval(m, w, &lo, &hi);
			if (demand[1] != SC_ZERO)
				out->limits |= MIXER_LIMIT_TX;
			if (demand[2] != SC_ZERO)
				out->limits |= MIXER_LIMIT_TY;
		}
		/* c. thrust nearest to the demand for which some yaw beta tau_z, beta in [0, 1],
		 * is attainable: exact when the demanded thrust itself or the zero-yaw slice
		 * allows it, else MIXER_ALPHA_ITERS bisection steps towards the demand */
		scalar_t dy = sc_sub(wd[3], yaw0), dy_dem = dy, blo, bhi;
		w[0] = sc_clamp(wd[0], lo, hi); /* attainable with beta = 0 */
		if (alpha < SC(1)) {
			/* roll/pitch saturated: no room is left for yaw; thrust from the zero-yaw slice */
			dy = SC_ZERO;
			if (w[0] != wd[0])
				out->limits |= MIXER_LIMIT_F;
		} else if (w[0] != wd[0]) {
			scalar_t ok_f = w[0];
			w[0] = wd[0];
			if (!yaw_interval(m, w, dy, &blo, &bhi)) {
				scalar_t bad_f = wd[0];
				for (int it = 0; it < MIXER_ALPHA_ITERS; it++) {
					w[0] = sc_add(sc_mul(ok_f, SC(0.5)), sc_mul(bad_f, SC(0.5)));
					if (yaw_interval(m, w, dy, &blo, &bhi))
						ok_f = w[0];
					else
						bad_f = w[0];
					steps++;
				}
				w[0] = ok_f;
				out->limits |= MIXER_LIMIT_F;
			}
		}
		/* d. yaw: the largest part of the demanded yaw attainable at that thrust (between
		 * zero and the demand: no yaw reversal) */
		scalar_t ty = SC_ZERO;
		if (dy != SC_ZERO && yaw_interval(m, w, dy, &blo, &bhi))
			ty = dy > 0 ? bhi : blo;
		if (ty != dy_dem && demand[3] != SC_ZERO)
			out->limits |= MIXER_LIMIT_TZ;
		w[3] = sc_add(yaw0, ty);
	}
	scalar_t u[NR];
	steps += preimage(m, w, u);
	for (int j = 0; j < NR; j++)
		out->f_n[j] = (m->present & (1u << j)) ? sc_add(m->f_lo, sc_mul(u[j], m->width)) : SC_ZERO;
	out->steps = (uint8_t)steps;
	finish(m, out);
}
