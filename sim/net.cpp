// net: POSIX sockets.
#include "net.hpp"

#include <arpa/inet.h>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace sim
{

bool parse_hostport(const std::string &s, sockaddr_in &out, std::string &err)
{
	size_t c = s.rfind(':');
	if (c == std::string::npos || c == 0 || c + 1 >= s.size()) {
		err = "expected HOST:PORT";
		return false;
	}
	std::string host = s.substr(0, c), ps = s.substr(c + 1);
	long port = 0;
	for (char ch : ps) {
		if (ch < '0' || ch > '9' || port > 65535) {
			err = "bad port '" + ps + "'";
			return false;
		}
		port = port * 10 + (ch - '0');
	}
	if (port < 1 || port > 65535) {
		err = "port out of range '" + ps + "'";
		return false;
	}
	std::memset(&out, 0, sizeof out);
	out.sin_family = AF_INET;
	out.sin_port = htons(static_cast<uint16_t>(port));
	if (inet_pton(AF_INET, host.c_str(), &out.sin_addr) == 1)
		return true;
	addrinfo hints{}, *res = nullptr;
	hints.ai_family = AF_INET;
	hints.ai_socktype = SOCK_DGRAM;
	if (getaddrinfo(host.c_str(), nullptr, &hints, &res) != 0 || !res) {
		err = "cannot resolve host '" + host + "'";
		return false;
	}
	out.sin_addr = reinterpret_cast<sockaddr_in *>(res->ai_addr)->sin_addr;
	freeaddrinfo(res);
	return true;
}

std::string addr_str(const sockaddr_in &a)
{
	char ip[INET_ADDRSTRLEN] = "?";
	inet_ntop(AF_INET, &a.sin_addr, ip, sizeof ip);
	return std::string(ip) + ":" + std::to_string(ntohs(a.sin_port));
}

bool same_addr(const sockaddr_in &a, const sockaddr_in &b)
{
	return a.sin_addr.s_addr == b.sin_addr.s_addr && a.sin_port == b.sin_port;
}

UdpSocket::~UdpSocket()
{
	if (fd_ >= 0)
		close(fd_);
}

bool UdpSocket::open(const std::string &bind_ip, uint16_t port, std::string &err)
{
	fd_ = socket(AF_INET, SOCK_DGRAM, 0);
	if (fd_ < 0) {
		err = std::strerror(errno);
		return false;
	}
	fcntl(fd_, F_SETFL, fcntl(fd_, F_GETFL) | O_NONBLOCK);
	int big = 1 << 20;
	setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
	sockaddr_in a{};
	a.sin_family = AF_INET;
	a.sin_port = htons(port);
	if (inet_pton(AF_INET, bind_ip.c_str(), &a.sin_addr) != 1) {
		err = "bad bind address '" + bind_ip + "'";
		return false;
	}
	if (bind(fd_, reinterpret_cast<sockaddr *>(&a), sizeof a) != 0) {
		err = "cannot bind " + bind_ip + ":" + std::to_string(port) + ": " + std::strerror(errno);
		return false;
	}
	return true;
}

bool UdpSocket::wait_readable(double timeout_s)
{
	pollfd p{fd_, POLLIN, 0};
	int ms = timeout_s <= 0 ? 0 : static_cast<int>(timeout_s * 1000.0 + 0.999);
	int r = poll(&p, 1, ms);
	return r > 0 && (p.revents & POLLIN);
}

bool UdpSocket::recv(uint8_t *buf, size_t cap, sockaddr_in &from, size_t &len)
{
	socklen_t fl = sizeof from;
	ssize_t n = recvfrom(fd_, buf, cap, MSG_TRUNC, reinterpret_cast<sockaddr *>(&from), &fl);
	if (n < 0)
		return false;
	len = static_cast<size_t>(n);
	return true;
}

bool UdpSocket::send(const uint8_t *p, size_t n, const sockaddr_in &to)
{
	ssize_t r = sendto(fd_, p, n, 0, reinterpret_cast<const sockaddr *>(&to), sizeof to);
	return r == static_cast<ssize_t>(n);
}

bool UdpSocket::open_multicast_sender(const std::string &iface_ip, std::string &err)
{
	if (!open("0.0.0.0", 0, err))
		return false;
	unsigned char ttl = 1, loop = 1;
	if (setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl) != 0 ||
	    setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop) != 0) {
		err = std::strerror(errno);
		return false;
	}
	in_addr a{};
	if (inet_pton(AF_INET, iface_ip.c_str(), &a) == 1 && a.s_addr != htonl(INADDR_ANY) &&
	    (ntohl(a.s_addr) >> 24) != 127 && setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_IF, &a, sizeof a) != 0) {
		err = std::strerror(errno);
		return false;
	}
	return true;
}

} // namespace sim
