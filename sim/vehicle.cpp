// vehicle: defaults and the --vehicle JSON loader (strict: unknown keys and
// impossible values are errors naming the key).
#include "vehicle.hpp"

#include <algorithm>
#include <initializer_list>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "json.hpp"

namespace sim
{

void VehicleParams::make_ideal()
{
	motor_tau = 0.0;
	delay = 0.0;
	noise.thrust = noise.torque = 0.0;
	noise.gyro = noise.attitude_deg = noise.position = 0.0;
	noise.accel = noise.rpm = noise.current = 0.0;
	imu_bias = ImuBiasParams{0, 0, 0, 0};
	imu_scale = 0.0;
	vibration.accel = vibration.gyro = 0.0;
	esc_current_offset = 0.0;
}

double VehicleParams::failure_factor(int j, double clock) const
{
	double f = 1.0;
	for (const auto &r : rotor_failures)
		if (r.rotor == j && clock >= r.at_s)
			f = r.scale;
	return f;
}

double VehicleParams::rotor_effect(int j, double clock) const
{
	double e = rotor_scale[static_cast<size_t>(j)];
	for (const auto &r : rotor_failures)
		if (r.rotor == j && clock >= r.at_s)
			e = r.scale;
	return e;
}

bool sensors_parse(const std::string &list, unsigned &bits, std::string &bad)
{
	static const struct {
		const char *name;
		unsigned bit;
	} names[] = {{"imu", kSensorImu}, {"rpm", kSensorRpm}, {"torque", kSensorTorque}, {"thrust", kSensorThrust}};
	bits = 0;
	size_t p = 0;
	while (p <= list.size()) {
		size_t c = list.find(',', p);
		const std::string w = list.substr(p, c == std::string::npos ? std::string::npos : c - p);
		unsigned b = 0;
		for (const auto &n : names)
			if (w == n.name)
				b = n.bit;
		if (!b) {
			bad = w;
			return false;
		}
		bits |= b;
		if (c == std::string::npos)
			break;
		p = c + 1;
	}
	return true;
}

namespace
{

// |kf_drift_per_min| above this (20 %/min) empties a battery within minutes: a typo, not a vehicle.
constexpr double kMaxDriftPerMin = 0.2;

enum class Rule { Positive, NonNegative, Any, Unit };

std::string fmt(double d)
{
	char b[32];
	std::snprintf(b, sizeof b, "%g", d);
	return b;
}

// "key 'k' = v is out of range: accepted <range>" (the key, the value, the range).
VehicleError out_of_range(const std::string &key, double d, const std::string &range)
{
	return VehicleError(key, "key '" + key + "' = " + fmt(d) + " is out of range: accepted " + range);
}

double num(const json::Value &v, const std::string &key, Rule r)
{
	if (v.kind != json::Value::Kind::Number)
		throw VehicleError(key, "key '" + key + "' must be a number, not " + v.kind_name());
	double d = v.num;
	if (!std::isfinite(d))
		throw VehicleError(key, "key '" + key + "' must be finite");
	switch (r) {
	case Rule::Positive:
		if (!(d > 0))
			throw out_of_range(key, d, "> 0");
		break;
	case Rule::NonNegative:
		if (!(d >= 0))
			throw out_of_range(key, d, ">= 0");
		break;
	case Rule::Unit:
		if (!(d >= 0 && d <= 1))
			throw out_of_range(key, d, "[0, 1]");
		break;
	case Rule::Any: break;
	}
	return d;
}

template <size_t N> void vec(const json::Value &v, const std::string &key, Rule r, std::array<double, N> &out)
{
	if (v.kind != json::Value::Kind::Array || v.arr.size() != N)
		throw VehicleError(key, "key '" + key + "' must be an array of " + std::to_string(N) + " numbers");
	for (size_t i = 0; i < N; i++)
		out[i] = num(v.arr[i], key, r);
}

// Consistency of the keys taken together (each key alone was checked above).
void check_physics(const VehicleParams &q)
{
	// A body's principal moments obey the triangle inequality: each is at most the sum of the other two.
	static const char *const axis[3] = {"Ix", "Iy", "Iz"};
	for (int i = 0; i < 3; i++) {
		const double other = q.inertia[(size_t)(i + 1) % 3] + q.inertia[(size_t)(i + 2) % 3];
		if (q.inertia[(size_t)i] > other)
			throw VehicleError("inertia", std::string("key 'inertia' = [") + fmt(q.inertia[0]) + ", " +
							      fmt(q.inertia[1]) + ", " + fmt(q.inertia[2]) +
							      "] violates the triangle inequality: " + axis[i] + " = " +
							      fmt(q.inertia[(size_t)i]) +
							      " is out of range: accepted <= " + fmt(other) +
							      " (the sum of the other two)");
	}
	// Eight rotors at full throttle must lift the vehicle: m g / (8 kf) <= 1.
	const double th = q.hover_throttle();
	if (th > 1.0)
		throw VehicleError("kf", "key 'kf' = " + fmt(q.kf) + " N gives a hover throttle m g / (8 kf) = " +
						 fmt(th) + " > 1 with mass " + fmt(q.mass) + " kg: accepted kf >= " +
						 fmt(q.mass * q.g / kRotors) + " N (or a lower 'mass')");
}

// An object of non-negative numbers, each member stored where `fields` says; an unknown
// member or a non-object names itself.
void non_negative_members(const json::Value &v, const std::string &k,
			  std::initializer_list<std::pair<const char *, double *>> fields)
{
	if (v.kind != json::Value::Kind::Object)
		throw VehicleError(k, "key '" + k + "' must be an object");
	for (const auto &nk : v.obj) {
		const std::string key = k + "." + nk.first;
		const double d = num(nk.second, key, Rule::NonNegative);
		bool known = false;
		for (const auto &f : fields)
			if (nk.first == f.first) {
				*f.second = d;
				known = true;
			}
		if (!known)
			throw VehicleError(key, "unknown key '" + key + "'");
	}
}

// One object or a list of them, each parsed by `one`, replacing `out`.
template <typename T, typename F> void one_or_list(const json::Value &v, F one, std::vector<T> &out)
{
	out.clear();
	if (v.kind == json::Value::Kind::Array)
		for (const auto &e : v.arr)
			out.push_back(one(e));
	else
		out.push_back(one(v));
}

// The members an event on one rotor at one time shares: "rotor" (1..8, kept 0-based) and
// "at_s" (plant seconds); false for another member.
bool rotor_at(const std::string &member, const json::Value &val, const std::string &key, int &rotor, double &at_s,
	      bool &have_rotor, bool &have_t)
{
	if (member == "rotor") {
		const double d = num(val, key, Rule::Any);
		if (d != std::floor(d) || d < 1 || d > kRotors)
			throw out_of_range(key, d, "an integer in [1, 8]");
		rotor = static_cast<int>(d) - 1;
		have_rotor = true;
		return true;
	}
	if (member == "at_s") {
		at_s = num(val, key, Rule::NonNegative);
		if (at_s > 1e9)
			throw out_of_range(key, at_s, "[0, 1e9] s");
		have_t = true;
		return true;
	}
	return false;
}

// One rotor_failure object: {"rotor": J (1..8), "at_s": T (>= 0), "scale": S ([0, 1], default 0)}.
RotorFailure rotor_failure(const json::Value &v)
{
	const std::string k = "rotor_failure";
	if (v.kind != json::Value::Kind::Object)
		throw VehicleError(k, "key 'rotor_failure' must be an object {\"rotor\": J, \"at_s\": T, \"scale\": S} "
				      "or an array of them");
	RotorFailure f;
	bool have_rotor = false, have_t = false;
	for (const auto &kv : v.obj) {
		const std::string key = k + "." + kv.first;
		if (rotor_at(kv.first, kv.second, key, f.rotor, f.at_s, have_rotor, have_t))
			continue;
		if (kv.first == "scale") {
			f.scale = num(kv.second, key, Rule::Unit);
		} else {
			throw VehicleError(key, "unknown key '" + key + "' (known: rotor, at_s, scale)");
		}
	}
	if (!have_rotor || !have_t)
		throw VehicleError(k,
				   std::string("key 'rotor_failure' needs '") + (have_rotor ? "at_s" : "rotor") + "'");
	return f;
}

// One stuck_rpm object: {"rotor": J (1..8), "at_s": T (>= 0)}.
StuckRpm stuck_rpm(const json::Value &v)
{
	const std::string k = "stuck_rpm";
	if (v.kind != json::Value::Kind::Object)
		throw VehicleError(k,
				   "key 'stuck_rpm' must be an object {\"rotor\": J, \"at_s\": T} or an array of them");
	StuckRpm f;
	bool have_rotor = false, have_t = false;
	for (const auto &kv : v.obj) {
		const std::string key = k + "." + kv.first;
		if (!rotor_at(kv.first, kv.second, key, f.rotor, f.at_s, have_rotor, have_t))
			throw VehicleError(key, "unknown key '" + key + "' (known: rotor, at_s)");
	}
	if (!have_rotor || !have_t)
		throw VehicleError(k, std::string("key 'stuck_rpm' needs '") + (have_rotor ? "at_s" : "rotor") + "'");
	return f;
}

// The imu_spike object: {"prob": P ([0, 1]), "gyro": rad/s (> 0), "accel": m/s^2 (> 0)}.
void imu_spike(const json::Value &v, ImuSpikeParams &s)
{
	if (v.kind != json::Value::Kind::Object)
		throw VehicleError("imu_spike",
				   "key 'imu_spike' must be an object {\"prob\": P, \"gyro\": G, \"accel\": A}");
	for (const auto &kv : v.obj) {
		const std::string key = "imu_spike." + kv.first;
		if (kv.first == "prob")
			s.prob = num(kv.second, key, Rule::Unit);
		else if (kv.first == "gyro")
			s.gyro = num(kv.second, key, Rule::Positive);
		else if (kv.first == "accel")
			s.accel = num(kv.second, key, Rule::Positive);
		else
			throw VehicleError(key, "unknown key '" + key + "' (known: prob, gyro, accel)");
	}
}

} // namespace

void vehicle_from_json(const std::string &text, VehicleParams &p)
{
	json::Value root;
	try {
		root = json::parse(text);
	} catch (const json::ParseError &e) {
		throw VehicleError("", std::string("not valid JSON: ") + e.what());
	}
	if (root.kind != json::Value::Kind::Object)
		throw VehicleError("", "the vehicle file must hold one JSON object");
	VehicleParams q = p;
	for (const auto &kv : root.obj) {
		const std::string &k = kv.first;
		const json::Value &v = kv.second;
		if (k == "mass")
			q.mass = num(v, k, Rule::Positive);
		else if (k == "g")
			q.g = num(v, k, Rule::NonNegative);
		else if (k == "arm_length")
			q.arm_length = num(v, k, Rule::Positive);
		else if (k == "kf")
			q.kf = num(v, k, Rule::Positive);
		else if (k == "ktau")
			q.ktau = num(v, k, Rule::Positive);
		else if (k == "inertia")
			vec(v, k, Rule::Positive, q.inertia);
		else if (k == "motor_tau")
			q.motor_tau = num(v, k, Rule::NonNegative);
		else if (k == "delay") {
			q.delay = num(v, k, Rule::NonNegative);
			if (q.delay > 10.0)
				throw out_of_range(k, q.delay, "[0, 10] s");
		} else if (k == "thrust_curve")
			q.thrust_curve = num(v, k, Rule::Unit);
		else if (k == "rotor_scale")
			vec(v, k, Rule::NonNegative, q.rotor_scale);
		else if (k == "kf_drift_per_min") {
			q.kf_drift_per_min = num(v, k, Rule::Any);
			if (std::fabs(q.kf_drift_per_min) > kMaxDriftPerMin)
				throw out_of_range(k, q.kf_drift_per_min,
						   "[-" + fmt(kMaxDriftPerMin) + ", " + fmt(kMaxDriftPerMin) +
							   "] (a fraction per minute: -0.02 is -2 %/min)");
		} else if (k == "origin") {
			vec(v, k, Rule::Any, q.origin);
			if (std::fabs(q.origin[0]) > 89.0 || std::fabs(q.origin[1]) > 180.0)
				throw VehicleError(
					k, "key 'origin' must be [lat (|lat| <= 89), lon (|lon| <= 180), alt_m]");
		} else if (k == "origin_shift_s") {
			if (v.kind != json::Value::Kind::Array)
				throw VehicleError(k, "key 'origin_shift_s' must be an array of plant times (s)");
			q.origin_shift_s.clear();
			for (const auto &e : v.arr) {
				const double ts = num(e, k, Rule::NonNegative);
				if (ts > 1e9)
					throw out_of_range(k, ts, "[0, 1e9] s");
				q.origin_shift_s.push_back(ts);
			}
			std::sort(q.origin_shift_s.begin(), q.origin_shift_s.end());
		} else if (k == "rotor_failure") {
			one_or_list(v, rotor_failure, q.rotor_failures);
		} else if (k == "stuck_rpm") {
			one_or_list(v, stuck_rpm, q.stuck_rpm);
		} else if (k == "imu_spike")
			imu_spike(v, q.imu_spike);
		else if (k == "noise") {
			non_negative_members(v, k,
					     {{"thrust", &q.noise.thrust},
					      {"torque", &q.noise.torque},
					      {"gyro", &q.noise.gyro},
					      {"attitude_deg", &q.noise.attitude_deg},
					      {"position", &q.noise.position},
					      {"accel", &q.noise.accel},
					      {"rpm", &q.noise.rpm},
					      {"current", &q.noise.current}});
		} else if (k == "imu_bias") {
			non_negative_members(v, k,
					     {{"accel", &q.imu_bias.accel},
					      {"gyro", &q.imu_bias.gyro},
					      {"accel_walk", &q.imu_bias.accel_walk},
					      {"gyro_walk", &q.imu_bias.gyro_walk}});
		} else if (k == "imu_scale") {
			q.imu_scale = num(v, k, Rule::NonNegative);
			if (q.imu_scale > 0.2)
				throw out_of_range(k, q.imu_scale, "[0, 0.2] (an sd as a fraction: 0.005 is 0.5 %)");
		} else if (k == "vibration") {
			if (v.kind != json::Value::Kind::Object)
				throw VehicleError(k, "key 'vibration' must be an object");
			for (const auto &nk : v.obj) {
				const std::string key = "vibration." + nk.first;
				if (nk.first == "harmonics") {
					const json::Value &h = nk.second;
					if (h.kind != json::Value::Kind::Array || h.arr.empty() ||
					    h.arr.size() > q.vibration.harmonics.size())
						throw VehicleError(
							key, "key '" + key + "' must be an array of 1 to " +
								     std::to_string(q.vibration.harmonics.size()) +
								     " numbers");
					q.vibration.harmonics.fill(0.0);
					for (size_t i = 0; i < h.arr.size(); i++)
						q.vibration.harmonics[i] = num(h.arr[i], key, Rule::NonNegative);
					continue;
				}
				if (nk.first == "accel")
					q.vibration.accel = num(nk.second, key, Rule::NonNegative);
				else if (nk.first == "gyro")
					q.vibration.gyro = num(nk.second, key, Rule::NonNegative);
				else if (nk.first == "cutoff_hz")
					q.vibration.cutoff_hz = num(nk.second, key, Rule::Positive);
				else if (nk.first == "sample_hz") {
					q.vibration.sample_hz = num(nk.second, key, Rule::Positive);
					if (q.vibration.sample_hz < 100.0 || q.vibration.sample_hz > 32000.0)
						throw out_of_range(key, q.vibration.sample_hz, "[100, 32000] Hz");
				} else
					throw VehicleError(key, "unknown key '" + key + "'");
			}
			if (!(q.vibration.cutoff_hz < 0.45 * q.vibration.sample_hz))
				throw out_of_range("vibration.cutoff_hz", q.vibration.cutoff_hz,
						   "< 0.45 vibration.sample_hz = " + fmt(0.45 * q.vibration.sample_hz) +
							   " Hz");
		} else if (k == "rpm_max")
			q.rpm_max = num(v, k, Rule::Positive);
		else if (k == "esc_pole_pairs") {
			q.esc_pole_pairs = num(v, k, Rule::Positive);
			if (q.esc_pole_pairs != std::floor(q.esc_pole_pairs) || q.esc_pole_pairs > 64)
				throw out_of_range(k, q.esc_pole_pairs, "an integer in [1, 64]");
		} else if (k == "esc_kt")
			q.esc_kt = num(v, k, Rule::Positive);
		else if (k == "thrust_row_scale")
			q.thrust_row_scale = num(v, k, Rule::Positive);
		else if (k == "esc_current_offset")
			q.esc_current_offset = num(v, k, Rule::Any);
		else if (k == "sensors") {
			if (v.kind != json::Value::Kind::Array || v.arr.empty())
				throw VehicleError(
					k,
					"key 'sensors' must be a non-empty list of \"imu\", \"rpm\", \"torque\", \"thrust\"");
			std::string list;
			for (const auto &e : v.arr) {
				if (e.kind != json::Value::Kind::String)
					throw VehicleError(k, "key 'sensors' must be a list of strings");
				list += (list.empty() ? "" : ",") + e.str;
			}
			std::string bad;
			if (!sensors_parse(list, q.sensors, bad))
				throw VehicleError(k, "key 'sensors': unknown sensor '" + bad +
							      "' (known: imu, rpm, torque, thrust)");
		} else
			throw VehicleError(k, "unknown key '" + k + "'");
	}
	check_physics(q);
	p = q;
}

void vehicle_load(const std::string &path, VehicleParams &p)
{
	std::ifstream f(path, std::ios::binary);
	if (!f)
		throw VehicleError("", "cannot read '" + path + "'");
	std::ostringstream ss;
	ss << f.rdbuf();
	vehicle_from_json(ss.str(), p);
}

} // namespace sim
