// counters: what the simulator dropped, clamped or ignored, printed on exit.
#pragma once

#include <cstdint>
#include <string>

namespace sim
{

struct Counters {
	enum Id {
		RxDatagrams,    // every datagram received
		RxShort,        // shorter than the 5-byte header
		RxUnknownType,  // first 4 bytes name no request
		RxBadSize,      // wrong size for its type (DATA, DREF, RREF, DSEL/USEL, ISE4)
		RxUnterminated, // path without NUL in its field, empty or not printable
		RxBadValue,     // NaN or Inf value (column or DREF dropped)
		RxClamped,      // throttle outside [0, 1], clamped
		RxBadRow,       // DSEL/USEL index out of range
		RxIgnoredRow,   // DATA-in row other than 25
		RxIgnoredDref,  // DREF to a dataref the simulator does not model
		RxCmnd,         // CMND, accepted and ignored
		RxBadIse4,      // ISE4 other than a valid index 64
		RxRrefLimit,    // RREF subscriptions beyond the limit
		RrefUnknown,    // RREF subscription to an unknown dataref (replies 0)
		TxData,         // DATA datagrams sent
		TxRref,         // RREF datagrams sent
		TxError,        // sendto failures
		FaultDropped,   // DATA frames dropped by --drop / --burst
		FaultDuplicated,
		FaultReordered,
		LockstepTimeouts,
		LockstepWithheld, // lockstep ticks not waited for: the fault injector withheld the frame
		TxBeacon,         // BECN beacons sent
		TxBeaconError,    // BECN beacons that could not be sent (no multicast route)
		Count
	};
	uint64_t v[Count] = {};

	void inc(Id id, uint64_t n = 1) { v[id] += n; }
	uint64_t operator[](Id id) const { return v[id]; }
	static const char *name(Id id);
	// {"rx_datagrams": 12, ...} on one line
	std::string json() const;
};

} // namespace sim
