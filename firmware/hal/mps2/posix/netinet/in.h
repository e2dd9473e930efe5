/*
 * netinet/in.h for the MPS2 board: the IPv4 address types that the X-Plane client of
 * hal/host (xp_client.c) names. The board has no IP stack: its plant link is a UART, and
 * the one "address" it uses stands for the host bridge at the other end (docs/pil.md).
 */
#ifndef OCTO_MPS2_NETINET_IN_H
#define OCTO_MPS2_NETINET_IN_H

#include <stdint.h>

typedef uint16_t sa_family_t;
typedef uint16_t in_port_t;
typedef uint32_t in_addr_t;

struct in_addr {
	in_addr_t s_addr;
};

struct sockaddr_in {
	sa_family_t sin_family;
	in_port_t sin_port;
	struct in_addr sin_addr;
	unsigned char sin_zero[8];
};

#define AF_UNSPEC 0
#define AF_INET 2
#define INADDR_ANY ((in_addr_t)0)
#define INADDR_LOOPBACK ((in_addr_t)0x7f000001u)

static inline uint32_t htonl(uint32_t v) { return __builtin_bswap32(v); }
static inline uint16_t htons(uint16_t v) { return __builtin_bswap16(v); }
static inline uint32_t ntohl(uint32_t v) { return __builtin_bswap32(v); }
static inline uint16_t ntohs(uint16_t v) { return __builtin_bswap16(v); }

#endif
