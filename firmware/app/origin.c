/* origin.c - the plant's local position made continuous across origin shifts (see origin.h). */
#include "origin.h"

#include <math.h>
#include <string.h>

#include "fcmp.h"

#define EARTH_R_M 6371008.8 /* mean radius: a flat earth over one frame's step */
#define DEG_TO_RAD 0.017453292519943295

void origin_init(struct origin *o) { memset(o, 0, sizeof *o); }

static bool has_geo(const struct hal_sensor_frame *f) { return (f->valid & HAL_FRAME_GLOBAL) != 0u; }

/* The geodetic step from the previous frame in NWU metres (only when a shift is suspected). */
static void geo_step(const struct origin *o, const struct hal_sensor_frame *f, float d[3])
{
	const double lat_r = 0.5 * (f->lat_deg + o->lat_prev) * DEG_TO_RAD;
	d[0] = (float)((f->lat_deg - o->lat_prev) * DEG_TO_RAD * EARTH_R_M);
	d[1] = (float)(-(f->lon_deg - o->lon_prev) * DEG_TO_RAD * EARTH_R_M * cos(lat_r));
	d[2] = f->alt_msl_m - o->alt_prev;
}

static float max_abs3(const float v[3])
{
	float m = fabsf(v[0]);
	if (fabsf(v[1]) > m)
		m = fabsf(v[1]);
	if (fabsf(v[2]) > m)
		m = fabsf(v[2]);
	return m;
}

/* Whether the step raw - raw_prev over dt seconds is a shift; `cont` gets the step the
 * position really made (for the continuation). */
static bool is_shift(const struct origin *o, const struct hal_sensor_frame *f, float dt, float cont[3])
{
	const float *raw = f->pos_i_m;
	float step[3], by_vel[3];
	for (int i = 0; i < 3; i++)
		step[i] = raw[i] - o->raw_prev[i];
	const bool gap = dt > ORIGIN_GAP_S;
	if (!gap && max_abs3(step) <= ORIGIN_STEP_M + ORIGIN_SPEED_MPS * dt)
		return false;       /* the common case: a step a vehicle can make */
	for (int i = 0; i < 3; i++) /* the step the velocities make */
		by_vel[i] = 0.5f * (f->vel_i_mps[i] + o->vel_prev[i]) * dt;
	if (has_geo(f) && o->geo_prev) {
		float geo[3], e[3];
		geo_step(o, f, geo);
		for (int i = 0; i < 3; i++)
			e[i] = step[i] - geo[i];
		if (max_abs3(e) <= ORIGIN_GEO_TOL_M)
			return false; /* the geodetic position moved as much */
		memcpy(cont, gap ? geo : by_vel, sizeof by_vel);
		return true;
	}
	if (gap && max_abs3(step) <= ORIGIN_STEP_M + ORIGIN_SPEED_MPS * dt)
		return false;
	memcpy(cont, by_vel, sizeof by_vel);
	return true;
}

bool origin_correct(struct origin *o, struct hal_sensor_frame *f)
{
	if (!(f->valid & HAL_FRAME_POS))
		return false;
	float *p = f->pos_i_m;
	if (o->have && !app_t_before(o->t_prev, f->t_s)) {
		/* not newer than the last frame: the offset of its time, nothing learned */
		const float *off = o->shifts && app_t_before(f->t_s, o->t_shift) ? o->off_before : o->off;
		for (int i = 0; i < 3; i++)
			p[i] += off[i];
		return false;
	}
	bool shift = false;
	float cont[3];
	if (o->have && is_shift(o, f, app_t_gap(f->t_s, o->t_prev), cont)) {
		memcpy(o->off_before, o->off, sizeof o->off);
		for (int i = 0; i < 3; i++) {
			/* corrected = previous corrected + the step made */
			o->last_step[i] = p[i] - o->raw_prev[i] - cont[i];
			o->off[i] = o->raw_prev[i] + o->off[i] + cont[i] - p[i];
		}
		o->t_shift = f->t_s;
		o->shifts++;
		shift = true;
	}
	o->have = true;
	o->t_prev = f->t_s;
	for (int i = 0; i < 3; i++) { /* by assignment: a library memcpy costs more for three words */
		o->raw_prev[i] = p[i];
		o->vel_prev[i] = f->vel_i_mps[i];
	}
	o->geo_prev = has_geo(f);
	if (o->geo_prev) {
		o->lat_prev = f->lat_deg;
		o->lon_prev = f->lon_deg;
		o->alt_prev = f->alt_msl_m;
	}
	for (int i = 0; i < 3; i++)
		p[i] += o->off[i];
	return shift;
}
