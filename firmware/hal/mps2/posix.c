/*
 * posix.c - the socket calls of posix/sys/socket.h on a board without an IP stack: each
 * fails with ENOSYS. The X-Plane client's socket paths (xp_client_open, xp_client_receive,
 * sends without a send function) are never taken on this platform.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>

#include "posix/sys/socket.h"

int socket(int domain, int type, int protocol)
{
	(void)domain, (void)type, (void)protocol;
	errno = ENOSYS;
	return -1;
}

int bind(int fd, const struct sockaddr *addr, socklen_t len)
{
	(void)fd, (void)addr, (void)len;
	errno = ENOSYS;
	return -1;
}

ssize_t sendto(int fd, const void *buf, size_t len, int flags, const struct sockaddr *to, socklen_t tolen)
{
	(void)fd, (void)buf, (void)len, (void)flags, (void)to, (void)tolen;
	errno = ENOSYS;
	return -1;
}

ssize_t recvfrom(int fd, void *buf, size_t len, int flags, struct sockaddr *from, socklen_t *fromlen)
{
	(void)fd, (void)buf, (void)len, (void)flags, (void)from, (void)fromlen;
	errno = ENOSYS;
	return -1;
}

int fcntl(int fd, int cmd, ...)
{
	(void)fd, (void)cmd;
	errno = ENOSYS;
	return -1;
}
