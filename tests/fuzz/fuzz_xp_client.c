/*
 * fuzz_xp_client.c - libFuzzer harness of octo-fw's X-Plane receive path:
 * xp_decode (xp_proto.c) and the client that uses it (xp_client.c: sender
 * check, RREF version, row bookkeeping and USEL, convention conversion, time
 * re-basing), with poll and actuation in between.
 *
 * xp_client.c is compiled with -Drecvfrom=fuzz_recvfrom -Dsendto=fuzz_sendto,
 * so its socket calls land here. Input: a sequence of datagrams, each
 *   [ctrl][len_lo][len_hi][len bytes]
 * ctrl bit 0: from a foreign host; bits 1-7: wall time advance in ms.
 * Checks: accepted frames carry finite values and time that never runs
 * backwards; every datagram the client sends is a well-formed request.
 */
#include <arpa/inet.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#include "host.h"
#include "xp_client.h"
#include "xp_proto.h"
#include "records.h"

/* The client's console lines: dropped (the compiler checks their formats, host.h). */
void host_report(const char *fmt, ...) { (void)fmt; }

static const uint8_t *cur;
static size_t cur_len;
static int cur_foreign;
static int pending;

ssize_t fuzz_recvfrom(int fd, void *buf, size_t n, int flags, struct sockaddr *from, socklen_t *fl)
{
	(void)fd;
	(void)flags;
	if (!pending)
		return -1;
	pending = 0;
	size_t k = cur_len < n ? cur_len : n;
	memcpy(buf, cur, k);
	struct sockaddr_in a;
	memset(&a, 0, sizeof a);
	a.sin_family = AF_INET;
	a.sin_addr.s_addr = htonl(cur_foreign ? 0x7f000002u : 0x7f000001u);
	a.sin_port = htons(49001);
	memcpy(from, &a, sizeof a < *fl ? sizeof a : *fl);
	*fl = sizeof a;
	return (ssize_t)cur_len;
}

ssize_t fuzz_sendto(int fd, const void *buf, size_t n, int flags, const struct sockaddr *to, socklen_t tl)
{
	(void)fd;
	(void)flags;
	(void)to;
	(void)tl;
	const uint8_t *b = buf;
	if (n < 5)
		abort();
	if (!memcmp(b, "DREF", 4) && n != XP_DREF_LEN)
		abort();
	if (!memcmp(b, "RREF", 4) && n != XP_RREF_REQ_LEN)
		abort();
	if ((!memcmp(b, "DSEL", 4) || !memcmp(b, "USEL", 4)) && (n - 5) % 4)
		abort();
	return (ssize_t)n;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static struct xp_client c;
	memset(&c, 0, sizeof c);
	c.fd = 3;
	c.xp.sin_family = AF_INET;
	c.xp.sin_addr.s_addr = htonl(0x7f000001u);
	c.xp.sin_port = htons(49000);
	c.act = (size & 1) ? XP_ACT_DATA25 : XP_ACT_DREF;
	struct hal_sensor_frame frame;
	memset(&frame, 0, sizeof frame);
	uint64_t now = 1000000u;
	double t_prev = -1e300;
	size_t pos = 0;
	uint8_t ctrl;
	const uint8_t *rec;
	size_t len;
	while (fuzz_next_record(data, size, &pos, &ctrl, &rec, &len)) {
		cur = rec;
		cur_len = len;
		cur_foreign = ctrl & 1;
		pending = 1;
		now += (uint64_t)(ctrl >> 1) * 1000u;
		int got = xp_client_receive(&c, &frame, now);
		if (got > 0) {
			if (!(frame.t_s >= t_prev))
				abort();
			t_prev = frame.t_s;
			for (int i = 0; i < 4; i++)
				if (!isfinite(frame.q_ib[i]))
					abort();
			for (int i = 0; i < 3; i++)
				if (!isfinite(frame.rate_b_rps[i]) || !isfinite(frame.pos_i_m[i]) ||
				    !isfinite(frame.vel_i_mps[i]))
					abort();
			float thr[HAL_ROTORS];
			for (int i = 0; i < HAL_ROTORS; i++)
				thr[i] = frame.thr_cmd_echo[i];
			xp_client_actuate(&c, thr, now);
		}
		xp_client_poll(&c, now);
	}
	/* the decoder alone on the whole input, too */
	static struct xp_msg_in m;
	(void)xp_decode(data, size, &m);
	return 0;
}
