// cli: flag parsing with clear errors (exit 2 naming the flag or the JSON key).
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "net.hpp"
#include "options.hpp"

namespace sim
{

static const char kUsage[] =
	"usage: octo-sim [options]\n"
	"\n"
	"The paper's octocopter behind X-Plane 11/12's UDP protocol: receives DSEL/USEL,\n"
	"DATA (row 25), DREF, RREF, CMND and ISE4 on --xp-port and sends DATA* frames to\n"
	"the Data Output target at --rate, like X-Plane.\n"
	"\n"
	"network:\n"
	"  --xp-port N            UDP port X-Plane messages are received on (49000)\n"
	"  --bind ADDR            local IPv4 address to bind (127.0.0.1; 0.0.0.0 for all)\n"
	"  --data-out HOST:PORT   Data Output target (127.0.0.1:49005; ISE4 index 64 changes it)\n"
	"  --rate HZ              Data Output rate, frames per simulated second (90)\n"
	"  --xplane-version 11|12 protocol personality: row 16 order/units, version dataref (12)\n"
	"  --rows LIST            preselect Data Output rows, e.g. 1,16,17,20,21,25 (none)\n"
	"  --no-beacon            do not announce X-Plane's BECN beacon (sent once a second to\n"
	"                         239.255.1.1:49707, announcing --xp-port; a failed send is counted)\n"
	"  --computer-name NAME   computer name in the beacon (this machine's host name)\n"
	"\n"
	"simulation:\n"
	"  --vehicle FILE.json    truth, actuator and noise model; absent keys keep defaults\n"
	"  --ideal                no noise, no motor lag, no delay (the paper's ideal set-up)\n"
	"  --seed N               seed of the noise and of the fault injection (1)\n"
	"  --duration S           simulated seconds to run, then exit 0 (0: until stopped)\n"
	"  --start-time S         the plant clock at the first frame (0): Data Output row 1's\n"
	"                         times, the time datarefs and the truth log start at S, the\n"
	"                         dynamics are those of a run from 0 (a long uptime in seconds)\n"
	"  --lockstep             advance one frame when all 8 throttles are commanded (DATA\n"
	"                         row 25 or DREFs ENGN_thro_use[0..7]) or on timeout; before the\n"
	"                         first command time stands still and frame 0 is re-sent at --rate\n"
	"  --lockstep-timeout S   wall-clock seconds to wait for the throttles (0.5)\n"
	"  --step S               RK4 step (0.002)\n"
	"  --sensors LIST         what the plant serves, from imu (rows 4, 16), rpm (37, 38),\n"
	"                         torque (36), thrust (35), comma-separated (all; vehicle key\n"
	"                         `sensors`); a row not served is not sent, its datarefs reply 0\n"
	"  --lcm URL              ground truth on channel OCTO_TRUTH (octo.truth_t); file://PATH\n"
	"                         writes an LCM log stamped with simulated time\n"
	"  --log-every N          the truth log: every Nth frame only (1), frame 0 included\n"
	"\n"
	"fault injection on the DATA stream (seeded):\n"
	"  --drop P               lose each frame with probability P\n"
	"  --burst N              lose N consecutive frames at random times\n"
	"  --burst-prob P         probability per frame that a burst starts (0.005)\n"
	"  --delay-frames K       send every frame K frames late\n"
	"  --duplicate P          send a frame twice with probability P\n"
	"  --reorder P            swap a frame with the next one with probability P\n"
	"\n"
	"faults of the plant:\n"
	"  --shift-origin T       at plant time T s move the OpenGL local origin as X-Plane does\n"
	"                         at a scenery shift: local x/y/z (row 21, local_x/y/z) jump by\n"
	"                         kilometres; latitude, longitude, elevation, velocities and the\n"
	"                         physics do not change (repeatable; vehicle key origin_shift_s)\n"
	"  --fail-rotor J@T[:S]   at plant time T s rotor J (1..8) keeps S (0..1, default 0) of\n"
	"                         its thrust and torque, and its speed falls to sqrt(S) of what\n"
	"                         its throttle asks (repeatable; vehicle key rotor_failure\n"
	"                         {\"rotor\": J, \"at_s\": T, \"scale\": S} or a list of them)\n"
	"\n"
	"  --verbose              one status line per second on stderr\n"
	"  --help                 this text\n"
	"\n"
	"vehicle keys: mass, g, arm_length, kf, ktau, inertia [3], motor_tau, delay,\n"
	"thrust_curve, rotor_scale [8], kf_drift_per_min, noise {thrust, torque, gyro,\n"
	"attitude_deg, position, accel, rpm, current}, origin [lat, lon, alt_m],\n"
	"origin_shift_s [T, ...], rotor_failure {rotor, at_s, scale} or [{...}, ...];\n"
	"imu_spike {prob, gyro, accel}, stuck_rpm {rotor, at_s} or [{...}, ...];\n"
	"sensors: imu_bias {accel, gyro, accel_walk, gyro_walk}, imu_scale, vibration\n"
	"{accel, gyro, harmonics [<=4], cutoff_hz, sample_hz}, rpm_max, esc_pole_pairs,\n"
	"esc_kt, esc_current_offset, thrust_row_scale, sensors [list] (docs/sensors.md).\n"
	"Refused (exit 2, naming key, value and accepted range): mass, inertia or kf <= 0,\n"
	"|kf_drift_per_min| > 0.2, a negative noise, inertia violating the triangle\n"
	"inequality (each moment <= the sum of the other two), hover throttle\n"
	"mass g / (8 kf) above 1.\n"
	"On exit (SIGINT/SIGTERM or --duration) the counters of dropped inputs go to stderr.\n";

namespace
{

std::string fmt(double d)
{
	char b[32];
	std::snprintf(b, sizeof b, "%g", d);
	return b;
}

struct Bad {
	std::string flag, msg;
};

double num(const std::string &flag, const char *v, double lo, double hi)
{
	char *end = nullptr;
	errno = 0;
	double d = std::strtod(v, &end);
	if (!*v || *end || errno || !std::isfinite(d) || d < lo || d > hi)
		throw Bad{flag, "expected a number in [" + fmt(lo) + ", " + fmt(hi) + "], got '" + v + "'"};
	return d;
}

long integer(const std::string &flag, const char *v, long lo, long hi)
{
	char *end = nullptr;
	errno = 0;
	long d = std::strtol(v, &end, 10);
	if (!*v || *end || errno || d < lo || d > hi)
		throw Bad{flag, "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
					"], got '" + v + "'"};
	return d;
}

// --fail-rotor J@T[:S]
RotorFailure fail_rotor(const std::string &flag, const std::string &v)
{
	const size_t at = v.find('@');
	if (at == std::string::npos)
		throw Bad{flag,
			  "expected J@T[:S] (rotor 1..8, plant time s, remaining effectiveness 0..1), got '" + v + "'"};
	const size_t colon = v.find(':', at);
	const std::string j = v.substr(0, at);
	const std::string t = v.substr(at + 1, colon == std::string::npos ? std::string::npos : colon - at - 1);
	RotorFailure f;
	f.rotor = static_cast<int>(integer(flag + " (rotor J)", j.c_str(), 1, kRotors)) - 1;
	f.at_s = num(flag + " (time T)", t.c_str(), 0.0, 1e9);
	if (colon != std::string::npos)
		f.scale = num(flag + " (scale S)", v.substr(colon + 1).c_str(), 0.0, 1.0);
	return f;
}

// --stuck-rpm J@T
StuckRpm stuck_rpm(const std::string &flag, const std::string &v)
{
	const size_t at = v.find('@');
	if (at == std::string::npos)
		throw Bad{flag, "expected J@T (rotor 1..8, plant time s), got '" + v + "'"};
	StuckRpm f;
	f.rotor = static_cast<int>(integer(flag + " (rotor J)", v.substr(0, at).c_str(), 1, kRotors)) - 1;
	f.at_s = num(flag + " (time T)", v.substr(at + 1).c_str(), 0.0, 1e9);
	return f;
}

} // namespace

int parse_options(int argc, char **argv, Options &o)
{
	try {
		for (int i = 1; i < argc; i++) {
			const std::string a = argv[i];
			auto val = [&]() -> const char * {
				if (i + 1 >= argc)
					throw Bad{a, "needs a value"};
				return argv[++i];
			};
			if (a == "--help" || a == "-h") {
				std::fputs(kUsage, stdout);
				return 0;
			} else if (a == "--xp-port") {
				o.xp_port = static_cast<uint16_t>(integer(a, val(), 1, 65535));
			} else if (a == "--bind") {
				o.bind_ip = val();
			} else if (a == "--data-out") {
				o.data_out = val();
			} else if (a == "--rate") {
				o.rate = num(a, val(), 1.0, 10000.0);
			} else if (a == "--xplane-version") {
				long v = integer(a, val(), 11, 12);
				o.xplane_version = static_cast<int>(v);
			} else if (a == "--rows") {
				std::string s = val();
				o.rows.clear();
				size_t p = 0;
				while (p <= s.size()) {
					size_t c = s.find(',', p);
					std::string t = s.substr(p, c == std::string::npos ? std::string::npos : c - p);
					o.rows.push_back(static_cast<int>(integer(a, t.c_str(), 1, 255)));
					if (c == std::string::npos)
						break;
					p = c + 1;
				}
			} else if (a == "--vehicle") {
				o.vehicle_file = val();
			} else if (a == "--ideal") {
				o.ideal = true;
			} else if (a == "--seed") {
				const char *v = val();
				char *end = nullptr;
				errno = 0;
				unsigned long long s = std::strtoull(v, &end, 10);
				if (!*v || *end || errno || *v == '-')
					throw Bad{a, std::string("expected a non-negative integer, got '") + v + "'"};
				o.seed = s;
			} else if (a == "--duration") {
				o.duration = num(a, val(), 0.0, 1e9);
			} else if (a == "--start-time") {
				o.start_time = num(a, val(), 0.0, 1e9);
			} else if (a == "--lcm") {
				o.lcm_url = val();
			} else if (a == "--log-every") {
				o.log_every = static_cast<unsigned>(integer(a, val(), 1, 1000000));
			} else if (a == "--lockstep") {
				o.lockstep = true;
			} else if (a == "--lockstep-timeout") {
				o.lockstep_timeout = num(a, val(), 0.001, 3600.0);
			} else if (a == "--step") {
				o.step = num(a, val(), 1e-5, 0.1);
			} else if (a == "--drop") {
				o.faults.drop = num(a, val(), 0.0, 1.0);
			} else if (a == "--burst") {
				o.faults.burst = static_cast<int>(integer(a, val(), 0, 1000000));
			} else if (a == "--burst-prob") {
				o.faults.burst_prob = num(a, val(), 0.0, 1.0);
			} else if (a == "--delay-frames") {
				o.faults.delay_frames = static_cast<int>(integer(a, val(), 0, 100000));
			} else if (a == "--duplicate") {
				o.faults.duplicate = num(a, val(), 0.0, 1.0);
			} else if (a == "--reorder") {
				o.faults.reorder = num(a, val(), 0.0, 1.0);
			} else if (a == "--shift-origin") {
				o.shift_origin.push_back(num(a, val(), 0.0, 1e9));
			} else if (a == "--fail-rotor") {
				o.fail_rotor.push_back(fail_rotor(a, val()));
			} else if (a == "--imu-spike") {
				o.imu_spike = num(a, val(), 0.0, 1.0);
			} else if (a == "--imu-spike-gyro") {
				o.imu_spike_gyro = num(a, val(), 1e-6, 1e6);
			} else if (a == "--imu-spike-accel") {
				o.imu_spike_accel = num(a, val(), 1e-6, 1e6);
			} else if (a == "--stuck-rpm") {
				o.stuck_rpm.push_back(stuck_rpm(a, val()));
			} else if (a == "--no-beacon") {
				o.beacon = false;
			} else if (a == "--computer-name") {
				o.computer_name = val();
				if (o.computer_name.empty() || o.computer_name.size() > 255 ||
				    o.computer_name.find('\0') != std::string::npos)
					throw Bad{a, "expected a name of 1 to 255 characters"};
			} else if (a == "--sensors") {
				std::string bad;
				if (!sensors_parse(val(), o.sensors, bad))
					throw Bad{a, "unknown sensor '" + bad + "' (known: imu, rpm, torque, thrust)"};
			} else if (a == "--verbose" || a == "-v") {
				o.verbose = true;
			} else {
				throw Bad{a, "unknown option (see --help)"};
			}
		}
		std::string err;
		if (!parse_hostport(o.data_out, o.data_out_addr, err))
			throw Bad{"--data-out", err};
		if (!o.vehicle_file.empty()) {
			try {
				vehicle_load(o.vehicle_file, o.vehicle);
			} catch (const VehicleError &e) {
				std::fprintf(stderr, "octo-sim: --vehicle %s: %s\n", o.vehicle_file.c_str(), e.what());
				return 2;
			}
		}
		auto &shifts = o.vehicle.origin_shift_s;
		shifts.insert(shifts.end(), o.shift_origin.begin(), o.shift_origin.end());
		std::sort(shifts.begin(), shifts.end());
		auto &fails = o.vehicle.rotor_failures;
		fails.insert(fails.end(), o.fail_rotor.begin(), o.fail_rotor.end());
		auto &stuck = o.vehicle.stuck_rpm;
		stuck.insert(stuck.end(), o.stuck_rpm.begin(), o.stuck_rpm.end());
		if (o.imu_spike >= 0)
			o.vehicle.imu_spike.prob = o.imu_spike;
		if (o.imu_spike_gyro >= 0)
			o.vehicle.imu_spike.gyro = o.imu_spike_gyro;
		if (o.imu_spike_accel >= 0)
			o.vehicle.imu_spike.accel = o.imu_spike_accel;
		if (o.ideal)
			o.vehicle.make_ideal();
		if (o.sensors)
			o.vehicle.sensors = o.sensors;
	} catch (const Bad &b) {
		std::fprintf(stderr, "octo-sim: %s: %s\n", b.flag.c_str(), b.msg.c_str());
		return 2;
	}
	return -1;
}

} // namespace sim
