// xplane_emit: frames, units and Data Output rows as X-Plane 11/12 emit them.
#include "xplane_emit.hpp"

#include <algorithm>
#include <cmath>

#include "rng.hpp"

namespace sim
{

namespace
{

constexpr double kDeg = 180.0 / M_PI;
constexpr double kLbPerN = 1.0 / 4.4482216152605;
constexpr double kFtLbPerNm = 1.0 / 1.3558179483314;
constexpr double kFtPerM = 1.0 / 0.3048;
constexpr double kKnPerMps = 3600.0 / 1852.0;
constexpr double kMphPerMps = 3600.0 / 1609.344;
constexpr double kHpPerW = 1.0 / 745.69987158227;
constexpr double kEarthR = 6371008.8; // m, mean radius (flat-earth offsets)
constexpr double kSoundMps = 340.29;

float f32(double v) { return static_cast<float>(v); }

void euler_from_rotation(const Eigen::Matrix3d &Rnf, double &roll, double &pitch, double &yaw)
{
	// R maps FRD to NED; Z-Y-X sequence
	pitch = std::asin(std::max(-1.0, std::min(1.0, -Rnf(2, 0))));
	roll = std::atan2(Rnf(2, 1), Rnf(2, 2));
	yaw = std::atan2(Rnf(1, 0), Rnf(0, 0));
}

// The origin's moves, east and north in m, cycled (xp_origin_offset).
constexpr double kShiftMoves[4][2] = {{11200.0, -7400.0}, {-4600.0, 13900.0}, {9300.0, 5100.0}, {-15800.0, -2700.0}};

} // namespace

void xp_origin_offset(const VehicleParams &p, double t, double off[3])
{
	double e = 0, n = 0;
	size_t k = 0;
	for (double ts : p.origin_shift_s) {
		if (ts > t)
			break;
		e += kShiftMoves[k % 4][0];
		n += kShiftMoves[k % 4][1];
		k++;
	}
	off[0] = -e;
	off[1] = -(e * e + n * n) / (2 * kEarthR);
	off[2] = n;
}

XpFrame xp_measure(const Model &m, const RotorArray &thro_cmd, uint64_t seed, uint64_t frame)
{
	XpFrame f;
	xp_measure(m, thro_cmd, seed, frame, f);
	return f;
}

void xp_measure(const Model &m, const RotorArray &thro_cmd, uint64_t seed, uint64_t frame, XpFrame &f)
{
	const Sensors s(m.params(), seed, 90.0);
	xp_measure(m, thro_cmd, seed, frame, s, f);
}

void xp_measure(const Model &m, const RotorArray &thro_cmd, uint64_t seed, uint64_t frame, const Sensors &s, XpFrame &f)
{
	const VehicleParams &p = m.params();
	const BodyState &x = m.state();
	Rng rng(seed, Stream::Noise, frame);
	f.t = m.clock();

	// body rates: the gyro's reading (FLU) -> FRD, white noise
	const Eigen::Vector3d w = s.gyro(x.w);
	const double sg = p.noise.gyro;
	f.P = w.x() + sg * rng.gauss();
	f.Q = -w.y() + sg * rng.gauss();
	f.R = -w.z() + sg * rng.gauss();

	// attitude: R_ned<-frd = D R_i<-b D with D = diag(1, -1, -1)
	const Eigen::Matrix3d D = Eigen::Vector3d(1, -1, -1).asDiagonal();
	const Eigen::Matrix3d Rnf = D * x.q.normalized().toRotationMatrix() * D;
	double roll, pitch, yaw;
	euler_from_rotation(Rnf, roll, pitch, yaw);
	const double sa = p.noise.attitude_deg / kDeg;
	roll += sa * rng.gauss();
	pitch += sa * rng.gauss();
	yaw += sa * rng.gauss();
	f.roll = roll * kDeg;
	f.pitch = pitch * kDeg;
	double hdg = std::fmod(yaw * kDeg, 360.0);
	if (hdg < 0)
		hdg += 360.0;
	if (hdg >= 360.0)
		hdg -= 360.0;
	f.heading = hdg;
	f.roll_rad = roll;
	f.pitch_rad = pitch;
	f.yaw_rad = yaw;

	// position (noise), velocity (true)
	const double sp_ = p.noise.position;
	f.north = x.r.x() + sp_ * rng.gauss();
	f.east = -x.r.y() + sp_ * rng.gauss();
	f.up = x.r.z() + sp_ * rng.gauss();
	f.vn = x.v.x();
	f.ve = -x.v.y();
	f.vd = -x.v.z();
	const double lat0 = p.origin[0] / kDeg;
	f.lat = p.origin[0] + f.north / kEarthR * kDeg;
	f.lon = p.origin[1] + f.east / (kEarthR * std::cos(lat0)) * kDeg;
	f.alt_msl_m = p.origin[2] + f.up;
	f.agl_m = f.up;
	double off[3] = {0, 0, 0};
	if (!p.origin_shift_s.empty())
		xp_origin_offset(p, f.t, off);
	f.gl_x = f.east + off[0];
	f.gl_y = f.alt_msl_m + off[1];
	f.gl_z = -f.north + off[2];
	f.crashed = m.crashed() ? 1.0 : 0.0;

	// load factors: the accelerometer's reading of the specific force in the body (FLU)
	// plus its white noise, over g
	const RotorOutputs o = m.rotor_outputs(x, m.t());
	const Eigen::Vector3d acc = m.acceleration(o);
	const Eigen::Vector3d sf_i = acc + Eigen::Vector3d(0, 0, p.g);
	Eigen::Vector3d sf_b = s.accel(x.q.normalized().conjugate() * sf_i);
	Rng imu(seed, Stream::ImuNoise, frame);
	for (int i = 0; i < 3; i++)
		sf_b[i] += p.noise.accel * imu.gauss();
	const double g = p.g > 0 ? p.g : 9.80665;
	f.g_nrml = sf_b.z() / g;  // up along the body: +1 when level at rest
	f.g_axil = sf_b.x() / g;  // forward positive
	f.g_side = -sf_b.y() / g; // right positive

	// an IMU spike: one axis of one sensor replaced by an outlier (drawn every frame, so the
	// draws of one frame do not depend on the probability)
	Rng spike(seed, Stream::ImuSpike, frame);
	const double u_spike = spike.uniform(), u_which = spike.uniform(), u_sign = spike.uniform();
	if (u_spike < p.imu_spike.prob) {
		const int which = std::min(5, static_cast<int>(u_which * 6)); // gyro x y z, accel x y z
		const double sign = u_sign < 0.5 ? -1.0 : 1.0;
		double *gyro_frd[3] = {&f.P, &f.Q, &f.R};
		double *accel_g[3] = {&f.g_axil, &f.g_side, &f.g_nrml};
		if (which < 3)
			*gyro_frd[which] = sign * p.imu_spike.gyro;
		else
			*accel_g[which - 3] = sign * p.imu_spike.accel / g;
	}

	// rotors: true outputs plus noise on thrust; torque as the ESC's current gives it
	// (Kt times the current, whose offset and noise add to the torque's own noise);
	// speed as bidirectional DShot reports it
	const double st = p.sigma_thrust(), sq = p.sigma_torque();
	Rng esc(seed, Stream::Esc, frame);
	for (int j = 0; j < kRotors; j++) {
		f.thro_cmd[j] = thro_cmd[j];
		f.thro_act[j] = x.s[j];
		f.thrust_n[j] = p.thrust_row_scale * (o.thrust[j] + st * rng.gauss());
		f.torque_nm[j] = std::fabs(o.torque[j]) + sq * rng.gauss();
		f.torque_abs_nm[j] = std::fabs(o.torque[j]);
		f.rpm_true[j] =
			rotor_speed(p, x.s[j], m.t()) * std::sqrt(p.failure_factor(j, m.clock())) * (60.0 / (2 * M_PI));
		f.rpm[j] = dshot_rpm(f.rpm_true[j] + p.noise.rpm * esc.gauss(), p.esc_pole_pairs);
		f.torque_nm[j] += p.esc_kt * (p.esc_current_offset + p.noise.current * esc.gauss());
	}
}

void xp_frame_quat(const XpFrame &f, double q[4])
{
	const double roll = f.roll_rad, pitch = f.pitch_rad, yaw = f.yaw_rad;
	const double cr = std::cos(roll / 2), sr = std::sin(roll / 2);
	const double cp = std::cos(pitch / 2), sp = std::sin(pitch / 2);
	const double cy = std::cos(yaw / 2), sy = std::sin(yaw / 2);
	q[0] = cr * cp * cy + sr * sp * sy;
	q[1] = sr * cp * cy - cr * sp * sy;
	q[2] = cr * sp * cy + sr * cp * sy;
	q[3] = cr * cp * sy - sr * sp * cy;
}

double xp_frame_rpm(const XpFrame &f, int j) { return f.rpm_true[static_cast<size_t>(j)]; }

double xp_frame_power_w(const XpFrame &f, int j)
{
	return f.torque_abs_nm[static_cast<size_t>(j)] * xp_frame_rpm(f, j) * (2 * M_PI / 60.0);
}

const std::vector<int> &xp_supported_rows()
{
	static const std::vector<int> rows = {1, 3, 4, 16, 17, 20, 21, 25, 26, 34, 35, 36, 37, 38};
	return rows;
}

bool xp_row_supported(int row)
{
	for (int r : xp_supported_rows())
		if (r == row)
			return true;
	return false;
}

bool xp_row_served(int row, unsigned sensors)
{
	switch (row) {
	case 4:
	case 16: return (sensors & kSensorImu) != 0;
	case 35: return (sensors & kSensorThrust) != 0;
	case 36: return (sensors & kSensorTorque) != 0;
	case 37:
	case 38: return (sensors & kSensorRpm) != 0;
	default: return true;
	}
}

bool xp_dataref_served(const std::string &path, unsigned sensors)
{
	std::string base;
	int idx = -1;
	if (!xp::split_index(path, base, idx))
		return true;
	static const char *const imu[] = {
		"sim/flightmodel/position/Prad", "sim/flightmodel/position/Qrad", "sim/flightmodel/position/Rrad",
		"sim/flightmodel/position/P",    "sim/flightmodel/position/Q",    "sim/flightmodel/position/R",
		"sim/flightmodel/forces/g_nrml", "sim/flightmodel/forces/g_axil", "sim/flightmodel/forces/g_side"};
	for (const char *n : imu)
		if (base == n)
			return (sensors & kSensorImu) != 0;
	if (base == "sim/flightmodel/engine/POINT_thrust")
		return (sensors & kSensorThrust) != 0;
	if (base == "sim/flightmodel/engine/ENGN_TRQ")
		return (sensors & kSensorTorque) != 0;
	if (base == "sim/flightmodel/engine/POINT_tacrad" || base == "sim/flightmodel/engine/ENGN_tacrad")
		return (sensors & kSensorRpm) != 0;
	return true;
}

xp::DataRow xp_row(const XpFrame &f, int row, int version)
{
	xp::DataRow r;
	r.index = row;
	for (float &c : r.col)
		c = xp::kNoData;
	// speeds only for the rows that show them (hypot is not cheap, and this runs per row and frame)
	const bool speeds = row == 3 || row == 4;
	const double vh = speeds ? std::hypot(f.vn, f.ve) : 0.0;
	const double v = speeds ? std::sqrt(f.vn * f.vn + f.ve * f.ve + f.vd * f.vd) : 0.0;
	switch (row) {
	case 1: { // times: real, total, mission, timer, -, zulu h, local h
		const double hours = std::fmod(12.0 + f.t / 3600.0, 24.0);
		r.col[0] = r.col[1] = r.col[2] = r.col[3] = f32(f.t);
		r.col[5] = r.col[6] = f32(hours);
		break;
	}
	case 3: // speeds (no wind: air = ground)
		r.col[0] = r.col[1] = r.col[2] = f32(v * kKnPerMps);
		r.col[3] = f32(vh * kKnPerMps);
		r.col[5] = r.col[6] = f32(v * kMphPerMps);
		r.col[7] = f32(vh * kMphPerMps);
		break;
	case 4: // Mach, VVI ft/min, g normal, g axial, g side
		r.col[0] = f32(v / kSoundMps);
		r.col[2] = f32(-f.vd * kFtPerM * 60.0);
		r.col[4] = f32(f.g_nrml);
		r.col[5] = f32(f.g_axil);
		r.col[6] = f32(f.g_side);
		break;
	case 16: // angular velocities
		if (version >= 12) {
			r.col[0] = f32(f.P * 180.0 / M_PI);
			r.col[1] = f32(f.Q * 180.0 / M_PI);
			r.col[2] = f32(f.R * 180.0 / M_PI);
		} else {
			r.col[0] = f32(f.Q);
			r.col[1] = f32(f.P);
			r.col[2] = f32(f.R);
		}
		break;
	case 17: // pitch, roll, true heading, magnetic heading (no variation)
		r.col[0] = f32(f.pitch);
		r.col[1] = f32(f.roll);
		r.col[2] = f32(f.heading);
		r.col[3] = f32(f.heading);
		break;
	case 20: // lat, lon, alt ft MSL, alt ft AGL
		r.col[0] = f32(f.lat);
		r.col[1] = f32(f.lon);
		r.col[2] = f32(f.alt_msl_m * kFtPerM);
		r.col[3] = f32(f.agl_m * kFtPerM);
		break;
	case 21: { // OpenGL local position and velocity, distance from the origin
		r.col[0] = f32(f.gl_x);
		r.col[1] = f32(f.gl_y);
		r.col[2] = f32(f.gl_z);
		r.col[3] = f32(f.ve);
		r.col[4] = f32(-f.vd);
		r.col[5] = f32(-f.vn);
		const double d = std::hypot(f.gl_x, f.gl_z);
		r.col[6] = f32(d * kFtPerM);
		r.col[7] = f32(d / 1852.0);
		break;
	}
	case 25:
	case 26:
	case 34:
	case 35:
	case 36:
	case 37:
	case 38:
		for (int j = 0; j < kRotors; j++) {
			double val = 0;
			switch (row) {
			case 25: val = f.thro_cmd[j]; break;
			case 26: val = f.thro_act[j]; break;
			case 34: val = xp_frame_power_w(f, j) * kHpPerW; break;
			case 35: val = f.thrust_n[j] * kLbPerN; break;
			case 36: val = f.torque_nm[j] * kFtLbPerNm; break;
			default: val = f.rpm[j]; break;
			}
			r.col[j] = f32(val);
		}
		break;
	default: break;
	}
	return r;
}

bool xp_dataref(const XpFrame &f, const std::string &path, int version, bool override_on,
		const std::array<float, 16> &thro_use, const std::array<float, 16> &thro, float &out)
{
	std::string base;
	int idx = -1;
	if (!xp::split_index(path, base, idx))
		return false;
	const int i = idx < 0 ? 0 : idx;
	static const std::string pos = "sim/flightmodel/position/";
	static const std::string eng = "sim/flightmodel/engine/";
	if (base == "sim/version/xplane_internal_version") {
		out = version >= 12 ? 120100.0f : 115500.0f;
		return true;
	}
	if (base == "sim/time/total_running_time_sec" || base == "sim/time/total_flight_time_sec") {
		out = f32(f.t);
		return true;
	}
	if (base == "sim/flightmodel2/misc/has_crashed") {
		out = f32(f.crashed);
		return true;
	}
	if (base == "sim/operation/override/override_throttles") {
		out = override_on ? 1.0f : 0.0f;
		return true;
	}
	if (base.compare(0, eng.size(), eng) == 0) {
		const std::string n = base.substr(eng.size());
		if (i >= 16)
			return false;
		if (n == "ENGN_thro_use") {
			out = thro_use[static_cast<size_t>(i)];
			return true;
		}
		if (n == "ENGN_thro") {
			out = thro[static_cast<size_t>(i)];
			return true;
		}
		if (n == "POINT_thrust") {
			out = i < kRotors ? f32(f.thrust_n[static_cast<size_t>(i)]) : 0.0f;
			return true;
		}
		if (n == "ENGN_TRQ") {
			out = i < kRotors ? f32(f.torque_nm[static_cast<size_t>(i)]) : 0.0f;
			return true;
		}
		if (n == "POINT_tacrad" || n == "ENGN_tacrad") {
			out = i < kRotors ? f32(f.rpm[static_cast<size_t>(i)] * (2 * M_PI / 60.0)) : 0.0f;
			return true;
		}
		return false;
	}
	static const std::string forces = "sim/flightmodel/forces/";
	if (base == forces + "g_nrml") {
		out = f32(f.g_nrml);
		return true;
	}
	if (base == forces + "g_axil") {
		out = f32(f.g_axil);
		return true;
	}
	if (base == forces + "g_side") {
		out = f32(f.g_side);
		return true;
	}
	if (base.compare(0, pos.size(), pos) != 0)
		return false;
	const std::string n = base.substr(pos.size());
	const double rd = 180.0 / M_PI;
	double v;
	if (n == "Prad")
		v = f.P;
	else if (n == "Qrad")
		v = f.Q;
	else if (n == "Rrad")
		v = f.R;
	else if (n == "P")
		v = f.P * rd;
	else if (n == "Q")
		v = f.Q * rd;
	else if (n == "R")
		v = f.R * rd;
	else if (n == "theta")
		v = f.pitch;
	else if (n == "phi")
		v = f.roll;
	else if (n == "psi")
		v = f.heading;
	else if (n == "q") {
		if (i > 3)
			return false;
		double q[4];
		xp_frame_quat(f, q);
		v = q[i];
	} else if (n == "local_x")
		v = f.gl_x;
	else if (n == "local_y")
		v = f.gl_y;
	else if (n == "local_z")
		v = f.gl_z;
	else if (n == "local_vx")
		v = f.ve;
	else if (n == "local_vy")
		v = -f.vd;
	else if (n == "local_vz")
		v = -f.vn;
	else if (n == "latitude")
		v = f.lat;
	else if (n == "longitude")
		v = f.lon;
	else if (n == "elevation")
		v = f.alt_msl_m;
	else if (n == "y_agl")
		v = f.agl_m;
	else
		return false;
	out = f32(v);
	return true;
}

} // namespace sim
