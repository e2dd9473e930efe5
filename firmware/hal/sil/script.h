/*
 * mission.h - the ground station's part of a flight as steps on the platform's
 * clock (octo-sil --mission). One step per line or separated by ';', '#' starts
 * a comment:
 *   param NAME VALUE   PARAM_SET, the echoed PARAM_VALUE must hold VALUE
 *   arm                MAV_CMD_COMPONENT_ARM_DISARM (retried until the vehicle has frames)
 *   takeoff H          MAV_CMD_NAV_TAKEOFF to H m
 *   wait hold          until the vehicle holds
 *   experiment N       MAV_CMD_USER_1 (retried while the vehicle is not hovering yet)
 *   wait experiment    until its final COMMAND_ACK; anything but ACCEPTED fails
 *   land               MAV_CMD_NAV_LAND
 *   wait disarmed      until the vehicle has landed and disarmed
 *   sleep S            S seconds of simulated time
 * Commands are packed MAVLink 2 messages handed to app_on_ground, the path a
 * ground station's bytes take.
 */
#ifndef OCTO_SIL_MISSION_H
#define OCTO_SIL_MISSION_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

struct sil;
struct mission;

/* Parses FILE (when `spec` names a readable file) or the text itself. NULL on
 * error, with the message (naming the step) on stderr. */
struct mission *mission_parse(const char *spec);
void mission_free(struct mission *m);

/* Runs the current step once (between frames). Returns 0 while running, 1 when
 * every step completed, -1 when a step failed (message on stderr). */
int mission_run(struct mission *m, struct sil *s);
/* Fails the current step for a reason outside the mission (the plant crashed): -1. */
int mission_abort(struct mission *m, struct sil *s, const char *why);
/* The message of the failure or of the step not completed, for the exit line. */
const char *mission_pending(struct mission *m);

#endif /* OCTO_SIL_MISSION_H */
