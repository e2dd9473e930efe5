/*
 * script.h - the ground station's part of a flight as steps on the platform's clock
 * (octo-sil --script). One step per line or separated by ';', '#' starts a comment:
 *   param NAME VALUE   PARAM_SET, the echoed PARAM_VALUE must hold VALUE
 *   arm                MAV_CMD_COMPONENT_ARM_DISARM (retried until the vehicle has frames)
 *   takeoff H          MAV_CMD_NAV_TAKEOFF to H m
 *   wait hold          until the vehicle holds
 *   experiment N       MAV_CMD_USER_1 (retried while the vehicle is not hovering yet)
 *   wait experiment    until its final COMMAND_ACK; anything but ACCEPTED fails
 *   land               MAV_CMD_NAV_LAND
 *   wait disarmed      until the vehicle has landed and disarmed
 *   sleep S            S seconds of simulated time
 * Commands are packed MAVLink 2 messages handed to mav_receive, the path a ground
 * station's bytes take; the app's answers come back through script_on_vehicle.
 */
#ifndef OCTO_SIL_SCRIPT_H
#define OCTO_SIL_SCRIPT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "app.h"
#include "mav.h"

struct script;

/* Parses FILE (when `spec` names a readable file) or the text itself. NULL on
 * error, with the message (naming the step) on stderr. quiet: no line per step done. */
struct script *script_parse(const char *spec, bool quiet);
void script_free(struct script *sc);

/* One MAVLink message the app sent (as a ground station receives it): acknowledgements,
 * parameter values and status lines are kept for the steps, the rest is skipped. */
void script_on_vehicle(struct script *sc, const uint8_t *buf, size_t len);

/* Runs the current step once (between frames) on `app` at platform time now_us. Returns
 * 0 while running, 1 when every step completed, -1 when a step failed (message on stderr). */
int script_run(struct script *sc, struct app *app, struct mav *mav, uint64_t now_us);
/* Fails the current step for a reason outside the script (the plant crashed): -1. */
int script_abort(struct script *sc, struct app *app, struct mav *mav, const char *why);
/* The message of the failure or of the step not completed, for the exit line. */
const char *script_pending(struct script *sc);

#endif /* OCTO_SIL_SCRIPT_H */
