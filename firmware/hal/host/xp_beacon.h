/*
 * xp_beacon.h - finding X-Plane by its BECN beacon (host platform).
 *
 * X-Plane 11 and 12 announce themselves once a second on multicast
 * 239.255.1.1:49707: '<BBiiIH' = beacon major (1), minor (1 on 11, 2 on 12),
 * host (1 = X-Plane), version number (e.g. 120100), role (1 = master), receive
 * port; then the computer name NUL-terminated (12 adds a uint16 after it).
 * X-Plane is at the beacon's source address and listens on its receive port.
 */
#ifndef OCTO_XP_BECON_H
#define OCTO_XP_BECON_H

#include <netinet/in.h>
#include <signal.h>
#include <stddef.h>
#include <stdint.h>

struct xp_beacon {
	struct sockaddr_in addr; /* where X-Plane receives: source IP, announced port */
	uint8_t major, minor;
	int32_t version; /* e.g. 120100 for 12.1.0 */
	char name[64];   /* computer name (cut, NUL-terminated) */
};

/* Decodes one datagram: 0 when it is an X-Plane master's beacon, -1 otherwise. */
int xp_beacon_decode(const uint8_t *p, size_t n, struct xp_beacon *out);

/* Waits up to timeout_s for the first X-Plane master's beacon, or until one of
 * the (blocked) signals in stop_set is pending (it stays pending for the caller).
 * 0 with *out filled, -1 on timeout, stop or a socket error (reason on stderr). */
int xp_beacon_find(double timeout_s, const sigset_t *stop_set, struct xp_beacon *out);

#endif
