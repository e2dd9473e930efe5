/* excite.c - see excite.h. */
#include "excite.h"

/* Galois LFSR masks (right shift) of maximum length for orders 2..16 */
static const uint32_t excite_taps[17] = {
	0, 0, 0x3, 0x6, 0xC, 0x14, 0x30, 0x60, 0xB8, 0x110, 0x240, 0x500, 0xE08, 0x1C80, 0x3802, 0x6000, 0xB400,
};

#define EXCITE_SEED_DEFAULT 0x2545F491u

struct excite_params excite_params_default(void)
{
	struct excite_params p;
	p.kind = EXCITE_UNIFORM;
	p.amplitude = SC(0.05);
	p.clock_div = 1;
	p.seed = 1;
	p.prbs_order = 9;
	p.ms_period_frames = 180;
	p.ms_count = 8;
	p.ms_k_first = 1;
	return p;
}

static uint32_t xorshift32(uint32_t *s)
{
	uint32_t x = *s;
	x ^= x << 13;
	x ^= x >> 17;
	x ^= x << 5;
	*s = x;
	return x;
}

/* sin(2 pi phase / 2^32): quarter-wave symmetry, then the odd Taylor polynomial of
 * sin(pi/2 x) to x^9 (error < 4e-6) on x in [0, 1] with 15-bit resolution of x. */
#if OCTO_FIXED
#if defined(__GNUC__)
#define EXC_INLINE static inline __attribute__((always_inline))
#else
#define EXC_INLINE static inline
#endif
/* x y 2^-16 rounded to nearest for 0 <= x <= 2^16 and 0 <= y < 2^17 (Q16.16): what sc_mul
 * gives for these operands, in a 16 x 16 product and an add (no sign, carry or saturation
 * case can arise). Every operand of the sine's polynomial is of this kind. */
EXC_INLINE uint32_t ms_mul(uint32_t x, uint32_t y)
{
	if (x >> 16) /* x = 1 */
		return y;
	return ((x * (y & 0xffffu) + 0x8000u) >> 16) + ((y >> 16) ? x : 0u);
}

/* the polynomial below in unsigned Q16.16: x and x^2 in [0, 1], and each Horner value
 * c_k - x^2 p positive and below 1.571 (the coefficients fall faster than x^2 can grow
 * them), so that each sc_mul and sc_sub of the float build's form is ms_mul and a plain
 * subtraction, bit for bit */
EXC_INLINE scalar_t excite_sin(uint32_t phase)
{
	uint32_t quadrant = phase >> 30;
	uint32_t x = ((phase & 0x3FFFFFFFu) >> 15) << 1; /* [0, 32767] / 32768 in Q16.16 */
	if (quadrant & 1u)
		x = (uint32_t)SC(1) - x;
	uint32_t x2 = ms_mul(x, x);
	uint32_t p = (uint32_t)SC(0.0046817541) - ms_mul(x2, (uint32_t)SC(0.0001604411));
	p = (uint32_t)SC(0.0796926262) - ms_mul(x2, p);
	p = (uint32_t)SC(0.6459640975) - ms_mul(x2, p);
	p = (uint32_t)SC(1.5707963268) - ms_mul(x2, p);
	uint32_t s = ms_mul(x, p);
	if (s > (uint32_t)SC(1))
		s = (uint32_t)SC(1);
	return (quadrant & 2u) ? -(scalar_t)s : (scalar_t)s;
}

/* normalised multisine sum(sin(phase_k)) / N at the current phases: the sum of N values
 * within +/-1 cannot saturate, and sc_div's quotient by the integer N, round(|sum| / N) with
 * ties away from zero, is floor((2 |sum| + N) / (2 N)) with the sum's sign: one integer
 * division */
