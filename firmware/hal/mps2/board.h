/*
 * board.h - octo-fw on the MPS2 AN386 board (Cortex-M4F), as QEMU's mps2-an386 emulates it:
 * the platform of processor-in-the-loop flights (docs/pil.md).
 *
 * One struct board holds the platform's state: the app and its MAVLink endpoint, the X-Plane
 * client of hal/host (its socket-free part), the three links' framing state, the parameter
 * sector and the log records waiting to be sent. main.c polls the links and the timer, runs
 * one control step per X-Plane frame and ticks the app and the endpoint on every pass.
 *
 *   cmsdk.h   the UARTs and the timer
 *   slip.c    SLIP frames with a CRC-32 (plant and log links)
 *   logenc.c  the log records (LCM's encoding of octo.fw_frame_t and friends)
 *   posix.c   the socket calls xp_client.c names, failing: the board has no IP stack
 *   main.c    the struct hal, the links and the loop
 *
 * A step is app_on_frame() alone, between board_step_begin() and board_step_end(): the
 * markers QEMU's instruction-counting plugin watches. What the app hands the platform in
 * a step (throttles, events) is kept and sent after the step; the frame's log record comes
 * at the frame boundary (app_tick) and is sent after it.
 */
#ifndef OCTO_MPS2_BOARD_H
#define OCTO_MPS2_BOARD_H

#include <stdbool.h>
#include <stdint.h>

#include "app.h"
#include "hal.h"
#include "id_result.h"
#include "mav.h"
#include "slip.h"
#include "xp_client.h"

#define BOARD_PARAM_CAP 8192 /* the parameter sector */
#define BOARD_EVENTS 8       /* log events a step or a pass may leave */
#define BOARD_EVENT_TEXT 200
#define BOARD_MAV_CAP 280  /* the longest MAVLink 2 packet (signed) */
#define BOARD_TICK_US 5000 /* the idle wake-up's period: app_tick and mav_tick at least this often */
#define BOARD_SPIN_US 200  /* polling goes on this long after the last byte before WFI */

/* Log record types on the log link (the first byte of a frame). */
enum board_rec {
	BOARD_REC_FRAME = 'F', /* octo.fw_frame_t without its fingerprint */
	BOARD_REC_EVENT = 'E', /* utime (int64), severity (int8), text */
	BOARD_REC_ID = 'I',    /* octo.fw_id_result_t without its fingerprint */
};

struct board_event {
	uint8_t kind; /* BOARD_REC_EVENT or BOARD_REC_ID */
	int8_t severity;
	double t_s;
	struct app_id_result id;
	char text[BOARD_EVENT_TEXT];
};

struct board {
	struct app app;
	struct mav mav;
	struct hal hal;
	struct xp_client xp;
	struct hal_sensor_frame frame; /* persistent: absent rows keep their values */
	struct sockaddr_in plant_addr; /* stands for the bridge at the other end of UART0 */

	/* clock: TIMER0 extended to 64 bits on every pass */
	uint32_t timer_last;
	uint64_t ticks;
	uint64_t now_us;     /* the pass's time: what wall_us answers */
	uint64_t rx_last_us; /* the last pass that received a byte */

	/* links */
	struct slip_rx plant_rx;
	unsigned lane; /* the plant lane the next byte comes on */
	struct slip_tx plant_tx, log_tx;
	uint8_t mav_rx[BOARD_MAV_CAP];
	size_t mav_n;
	uint32_t mav_junk; /* ground bytes outside any packet */

	/* what a step hands over, sent after it */
	float thr[HAL_ROTORS];
	bool actuate;
	const struct app_log_frame *log_pending;
	struct board_event events[BOARD_EVENTS];
	unsigned ev_head, ev_n;
	uint32_t ev_lost;

	/* parameter storage: a RAM sector (kept while the board is powered) */
	char param[BOARD_PARAM_CAP];
	long param_len; /* -1: never stored */

	uint32_t steps;
};

/* Encodes a log record body (logenc.c): returns its length (at most cap). */
size_t board_enc_frame(uint8_t *buf, size_t cap, const struct app_log_frame *f);
size_t board_enc_event(uint8_t *buf, size_t cap, double t_s, int severity, const char *text);
size_t board_enc_id(uint8_t *buf, size_t cap, double t_s, const struct app_id_result *r);

void board_step_begin(void);
void board_step_end(void);

#endif /* OCTO_MPS2_BOARD_H */
