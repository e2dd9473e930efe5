/* mav_lib.h - the MAVLink library as the endpoint's files (mav.c, mav_telem.c,
 * mav_ftp.c) include it, instead of <octo/mavlink.h>.
 *
 * The library keeps each channel's status (sequence number, signing) and receive
 * buffer in static arrays inside its inline helpers: one copy in every file that
 * includes it, one entry per possible channel. The endpoint has one channel;
 * mav.c owns its status and buffer (these two functions), so that every message
 * packed in any of the three files is numbered and signed on that one status.
 */
#ifndef OCTO_MAV_LIB_H
#define OCTO_MAV_LIB_H

#include <stdint.h>

#define MAVLINK_GET_CHANNEL_STATUS
#define MAVLINK_GET_CHANNEL_BUFFER
#include <mavlink_types.h>

mavlink_status_t *mavlink_get_channel_status(uint8_t chan);
mavlink_message_t *mavlink_get_channel_buffer(uint8_t chan);

#include <octo/mavlink.h>

#endif