static scalar_t excite_ms_raw(const struct excite *e)
{
	int32_t sum = 0;
	uint32_t n = e->p.ms_count;
	for (uint32_t k = 0; k < n; k++)
		sum += excite_sin(e->phase[k]);
	uint32_t q = (2u * (uint32_t)(sum < 0 ? -sum : sum) + n) / (2u * n);
	return sum < 0 ? -(scalar_t)q : (scalar_t)q;
}
#else
static scalar_t excite_sin(uint32_t phase)
{
	uint32_t quadrant = phase >> 30;
	int32_t v = (int32_t)((phase & 0x3FFFFFFFu) >> 15); /* [0, 32767] */
	scalar_t x = sc_mul(sc_from_int(v), SC(1.0 / 32768.0));
	if (quadrant & 1u)
		x = sc_sub(SC(1), x);
	scalar_t x2 = sc_mul(x, x);
	scalar_t p = sc_sub(SC(0.0046817541), sc_mul(x2, SC(0.0001604411)));
	p = sc_sub(SC(0.0796926262), sc_mul(x2, p));
	p = sc_sub(SC(0.6459640975), sc_mul(x2, p));
	p = sc_sub(SC(1.5707963268), sc_mul(x2, p));
	scalar_t s = sc_clamp(sc_mul(x, p), SC_ZERO, SC(1));
	return (quadrant & 2u) ? sc_neg(s) : s;
}

/* normalised multisine sum(sin(phase_k)) / N at the current phases */
static scalar_t excite_ms_raw(const struct excite *e)
{
	scalar_t sum = SC_ZERO;
	for (uint32_t k = 0; k < e->p.ms_count; k++)
		sum = sc_add(sum, excite_sin(e->phase[k]));
	return sc_div(sum, sc_from_int((int32_t)e->p.ms_count));
}
#endif

static void excite_ms_step(struct excite *e)
{
	for (uint32_t k = 0; k < e->p.ms_count; k++)
		e->phase[k] += e->dphase1 * (e->p.ms_k_first + k);
}

static void excite_ms_start(struct excite *e)
{
	uint32_t n = e->p.ms_count;
	uint32_t d1 = (uint32_t)((((uint64_t)1 << 32) + e->p.ms_period_frames / 2) / e->p.ms_period_frames);
	for (uint32_t k = 0; k < EXCITE_MS_MAX; k++)
		e->phase[k] = 0;
	e->dphase1 = d1;
	for (uint32_t k = 1; k <= n; k++) {
		/* Schroeder: -k (k - 1) / (2 N) turn */
		uint64_t turns = ((uint64_t)k * (k - 1u) << 31) / n;
		e->phase[k - 1] = 0u - (uint32_t)turns;
	}
}

/* what the phases do after a sample (struct excite, ms_due) */
#define EXCITE_MS_NONE 0u
#define EXCITE_MS_STEP 1u
#define EXCITE_MS_RESTART 2u

void excite_prepare(struct excite *e)
{
	if (e->p.kind != EXCITE_MULTISINE || e->ms_ready)
		return;
	if (e->ms_due == EXCITE_MS_STEP)
		excite_ms_step(e);
	else if (e->ms_due == EXCITE_MS_RESTART)
		excite_ms_start(e);
	e->ms_due = EXCITE_MS_NONE;
	e->ms_next = excite_ms_raw(e);
	e->ms_ready = true;
}

