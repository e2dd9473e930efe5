// xplane_emit: the ONLY place where the paper's frames become X-Plane's.
//
// Conventions (see sim/README.md):
//   S_I (Z up) is placed on NED as X_I = north, Y_I = west, Z_I = up, with the
//   origin at the take-off point: N = x, E = -y, D = -z. Paper yaw 0 (nose along
//   X_I) is therefore heading 0 (north); a positive paper yaw (counter-clockwise
//   seen from above) lowers the heading.
//   Body FLU -> FRD: (x, y, z) -> (x, -y, -z), so P = w_x, Q = -w_y, R = -w_z.
//   OpenGL local frame (+X east, +Y up, +Z south): X = -y_I, Y = z_I + origin
//   altitude, Z = -x_I. As in X-Plane its origin lies on the earth's surface at
//   sea level, below the take-off point, so local_y is the elevation MSL.
//   Euler angles: Z-Y-X (heading, pitch, roll) from NED to FRD, in degrees.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "model.hpp"
#include "sensors.hpp"
#include "xplane_proto.hpp"

namespace sim
{

// One measured frame in X-Plane's frames and SI units (noise included).
struct XpFrame {
	double t = 0;                                    // the plant's clock, s (Model::clock)
	double P = 0, Q = 0, R = 0;                      // body rates about forward-right-down, rad/s
	double roll = 0, pitch = 0, heading = 0;         // deg (heading in [0, 360))
	double roll_rad = 0, pitch_rad = 0, yaw_rad = 0; // the same angles in radians (yaw not wrapped)
	double north = 0, east = 0, up = 0;              // m from the origin
	double vn = 0, ve = 0, vd = 0;                   // m/s (true, no noise)
	double lat = 0, lon = 0, alt_msl_m = 0, agl_m = 0;
	double gl_x = 0, gl_y = 0, gl_z = 0;       // OpenGL local position (m), origin shifts included
	double g_nrml = 1, g_axil = 0, g_side = 0; // IMU load factors (+1 level, at rest)
	RotorArray thro_cmd{};                     // throttle driving each engine
	RotorArray thro_act{};                     // actuator output s_j
	RotorArray thrust_n{};                     // measured thrust, N
	RotorArray torque_nm{};                    // measured engine torque (magnitude, ESC current * Kt), N m
	RotorArray rpm{};                          // rotor speed as the ESC reports it (DShot), rpm
	RotorArray rpm_true{};                     // true rotor speed, rpm
	RotorArray torque_abs_nm{};                // true engine torque (magnitude), N m
	double crashed = 0;                        // 1 after a crash (sim/flightmodel2/misc/has_crashed)
};

// The OpenGL local frame's displacement at plant time t (m, OpenGL axes): X-Plane moves
// its origin at a scenery shift; the vehicle file's origin_shift_s says when. The k-th
// shift (k = 1, 2, ...) moves the origin by the k-th entry of a fixed cycle of four moves
// of 5 to 16 km (east, north); the local frame is the tangent plane at the new origin,
// so y drops by the earth's curvature there, d^2 / 2R for the total move d. Latitude,
// longitude, elevation and the velocities do not change.
void xp_origin_offset(const VehicleParams &p, double t, double off[3]);

// Quantities few rows and datarefs show, computed when they are asked for (from the
// frame's fields alone, so the same frame gives the same values whenever that is):
// X-Plane's q [w x y z] from the half angles; true rotor speed (rpm) and shaft power (W).
void xp_frame_quat(const XpFrame &f, double q[4]);
double xp_frame_rpm(const XpFrame &f, int j);
double xp_frame_power_w(const XpFrame &f, int j);

// Builds the measured frame for the model's current state with the sensors' state s
// (advanced to this frame); white noise is drawn from Rng(seed, Noise, frame) in a fixed
// order (independent of the selected rows), the IMU's and ESCs' from their own streams.
// Every field of f is written (the plant's per-frame form: no temporary).
void xp_measure(const Model &m, const RotorArray &thro_cmd, uint64_t seed, uint64_t frame, const Sensors &s,
		XpFrame &f);
// The same with the sensors as they start a run (no walk, no vibration yet).
XpFrame xp_measure(const Model &m, const RotorArray &thro_cmd, uint64_t seed, uint64_t frame);
void xp_measure(const Model &m, const RotorArray &thro_cmd, uint64_t seed, uint64_t frame, XpFrame &f);

// Rows this emitter fills (ascending). Other selected rows are not sent.
const std::vector<int> &xp_supported_rows();
bool xp_row_supported(int row);
// Whether the sensors served (SensorBits) include what a row or a dataref shows: rows 4
// and 16 and the IMU's datarefs need imu, 35 thrust, 36 torque, 37/38 rpm. A row not
// served is not sent; a dataref not served replies 0 as an unknown one.
bool xp_row_served(int row, unsigned sensors);
bool xp_dataref_served(const std::string &path, unsigned sensors);

// One Data Output row in X-Plane units; unused columns -999. version: 11 or 12.
xp::DataRow xp_row(const XpFrame &f, int row, int version);

// Value of a dataref for an RREF reply; false for an unknown path.
bool xp_dataref(const XpFrame &f, const std::string &path, int version, bool override_on,
		const std::array<float, 16> &thro_use, const std::array<float, 16> &thro, float &out);

} // namespace sim
