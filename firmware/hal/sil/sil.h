/*
 * sil.h - octo-sil: the app on an in-process platform beside octo-sim's plant.
 *
 * All the platform's state is one struct sil, allocated by main(); its struct
 * hal (sil.c) has the struct sil as ctx, so no state lives at file scope. The
 * parameter file and the LCM log are hal/host's (param_file.c, lcm_log.c) with
 * their contexts kept here. The plant link is X-Plane's protocol as bytes: the plant's datagrams go through
 * octo-fw's X-Plane client (xp_client.c, its decoder and conventions), the
 * client's requests and throttles (its encoder) through the plant's decoder,
 * with no socket in between. Lockstep by construction: each pass of the loop is
 * one frame; the plant advances when the firmware has answered it.
 */
#ifndef OCTO_SIL_H
#define OCTO_SIL_H

#include <netinet/in.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "app.h"
#include "hal.h"
#include "mav.h"
#include "host.h"
#include "plant.h"
#include "xp_client.h"

#define SIL_QUEUE_BYTES 65536

/* The firmware's datagrams on their way to the plant (filled by xp_client's send
 * hook, emptied into the plant once per pass). */
struct sil_queue {
	uint8_t buf[SIL_QUEUE_BYTES];
	size_t used;
	uint32_t overflow;
};

/* ---- cmdline.c: octo-sil's own flags; the rest are the plant's (plant_argv, for
 * octo_plant_create, allocated: the caller frees it). */
struct sil_config {
	const char *params, *lcm_fw, *lcm_sim, *script;
	uint16_t mav_listen; /* 0: no ground station served */
	struct sockaddr_in gcs;
	double duration; /* simulated seconds, 0: no limit */
	enum xp_actuation act;
	bool quiet;
	unsigned log_every; /* --log-every N: both logs (0 with --log-phases alone) */
	bool log_phases;    /* --log-phases: the firmware's frames during experiments */
	int plant_argc;
	char **plant_argv;
};
/* Fills *cfg from argv. Returns -1 to run, or the exit status (0 after --help, 1 or 2
 * after an error, reported on stderr). */
int sil_parse_args(int argc, char **argv, struct sil_config *cfg);

struct script;

struct sil {
	octo_plant *plant;
	struct xp_client xp;
	struct sockaddr_in xplane; /* the plant's address as the client sees it */
	struct hal hal;            /* sil.c's functions, ctx = this struct */
	struct app app;
	struct mav mav;                /* the app's MAVLink endpoint */
	struct param_file params;      /* --params (hal/host/param_file.c) */
	struct lcm_log log;            /* --lcm-fw (hal/host/lcm_log.c) */
	struct hal_sensor_frame frame; /* persistent: absent rows keep their values */
	struct sil_queue to_plant;
	uint8_t from_plant[4096]; /* one plant datagram on its way to the client */
	uint64_t now_us;          /* the platform clock (see hal_wall_us in sil.c) */
	bool wall_clock;          /* MAVLink served: telemetry rates in wall time */
	bool quiet;

	/* MAVLink to a ground station (optional) */
	int mav_fd;
	struct sockaddr_in gcs;

	struct script *script; /* --script: the ground station's steps (script.c) */
	uint64_t withheld, unanswered;
};

#endif /* OCTO_SIL_H */