void excite_init(struct excite *e, const struct excite_params *params)
{
	e->p = *params;
	struct excite_params *p = &e->p;
	p->amplitude = sc_max(p->amplitude, SC_ZERO);
	if (p->clock_div == 0)
		p->clock_div = 1;
	if (p->seed == 0)
		p->seed = EXCITE_SEED_DEFAULT;
	p->prbs_order = p->prbs_order < 2 ? 2 : (p->prbs_order > 16 ? 16 : p->prbs_order);
	if (p->ms_period_frames < 4)
		p->ms_period_frames = 4;
	p->ms_count = p->ms_count < 1 ? 1 : (p->ms_count > EXCITE_MS_MAX ? EXCITE_MS_MAX : p->ms_count);
	if (p->ms_k_first < 1)
		p->ms_k_first = 1;

	e->rng = p->seed;
	uint32_t len = ((uint32_t)1 << p->prbs_order) - 1u;
	e->lfsr = p->seed % len + 1u;
	e->lfsr_taps = excite_taps[p->prbs_order];
	e->count = 0;
	e->value = SC_ZERO;
	e->ms_scale = SC_ZERO;
	e->ms_due = EXCITE_MS_NONE;
	e->ms_ready = false;
	e->ms_next = SC_ZERO;

	/* multisine: scan one period for the peak of the normalised sum */
	excite_ms_start(e);
	if (p->kind == EXCITE_MULTISINE) {
		scalar_t peak = SC_ZERO;
		uint32_t scan = p->ms_period_frames < EXCITE_MS_PEAK_SCAN ? p->ms_period_frames : EXCITE_MS_PEAK_SCAN;
		for (uint32_t i = 0; i < scan; i++) {
			peak = sc_max(peak, sc_abs(excite_ms_raw(e)));
			excite_ms_step(e);
		}
		e->ms_scale = peak > SC_ZERO ? sc_div(p->amplitude, peak) : SC_ZERO;
		excite_ms_start(e);
	}
}

scalar_t excite_update(struct excite *e)
{
	const struct excite_params *p = &e->p;
	scalar_t a = p->amplitude;
	scalar_t y = SC_ZERO;
	switch (p->kind) {
	case EXCITE_UNIFORM:
		if (e->count == 0) {
			int32_t v = (int32_t)(xorshift32(&e->rng) >> 17); /* [0, 32767] */
			scalar_t u = sc_div(sc_from_int(2 * v - 32767), sc_from_int(32767));
			e->value = sc_mul(a, u);
		}
		if (++e->count >= p->clock_div) /* count < clock_div: no division */
			e->count = 0;
		y = e->value;
		break;
	case EXCITE_PRBS:
		if (e->count == 0) {
			uint32_t bit = e->lfsr & 1u;
			e->lfsr >>= 1;
			if (bit)
				e->lfsr ^= e->lfsr_taps;
			e->value = bit ? a : sc_neg(a);
		}
		if (++e->count >= p->clock_div)
			e->count = 0;
		y = e->value;
		break;
	case EXCITE_MULTISINE:
		excite_prepare(e); /* when it was not done between frames */
		y = sc_mul(e->ms_scale, e->ms_next);
		e->ms_ready = false;
		/* restart the phases every period: exactly periodic, the phase jump at the
		 * restart is below P / 2^33 of a turn; the phases move before the next sum
		 * (excite_prepare) */
		if (++e->count >= p->ms_period_frames) {
			e->count = 0;
			e->ms_due = EXCITE_MS_RESTART;
		} else {
			e->ms_due = EXCITE_MS_STEP;
		}
		break;
	case EXCITE_OFF:
	default: y = SC_ZERO; break;
	}
	return sc_clamp(y, sc_neg(a), a);
}

void excite_null_pattern(unsigned k, scalar_t out[EXCITE_ROTORS])
{
	/* as scalar_t already: the rotor experiment asks for two patterns every step */
	static const scalar_t pat[EXCITE_NULL_PATTERNS][EXCITE_ROTORS] = {
		{SC(1), SC(0), SC(-1), SC(0), SC(1), SC(0), SC(-1), SC(0)},
		{SC(0), SC(1), SC(0), SC(-1), SC(0), SC(1), SC(0), SC(-1)},
		{SC(1), SC(1), SC(-1), SC(-1), SC(1), SC(1), SC(-1), SC(-1)},
	};
	const scalar_t *src = k < EXCITE_NULL_PATTERNS ? pat[k] : NULL;
	for (unsigned j = 0; j < EXCITE_ROTORS; j++)
		out[j] = src ? src[j] : SC_ZERO;
}

scalar_t excite_offset_level(uint32_t frame, uint32_t seg_frames)
{
	static const int8_t lv[4] = {1, 0, -1, 0};
	uint32_t seg = seg_frames > 0u ? seg_frames : 1u;
	return sc_from_int(lv[(frame / seg) % 4u]);
}
