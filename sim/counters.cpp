// counters: names and the exit summary.
#include "counters.hpp"

namespace sim
{

const char *Counters::name(Id id)
{
	static const char *const names[Count] = {
		"rx_datagrams",      "rx_short",          "rx_unknown_type", "rx_bad_size",      "rx_unterminated",
		"rx_bad_value",      "rx_clamped",        "rx_bad_row",      "rx_ignored_row",   "rx_ignored_dref",
		"rx_cmnd",           "rx_bad_ise4",       "rx_rref_limit",   "rref_unknown",     "tx_data",
		"tx_rref",           "tx_error",          "fault_dropped",   "fault_duplicated", "fault_reordered",
		"lockstep_timeouts", "lockstep_withheld", "tx_beacon",       "tx_beacon_error",
	};
	return names[id];
}

std::string Counters::json() const
{
	std::string s = "{";
	for (int i = 0; i < Count; i++) {
		if (i)
			s += ", ";
		s += "\"";
		s += name(static_cast<Id>(i));
		s += "\": " + std::to_string(v[i]);
	}
	return s + "}";
}

} // namespace sim
