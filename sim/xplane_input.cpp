// xplane_input: request decoding with every size and value checked.
#include "xplane_input.hpp"

#include <arpa/inet.h>

#include <cmath>
#include <cstring>
#include <string_view>
#include <vector>

#include "xplane_proto.hpp"

namespace sim
{

void XpInput::handle(const uint8_t *p, size_t len, const sockaddr_in &from)
{
	c_.inc(Counters::RxDatagrams);
	if (len < xp::kHeader) {
		c_.inc(Counters::RxShort);
		return;
	}
	switch (xp::message_type(p, len)) {
	case xp::Msg::Dsel: dsel(p, len, true); break;
	case xp::Msg::Usel: dsel(p, len, false); break;
	case xp::Msg::Data: data(p, len); break;
	case xp::Msg::Dref: dref(p, len); break;
	case xp::Msg::Rref: rref(p, len, from); break;
	case xp::Msg::Cmnd: cmnd(p, len); break;
	case xp::Msg::Ise4: ise4(p, len); break;
	case xp::Msg::Unknown: c_.inc(Counters::RxUnknownType); break;
	}
}

std::array<double, kRotors> XpInput::effective_throttle() const
{
	std::array<double, kRotors> u;
	for (int j = 0; j < kRotors; j++)
		u[j] = override_on ? thro_use[j] : thro[j];
	return u;
}

void XpInput::dsel(const uint8_t *p, size_t len, bool on)
{
	if ((len - xp::kHeader) % 4 != 0) {
		c_.inc(Counters::RxBadSize);
		return;
	}
	for (size_t o = xp::kHeader; o + 4 <= len; o += 4) {
		int32_t row = xp::get_i32(p + o);
		if (row == 0)
			continue; // unused slot
		if (row < 0 || row > kMaxRow) {
			c_.inc(Counters::RxBadRow);
			continue;
		}
		selected[static_cast<size_t>(row)] = on;
	}
}

bool XpInput::throttle_value(float in, float &out)
{
	if (!std::isfinite(in)) {
		c_.inc(Counters::RxBadValue);
		return false;
	}
	if (in < 0.0f || in > 1.0f) {
		c_.inc(Counters::RxClamped);
		in = in < 0.0f ? 0.0f : 1.0f;
	}
	out = in;
	return true;
}

void XpInput::data(const uint8_t *p, size_t len)
{
	if ((len - xp::kHeader) % xp::kDataRecord != 0 || len == xp::kHeader) {
		c_.inc(Counters::RxBadSize);
		return;
	}
	for (size_t o = xp::kHeader; o + xp::kDataRecord <= len; o += xp::kDataRecord) {
		int32_t row = xp::get_i32(p + o);
		if (row != 25) {
			c_.inc(Counters::RxIgnoredRow);
			continue;
		}
		for (int j = 0; j < kRotors; j++) {
			float v = xp::get_f32(p + o + 4 + 4 * static_cast<size_t>(j));
			if (v == xp::kNoData) {
				cmd_mask |= 1u << j; // leave alone: commanded to keep its value
				continue;
			}
			float t;
			if (!throttle_value(v, t))
				continue; // NaN/Inf: dropped, and not a command (lockstep waits on)
			thro[static_cast<size_t>(j)] = t;
			thro_use[static_cast<size_t>(j)] = t;
			cmd_mask |= 1u << j;
		}
	}
}

void XpInput::dref(const uint8_t *p, size_t len)
{
	if (len != xp::kDrefSize) {
		c_.inc(Counters::RxBadSize);
		return;
	}
	// Views into the datagram. The throttles arrive eight times a frame as
	// "sim/flightmodel/engine/ENGN_thro_use[i]" with one digit and the NUL right after
	// the bracket: such a field is taken by its bytes (the full decoding below gives the
	// same path, base and index for it); every other field is decoded in full.
	static constexpr char kThroUse[] = "sim/flightmodel/engine/ENGN_thro_use[";
	constexpr size_t kLb = sizeof kThroUse - 2; // where '[' is
	const uint8_t *field = p + 9;
	const bool thro_use_digit = std::memcmp(field, kThroUse, kLb + 1) == 0 && field[kLb + 1] >= '0' &&
				    field[kLb + 1] <= '9' && field[kLb + 2] == ']' && field[kLb + 3] == 0;
	std::string_view path;
	if (!thro_use_digit && !xp::field_path(field, xp::kDrefPath, path)) {
		c_.inc(Counters::RxUnterminated);
		return;
	}
	float v = xp::get_f32(p + 5);
	if (!std::isfinite(v)) {
		c_.inc(Counters::RxBadValue);
		return;
	}
	std::string_view base;
	int idx;
	if (thro_use_digit) {
		base = std::string_view(kThroUse, kLb);
		idx = field[kLb + 1] - '0';
	} else if (!xp::split_index(path, base, idx)) {
		c_.inc(Counters::RxIgnoredDref);
		return;
	}
	if (base == "sim/operation/override/override_throttles" && idx <= 0) {
		override_on = v >= 0.5f;
		return;
	}
	const bool use = base == "sim/flightmodel/engine/ENGN_thro_use";
	const bool usr = base == "sim/flightmodel/engine/ENGN_thro";
	if ((use || usr) && idx >= 0 && idx < 16) {
		float t;
		if (!throttle_value(v, t))
			return;
		(use ? thro_use : thro)[static_cast<size_t>(idx)] = t;
		if (idx < kRotors)
			cmd_mask |= 1u << idx;
		return;
	}
	c_.inc(Counters::RxIgnoredDref);
}

void XpInput::rref(const uint8_t *p, size_t len, const sockaddr_in &from)
{
	if (len != xp::kRrefReqSize) {
		c_.inc(Counters::RxBadSize);
		return;
	}
	int32_t freq = xp::get_i32(p + 5);
	int32_t index = xp::get_i32(p + 9);
	std::string path;
	if (!xp::field_path(p + 13, xp::kRrefPath, path)) {
		c_.inc(Counters::RxUnterminated);
		return;
	}
	if (freq < 0) {
		c_.inc(Counters::RxBadValue);
		return;
	}
	for (size_t k = 0; k < subs.size(); k++) {
		if (subs[k].index == index && same_addr_port(subs[k].to, from)) {
			if (freq == 0) {
				subs.erase(subs.begin() + static_cast<long>(k));
			} else {
				subs[k].path = path;
				subs[k].freq = freq;
			}
			return;
		}
	}
	if (freq == 0)
		return;
	if (subs.size() >= kMaxSubs) {
		c_.inc(Counters::RxRrefLimit);
		return;
	}
	subs.push_back(RrefSub{from, index, path, freq, 1.0}); // first reply on the next tick
}

bool XpInput::same_addr_port(const sockaddr_in &a, const sockaddr_in &b)
{
	return a.sin_addr.s_addr == b.sin_addr.s_addr && a.sin_port == b.sin_port;
}

void XpInput::cmnd(const uint8_t *p, size_t len)
{
	// The command path runs to a NUL or to the end of the datagram: X-Plane
	// accepts both, and client libraries send it without the NUL.
	std::string path;
	const size_t n = len - xp::kHeader;
	std::vector<uint8_t> field(p + xp::kHeader, p + len);
	if (n == 0 || !std::memchr(field.data(), 0, n))
		field.push_back(0);
	if (!xp::field_path(field.data(), field.size(), path)) {
		c_.inc(Counters::RxUnterminated);
		return;
	}
	c_.inc(Counters::RxCmnd);
}

void XpInput::ise4(const uint8_t *p, size_t len)
{
	if (len != xp::kIse4Size) {
		c_.inc(Counters::RxBadSize);
		return;
	}
	int32_t index = xp::get_i32(p + 5);
	std::string ip, port;
	if (index != 64 || !xp::field_path(p + 9, 16, ip) || !xp::field_path(p + 25, 8, port)) {
		c_.inc(Counters::RxBadIse4);
		return;
	}
	int32_t enable = xp::get_i32(p + 33);
	sockaddr_in a{};
	a.sin_family = AF_INET;
	long pn = 0;
	for (char ch : port) {
		if (ch < '0' || ch > '9' || pn > 65535) {
			pn = -1;
			break;
		}
		pn = pn * 10 + (ch - '0');
	}
	if (inet_pton(AF_INET, ip.c_str(), &a.sin_addr) != 1 || pn < 1 || pn > 65535) {
		c_.inc(Counters::RxBadIse4);
		return;
	}
	a.sin_port = htons(static_cast<uint16_t>(pn));
	target = a;
	target_enabled = enable != 0;
}

} // namespace sim
