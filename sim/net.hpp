// net: one non-blocking IPv4 UDP socket, address parsing, waiting with poll().
#pragma once

#include <netinet/in.h>

#include <cstddef>
#include <cstdint>
#include <string>

namespace sim
{

// "HOST:PORT" (IPv4 literal or a resolvable name) -> address; false on error.
bool parse_hostport(const std::string &s, sockaddr_in &out, std::string &err);
std::string addr_str(const sockaddr_in &a);
bool same_addr(const sockaddr_in &a, const sockaddr_in &b);

class UdpSocket
{
      public:
	UdpSocket() = default;
	~UdpSocket();
	UdpSocket(const UdpSocket &) = delete;
	UdpSocket &operator=(const UdpSocket &) = delete;

	bool open(const std::string &bind_ip, uint16_t port, std::string &err);
	// Waits up to timeout_s (<= 0: no wait) for a datagram; true when readable.
	bool wait_readable(double timeout_s);
	// Non-blocking receive: false when nothing is pending; len is the datagram's
	// real length (may exceed cap: then it was truncated).
	bool recv(uint8_t *buf, size_t cap, sockaddr_in &from, size_t &len);
	bool send(const uint8_t *p, size_t n, const sockaddr_in &to);
	// A sender of multicast datagrams: bound to any address and port, TTL 1,
	// looped back to this host, out of the interface of `iface_ip` unless that
	// is a loopback or the any address (then the route to the group decides, so
	// that receivers that joined the group on the default interface get it).
	bool open_multicast_sender(const std::string &iface_ip, std::string &err);

      private:
	int fd_ = -1;
};

} // namespace sim
