// fuzz_sim_input.cpp - libFuzzer harness of octo-sim's X-Plane request decoder
// (sim/xplane_input.cpp with sim/xplane_proto.cpp and the counters).
//
// Input: a sequence of datagrams [ctrl][len_lo][len_hi][len bytes]; ctrl picks
// the sender's port (so RREF subscriptions from several clients pile up).
// Checks: the effective throttles stay finite and inside [0, 1], the
// subscription list stays within its limit, every datagram is counted once.
#include <arpa/inet.h>

#include <cmath>
#include <cstdlib>
#include <cstring>

#include "counters.hpp"
#include "records.h"
#include "xplane_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	sim::Counters c;
	sim::XpInput in(c);
	size_t pos = 0;
	uint64_t n = 0;
	uint8_t ctrl;
	const uint8_t *rec;
	size_t len;
	while (fuzz_next_record(data, size, &pos, &ctrl, &rec, &len)) {
		// a copy of exactly len bytes, so that ASan sees any read past the datagram
		uint8_t *d = static_cast<uint8_t *>(std::malloc(len ? len : 1));
		std::memcpy(d, rec, len);
		sockaddr_in from{};
		from.sin_family = AF_INET;
		from.sin_addr.s_addr = htonl(0x7f000001u);
		from.sin_port = htons(static_cast<uint16_t>(49005 + (ctrl & 7)));
		in.handle(d, len, from);
		std::free(d);
		n++;
		for (double u : in.effective_throttle())
			if (!std::isfinite(u) || u < 0.0 || u > 1.0)
				std::abort();
		if (in.subs.size() > sim::XpInput::kMaxSubs)
			std::abort();
	}
	if (c[sim::Counters::RxDatagrams] != n)
		std::abort();
	return 0;
}
