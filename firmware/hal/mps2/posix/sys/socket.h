/*
 * sys/socket.h for the MPS2 board: the socket calls that xp_client.c names. The board has
 * no IP stack; posix.c defines them to fail (ENOSYS). The platform uses only the client's
 * socket-free entry points (xp_client_init with a send function, xp_client_input).
 */
#ifndef OCTO_MPS2_SYS_SOCKET_H
#define OCTO_MPS2_SYS_SOCKET_H

#include <stddef.h>
#include <sys/types.h>

typedef uint32_t socklen_t;

struct sockaddr {
	uint16_t sa_family;
	char sa_data[14];
};

#define SOCK_DGRAM 2

int socket(int domain, int type, int protocol);
int bind(int fd, const struct sockaddr *addr, socklen_t len);
ssize_t sendto(int fd, const void *buf, size_t len, int flags, const struct sockaddr *to, socklen_t tolen);
ssize_t recvfrom(int fd, void *buf, size_t len, int flags, struct sockaddr *from, socklen_t *fromlen);

#endif
