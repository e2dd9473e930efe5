// fuzz_plant.cpp - libFuzzer harness of octo-sim's plant behind its C interface (sim/plant.h),
// as octo-sil drives it: arbitrary request datagrams into the plant's decoder, frames
// emitted through its fault injector and encoders, integration steps. Every datagram the
// plant emits must be one octo-fw's decoder (firmware/hal/host/xp_proto.c) accepts as DATA
// or an RREF reply: both sides' codecs meet here as in octo-sil.
//
// Input: [flags][fault byte] then a sequence of [ctrl][len_lo][len_hi][len bytes]:
// flags pick the X-Plane version and faults; ctrl bit 0: emit and advance one frame after
// this datagram; bits 1-3: the sender's port.
#include <arpa/inet.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "plant.h"
#include "records.h"

extern "C" {
#include "xp_proto.h"
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (size < 2)
		return 0;
	const uint8_t flags = data[0], fb = data[1];
	std::vector<std::string> args = {"fuzz-plant",
					 "--seed",
					 std::to_string(fb),
					 "--xplane-version",
					 (flags & 1) ? "11" : "12",
					 "--rows",
					 "1,16,17,21,25,35,36"};
	if (flags & 2)
		args.insert(args.end(), {"--drop", "0.2", "--duplicate", "0.2", "--reorder", "0.2"});
	if (flags & 4)
		args.insert(args.end(), {"--delay-frames", std::to_string(fb % 4)});
	std::vector<char *> argv;
	for (auto &a : args)
		argv.push_back(&a[0]);
	int status = 0;
	octo_plant *p = octo_plant_create("fuzz-plant", static_cast<int>(argv.size()), argv.data(), &status);
	if (!p)
		std::abort();
	static struct xp_msg_in msg; // large: off the stack
	size_t pos = 2;
	bool started = false;
	int frames = 0;
	uint8_t ctrl;
	const uint8_t *rec;
	size_t len;
	while (frames < 200 && fuzz_next_record(data, size, &pos, &ctrl, &rec, &len)) {
		// a copy of exactly len bytes, so that ASan sees any read past the datagram
		uint8_t *d = static_cast<uint8_t *>(std::malloc(len ? len : 1));
		std::memcpy(d, rec, len);
		octo_plant_receive(p, d, len, htonl(0x7f000001u), static_cast<uint16_t>(49005 + ((ctrl >> 1) & 7)));
		std::free(d);
		if (!(ctrl & 1))
			continue;
		octo_plant_emit(p, started);
		uint8_t out[8192];
		long n;
		while ((n = octo_plant_pop(p, out, sizeof out, nullptr, nullptr)) >= 0) {
			if (static_cast<size_t>(n) > sizeof out)
				std::abort(); // no X-Plane datagram is this long
			enum xp_msg t = xp_decode(out, static_cast<size_t>(n), &msg);
			if (t != XP_MSG_DATA && t != XP_MSG_RREF)
				std::abort();
		}
		started = started || octo_plant_commanded(p);
		octo_plant_advance(p);
		frames++;
		struct octo_plant_truth tr;
		octo_plant_truth(p, &tr);
		for (double v : tr.pos_i)
			if (!std::isfinite(v))
				std::abort();
	}
	octo_plant_destroy(p);
	return 0;
}
