/*
 * sil.h - octo-sil: the app on an in-process platform beside octo-sim's plant.
 *
 * All the platform's state is one struct sil reached through one pointer. The
 * plant link is X-Plane's protocol as bytes: the plant's datagrams go through
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

/* What the app last said on MAVLink, decoded (the mission reads it). */
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
	char text[SIL_TEXT_LEN];   /* the last report (STATUSTEXT or console) */
	char id_text[SIL_TEXT_LEN];/* the last "ID ..." report */
};

struct mission;

struct sil {
	octo_plant *plant;
	struct xp_client xp;
	struct sockaddr_in xplane;     /* the plant's address as the client sees it */
	struct app app;
	struct hal_sensor_frame frame; /* persistent: absent rows keep their values */
	struct sil_queue to_plant;
	uint8_t from_plant[4096];      /* one plant datagram on its way to the client */
	uint64_t now_us;               /* the platform clock (see hal_wall_us in sil.c) */
	bool wall_clock;               /* MAVLink served: telemetry rates in wall time */
	bool quiet;

	/* MAVLink to a ground station (optional) */
	int mav_fd;
	struct sockaddr_in gcs;
	uint8_t mav_chan_rx;           /* parser channel for the app's output */
	struct sil_mav_seen seen;

	struct mission *mission;
	uint64_t withheld, unanswered;
};

/* The one instance: hal.h has no context argument, so the hal functions reach
 * the platform through this pointer (set by main before app_init). */
extern struct sil *sil_ctx;

#endif /* OCTO_SIL_H */
