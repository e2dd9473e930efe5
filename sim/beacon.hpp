// beacon: X-Plane 11/12's BECN announcement on multicast 239.255.1.1:49707.
#pragma once

#include <cstdint>
#include <string>

#include "xplane_proto.hpp"

namespace sim
{

constexpr const char *kBeaconGroup = "239.255.1.1";
constexpr uint16_t kBeaconPort = 49707;
// X-Plane 12 announces its RakNet (multiplayer) port after the name; 49010 is
// X-Plane's default, and clients that parse the name up to the last byte rely
// on its low byte being 'r' (0x72), as it is in X-Plane's own beacon.
constexpr uint16_t kRaknetPort = 49010;

// sim/version/xplane_internal_version of the emulated X-Plane (11.55 or 12.1.0).
int32_t xp_version_number(int xplane_version);

// One BECN datagram: prologue "BECN\0", '<BBiiIH' = major 1, minor (1 for
// X-Plane 11, 2 for 12), host 1 (X-Plane), version number, role 1 (master),
// receive port; the computer name NUL-terminated; X-Plane 12 adds the uint16
// RakNet port after it.
xp::Bytes encode_becn(int xplane_version, uint16_t receive_port, const std::string &computer_name);

// This machine's name (gethostname), "octo-sim" when it has none.
std::string default_computer_name();

} // namespace sim
