// options: octo-sim's command line (see usage() in cli.cpp for the text).
#pragma once

#include <netinet/in.h>

#include <cstdint>
#include <string>
#include <vector>

#include "faults.hpp"
#include "vehicle.hpp"

namespace sim
{

struct Options {
	uint16_t xp_port = 49000;
	std::string bind_ip = "127.0.0.1";
	std::string data_out = "127.0.0.1:49005";
	sockaddr_in data_out_addr{};
	double rate = 90.0;
	int xplane_version = 12;
	std::string vehicle_file;
	VehicleParams vehicle;
	bool ideal = false;
	uint64_t seed = 1;
	double duration = 0;   // simulated s; 0 = run until stopped
	double start_time = 0; // the plant clock at frame 0, s (Data Output row 1 starts there)
	std::string lcm_url;
	unsigned log_every = 1; // --log-every: the truth log keeps every Nth frame
	bool lockstep = false;
	double lockstep_timeout = 0.5;        // wall s to wait for the 8 throttles
	std::vector<int> rows;                // preselected Data Output rows
	std::vector<double> shift_origin;     // --shift-origin T: plant times, added to the vehicle's
	std::vector<RotorFailure> fail_rotor; // --fail-rotor J@T[:S], added to the vehicle's
	FaultParams faults;
	// --imu-spike P, --imu-spike-gyro G, --imu-spike-accel A (< 0: the vehicle's imu_spike)
	double imu_spike = -1, imu_spike_gyro = -1, imu_spike_accel = -1;
	std::vector<StuckRpm> stuck_rpm; // --stuck-rpm J@T, added to the vehicle's
	double step = 0.002;             // RK4 step, s
	bool verbose = false;
	bool beacon = true;        // BECN once a second on 239.255.1.1:49707
	std::string computer_name; // announced in the beacon; empty: this machine's name
	// --sensors: what the plant serves (SensorBits); 0 = the vehicle file's `sensors`
	unsigned sensors = 0;
};

// Parses argv. Returns -1 to run, or an exit status (0 after --help, 2 on a
// bad flag or a bad --vehicle file, with the message on stderr).
int parse_options(int argc, char **argv, Options &o);

} // namespace sim
