/*
 * rotor_guard.h - the app's side of rotor failure (core/rotor_fail.h finds it): once a
 * frame, the detector is fed the last step's throttles and what the frame measured of the
 * rotors; on a detection the rotor's MOT_SCALEj becomes the detected effectiveness (0: left
 * out of the allocation), the mixer is rebuilt before the next step, an experiment in
 * progress stops with the rotor named, a critical status line says so, and after the
 * detector's hold the vehicle lands.
 */
#ifndef OCTO_ROTOR_GUARD_H
#define OCTO_ROTOR_GUARD_H

#include <stdbool.h>

struct app;
struct app_params;
struct rotor_fail;

void rotor_guard_init(struct rotor_fail *rf);
/* The detector's rotor model from the parameters (with the mixer's, between frames). */
void rotor_guard_sync(struct rotor_fail *rf, const struct app_params *p);
/* One frame, before the control step; dt is the step's time. */
void rotor_guard_step(struct app *a, float dt);
/* A rotor is known failed (its scale 0, or found failed and not set anew). */
bool rotor_guard_failed(const struct rotor_fail *rf);

#endif /* OCTO_ROTOR_GUARD_H */
