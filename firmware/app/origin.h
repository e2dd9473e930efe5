/*
 * origin.h - one continuous local frame across the plant's origin shifts.
 *
 * X-Plane keeps its local (OpenGL) origin near the aircraft and moves it when the
 * aircraft crosses a scenery boundary or the scenery reloads: the local position then
 * jumps by kilometres between two frames while latitude, longitude, altitude and the
 * velocities stay continuous. origin_correct() adds an offset to each frame's position
 * so that everything after it (control, identification, logs, telemetry) sees one
 * continuous frame.
 *
 * A shift is a step between two frames that the position cannot have made: larger than
 * ORIGIN_STEP_M plus ORIGIN_SPEED_MPS times the time between them, and (when both frames
 * carry the geodetic position) disagreeing with the geodetic displacement by more than
 * ORIGIN_GEO_TOL_M. Gaps longer than ORIGIN_GAP_S are always checked against the geodetic
 * displacement. At a shift the offset absorbs the step: the corrected position continues
 * from the previous one by the mean velocity over the step (by the geodetic displacement
 * after a gap), so the frame after the shift lies where the velocities put it.
 *
 * A frame older than the newest (reordered or delayed) takes the offset of its time.
 * The offset starts at zero: until the first shift the corrected position is the plant's.
 */
#ifndef OCTO_APP_ORIGIN_H
#define OCTO_APP_ORIGIN_H

#include <stdbool.h>
#include <stdint.h>

#include "hal.h"

#define ORIGIN_STEP_M 50.0f /* a step larger than this (plus speed x time) is a shift */
#define ORIGIN_SPEED_MPS 100.0f
#define ORIGIN_GEO_TOL_M 25.0f /* local and geodetic steps disagree by more: a shift */
#define ORIGIN_GAP_S 1.0f      /* a longer gap is checked against the geodetic step */

struct origin {
	bool have;         /* a previous frame with a position */
	double t_prev;     /* its plant time */
	float raw_prev[3]; /* its plant position (NWU, m) and velocity */
	float vel_prev[3];
	bool geo_prev; /* it carried the geodetic position */
	double lat_prev, lon_prev;
	float alt_prev;
	float off[3];        /* added to the plant position (NWU, m) */
	float off_before[3]; /* the offset before the last shift */
	double t_shift;      /* plant time of the first frame after the last shift */
	uint32_t shifts;     /* shifts absorbed */
	float last_step[3];  /* the last shift's step in the plant position, m */
};

void origin_init(struct origin *o);

/* Corrects f->pos_i_m in place; returns true when this frame brought a shift. */
bool origin_correct(struct origin *o, struct hal_sensor_frame *f);

#endif /* OCTO_APP_ORIGIN_H */
