// xplane_input: X-Plane's receiving side. Decodes every request datagram
// (DSEL/USEL, DATA-in row 25, DREF, RREF, CMND, ISE4), keeps what X-Plane would
// keep (selected rows, throttles, override, subscriptions, Data Output target)
// and drops, clamps and counts anything malformed. Never trusts a length.
#pragma once

#include <netinet/in.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "counters.hpp"
#include "vehicle.hpp"

namespace sim
{

struct RrefSub {
	sockaddr_in to; // replies go to the requester's source address
	int32_t index;  // client's index
	std::string path;
	int32_t freq; // per second
	double phase; // accumulated ticks (a reply when >= 1)
};

class XpInput
{
      public:
	static constexpr int kMaxRow = 255;
	static constexpr size_t kMaxSubs = 4096;

	explicit XpInput(Counters &c) : c_(c) { selected.fill(false); }

	void handle(const uint8_t *p, size_t len, const sockaddr_in &from);

	// Throttles driving the engines: ENGN_thro_use while override_throttles is
	// on, ENGN_thro otherwise (DATA row 25 writes both).
	std::array<double, kRotors> effective_throttle() const;

	std::array<bool, kMaxRow + 1> selected;
	std::array<float, 16> thro{};     // sim/flightmodel/engine/ENGN_thro
	std::array<float, 16> thro_use{}; // sim/flightmodel/engine/ENGN_thro_use
	bool override_on = false;
	uint32_t cmd_mask = 0; // engines 0..7 commanded since the last clear
	bool target_enabled = true;
	sockaddr_in target{};
	std::vector<RrefSub> subs;

      private:
	void dsel(const uint8_t *p, size_t len, bool on);
	void data(const uint8_t *p, size_t len);
	void dref(const uint8_t *p, size_t len);
	void rref(const uint8_t *p, size_t len, const sockaddr_in &from);
	void cmnd(const uint8_t *p, size_t len);
	void ise4(const uint8_t *p, size_t len);
	// clamps a throttle; false for NaN/Inf (counted)
	bool throttle_value(float in, float &out);
	static bool same_addr_port(const sockaddr_in &a, const sockaddr_in &b);

	Counters &c_;
};

} // namespace sim
