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

#include <common/mavlink.h>

#include "app.h"
#include "hal.h"
#include "mav.h"
#include "host.h"
#include "plant.h"
#include "xp_client.h"

#define SIL_QUEUE_BYTES 65536
#define SIL_TEXT_LEN 256

/* The firmware's datagrams on their way to the plant (filled by xp_client's send
 * hook, emptied into the plant once per pass). */
struct sil_queue {
	uint8_t buf[SIL_QUEUE_BYTES];
	size_t used;
	uint32_t overflow;
};

/* What the app last said on MAVLink, decoded (the mission reads it, as a ground
 * station would): acknowledgements, parameter values, and the status lines
 * (STATUSTEXT) that carry the firmware's reasons. */
struct sil_mav_seen {
	bool ack;                  /* a COMMAND_ACK since the last clear */
	uint16_t ack_command;
	uint8_t ack_result;
	bool exp_final;            /* the final ACK of MAV_CMD_USER_1 arrived */
	uint8_t exp_result;
	bool param;                /* a PARAM_VALUE since the last clear */
	char param_id[17];
	float param_value;
	uint64_t texts;            /* reports seen so far */
	char text[SIL_TEXT_LEN];   /* the last STATUSTEXT */
	char id_text[SIL_TEXT_LEN];/* the last "ID ..." STATUSTEXT */
	bool phase_failed;         /* a final COMMAND_ACK FAILED of take-off or landing (its time limit) */
	char fail_text[SIL_TEXT_LEN];/* the last error line saying "failed", and the error lines after it */
	char chunks[SIL_TEXT_LEN]; /* a long STATUSTEXT's chunks so far (id chunk_id, next chunk_next) */
	uint16_t chunk_id;
	uint8_t chunk_next;
};

struct mission;

struct sil {
	octo_plant *plant;
	struct xp_client xp;
	struct sockaddr_in xplane;     /* the plant's address as the client sees it */
	struct hal hal;                /* sil.c's functions, ctx = this struct */
	struct app app;
	struct mav mav;                /* the app's MAVLink endpoint */
	struct param_file params;      /* --params (hal/host/param_file.c) */
	struct lcm_log log;            /* --lcm-fw (hal/host/lcm_log.c) */
	struct hal_sensor_frame frame; /* persistent: absent rows keep their values */
	struct sil_queue to_plant;
	uint8_t from_plant[4096];      /* one plant datagram on its way to the client */
	uint64_t now_us;               /* the platform clock (see hal_wall_us in sil.c) */
	bool wall_clock;               /* MAVLink served: telemetry rates in wall time */
	bool quiet;

	/* MAVLink to a ground station (optional) */
	int mav_fd;
	struct sockaddr_in gcs;
	/* MAVLink parser and sender state of the mission (the library's per-channel
	 * globals are not used): the app's output is parsed here, the mission's
	 * messages are sequenced here */
	mavlink_message_t rx_msg;
	mavlink_status_t rx_status, gcs_tx;
	struct sil_mav_seen seen;

	struct mission *mission;
	uint64_t withheld, unanswered;
};

#endif /* OCTO_SIL_H */
