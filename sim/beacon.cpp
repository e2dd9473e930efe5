// beacon: BECN encoding (see beacon.hpp).
#include "beacon.hpp"

#include <unistd.h>

namespace sim
{

int32_t xp_version_number(int xplane_version) { return xplane_version >= 12 ? 120100 : 115500; }

xp::Bytes encode_becn(int xplane_version, uint16_t receive_port, const std::string &computer_name)
{
	xp::Bytes b = {'B', 'E', 'C', 'N', 0};
	auto put = [&b](uint32_t v, int n) {
		for (int k = 0; k < n; k++)
			b.push_back(static_cast<uint8_t>(v >> (8 * k)));
	};
	const bool v12 = xplane_version >= 12;
	b.push_back(1);           // beacon major version
	b.push_back(v12 ? 2 : 1); // beacon minor version
	put(1, 4);                // application host id: X-Plane
	put(static_cast<uint32_t>(xp_version_number(xplane_version)), 4);
	put(1, 4); // role: master
	put(receive_port, 2);
	// the name is cut so that the datagram stays small (X-Plane's field is short too)
	const std::string name = computer_name.substr(0, 255);
	b.insert(b.end(), name.begin(), name.end());
	b.push_back(0);
	if (v12)
		put(kRaknetPort, 2);
	return b;
}

std::string default_computer_name()
{
	char h[256] = {};
	if (gethostname(h, sizeof h - 1) != 0 || !h[0])
		return "octo-sim";
	return h;
}

} // namespace sim
