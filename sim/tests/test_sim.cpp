// Unit tests of octo-sim's model, actuator, JSON reader and byte encoders.
// Run by `make test-sim` and by tests/py/test_sim_model.py; exit status 0 when
// every test passes. Physics checks use the model class directly (no sockets).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "actuator.hpp"
#include "json.hpp"
#include "model.hpp"
#include "vehicle.hpp"
#include "rng.hpp"
#include "xplane_emit.hpp"
#include "xplane_input.hpp"
#include "xplane_proto.hpp"

using namespace sim;

static int g_failed = 0, g_checks = 0;
static const char *g_test = "";

#define CHECK(cond, ...)                                                               \
	do {                                                                           \
		g_checks++;                                                            \
		if (!(cond)) {                                                         \
			g_failed++;                                                    \
			std::printf("FAIL %s (%s:%d): %s: ", g_test, __FILE__, __LINE__, #cond); \
			std::printf(__VA_ARGS__);                                      \
			std::printf("\n");                                             \
		}                                                                      \
	} while (0)

struct TestCase {
	const char *name;
	std::function<void()> fn;
};
static std::vector<TestCase> &registry()
{
	static std::vector<TestCase> r;
	return r;
}
struct Reg {
	Reg(const char *n, std::function<void()> f) { registry().push_back({n, f}); }
};
#define TEST(name)                                  \
	static void name();                         \
	static Reg reg_##name(#name, name);         \
	static void name()

static VehicleParams ideal()
{
	VehicleParams p;
	p.make_ideal();
	return p;
}

static RotorArray all(double v)
{
	RotorArray u;
	u.fill(v);
	return u;
}

static std::string hex(const xp::Bytes &b)
{
	std::string s;
	char t[3];
	for (uint8_t c : b) {
		std::snprintf(t, sizeof t, "%02x", c);
		s += t;
	}
	return s;
}

// ------------------------------------------------------------------ physics

TEST(hover_holds_altitude_1mm_10s)
{
	VehicleParams p = ideal();
	Model m(p);
	BodyState x;
	x.r.z() = 10.0;
	m.set_state(x, 0.0);
	m.command(all(p.mass * p.g / (8 * p.kf)));
	double worst = 0;
	for (int n = 1; n <= 900; n++) {
		m.advance_to(n / 90.0);
		worst = std::max(worst, std::fabs(m.state().r.z() - 10.0));
	}
	std::printf("  hover: worst altitude error over 10 s %.3g m\n", worst);
	CHECK(worst < 1e-3, "worst altitude error %g m", worst);
	CHECK(std::fabs(m.t() - 10.0) < 1e-12, "t = %.15g", m.t());
	CHECK(m.state().w.norm() < 1e-12, "rates %g", m.state().w.norm());
}

TEST(hover_from_ground_stays_landed_below_weight)
{
	VehicleParams p = ideal();
	Model m(p);
	m.command(all(0.5 * p.hover_throttle()));
	m.advance_to(2.0);
	CHECK(m.on_ground(), "should rest on the ground");
	CHECK(m.state().r.z() == 0.0, "z = %g", m.state().r.z());
	m.command(all(1.2 * p.hover_throttle()));
	m.advance_to(3.0);
	CHECK(!m.on_ground() && m.state().r.z() > 0.1, "should climb: z = %g", m.state().r.z());
}

TEST(free_fall_matches_half_g_t2)
{
	VehicleParams p = ideal();
	Model m(p);
	BodyState x;
	x.r.z() = 100.0;
	m.set_state(x, 0.0);
	m.command(all(0.0));
	double worst = 0;
	for (int n = 1; n <= 270; n++) { // 3 s
		m.advance_to(n / 90.0);
		const double t = m.t();
		worst = std::max(worst, std::fabs(m.state().r.z() - (100.0 - 0.5 * p.g * t * t)));
	}
	std::printf("  free fall: worst error over 3 s %.3g m\n", worst);
	CHECK(worst < 1e-9, "free-fall error %g m", worst);
	// and the ground stops it
	m.advance_to(10.0);
	CHECK(m.state().r.z() == 0.0 && m.on_ground(), "z = %g", m.state().r.z());
}

// A contact the legs cannot take stops the body where and as it hit, whatever the rotors
// do after; a gentle one lands level (hover_from_ground_stays_landed_below_weight).
TEST(crash_tilted_or_fast_contact_stays_down)
{
	VehicleParams p = ideal();
	const struct {
		double tilt_deg, vz;
		bool crash;
	} cases[] = {{80.0, -1.0, true}, {65.0, -0.5, true}, {30.0, -1.0, false}, {0.0, -12.0, true},
		     {0.0, -3.0, false}};
	for (const auto &c : cases) {
		Model m(p);
		BodyState x;
		x.r.z() = 0.05;
		x.v.z() = c.vz;
		x.q = Eigen::Quaterniond(Eigen::AngleAxisd(c.tilt_deg * M_PI / 180.0, Eigen::Vector3d::UnitX()));
		m.set_state(x, 0.0);
		m.command(all(0.0));
		m.advance_to(0.2);
		CHECK(m.on_ground() && m.state().r.z() == 0.0, "tilt %g vz %g: z = %g", c.tilt_deg, c.vz,
		      m.state().r.z());
		CHECK(m.crashed() == c.crash, "tilt %g vz %g: crashed %d", c.tilt_deg, c.vz, m.crashed());
		if (!c.crash)
			continue;
		CHECK(std::fabs(m.crash().tilt_deg - c.tilt_deg) < 1.0 && m.crash().t < 0.2, "crash tilt %g at %g s",
		      m.crash().tilt_deg, m.crash().t);
		// full throttle: the body stays (tipped as it hit), the rotors still spin up
		const Eigen::Quaterniond q = m.state().q;
		m.command(all(1.0));
		m.advance_to(2.0);
		CHECK(m.state().r.norm() < 1e-12 && m.state().v.norm() == 0.0 && m.state().q.isApprox(q),
		      "moved after the crash: z %g", m.state().r.z());
		CHECK(m.acceleration().norm() == 0.0, "acceleration after a crash");
		CHECK(m.state().s[0] > 0.99, "rotor state %g", m.state().s[0]);
		const XpFrame f = xp_measure(m, all(1.0), 1, 180);
		float v = -1;
		std::array<float, 16> th{};
		CHECK(xp_dataref(f, "sim/flightmodel2/misc/has_crashed", 12, true, th, th, v) && v == 1.0f,
		      "has_crashed %g", v);
	}
}

TEST(torque_free_tumble_conserves_momentum_and_energy)
{
	VehicleParams p = ideal();
	Model m(p);
	m.set_ground(false);
	BodyState x;
	x.r.z() = 1000;
	x.w = Eigen::Vector3d(0.6, -0.4, 0.9);
	m.set_state(x, 0.0);
	m.command(all(0.0));
	const Eigen::Vector3d I(p.inertia[0], p.inertia[1], p.inertia[2]);
	auto h_inertial = [&]() { return Eigen::Vector3d(m.state().q * I.cwiseProduct(m.state().w)); };
	const Eigen::Vector3d h0 = h_inertial();
	const double e0 = m.kinetic_energy_rot();
	double worst_h = 0, worst_e = 0;
	for (int n = 1; n <= 900; n++) {
		m.advance_to(n / 90.0);
		worst_h = std::max(worst_h, (h_inertial() - h0).norm() / h0.norm());
		worst_e = std::max(worst_e, std::fabs(m.kinetic_energy_rot() - e0) / e0);
	}
	std::printf("  tumble: relative error momentum %.3g, energy %.3g\n", worst_h, worst_e);
	CHECK(worst_h < 1e-9, "angular momentum relative error %g", worst_h);
	CHECK(worst_e < 1e-9, "kinetic energy relative error %g", worst_e);
	CHECK((m.state().w - x.w).norm() > 0.1, "the body should actually tumble");
}

// A nonlinear manoeuvre (rotors uneven, lag on) integrated with steps h, h/2 and a
// fine reference: RK4's error ratio must be about 2^4 = 16.
TEST(rk4_order_error_ratio_16)
{
	VehicleParams p = ideal();
	p.motor_tau = 0.05;
	auto run = [&](double h) {
		Model m(p);
		m.set_ground(false);
		m.set_h_max(h);
		BodyState x;
		x.r.z() = 50;
		x.w = Eigen::Vector3d(1.0, -0.5, 0.7);
		m.set_state(x, 0.0);
		RotorArray u{{0.2, 0.05, 0.15, 0.08, 0.12, 0.1, 0.02, 0.18}};
		m.command(u);
		m.advance_to(2.0);
		Eigen::Matrix<double, 13, 1> v;
		v << m.state().r, m.state().v, m.state().q.w(), m.state().q.x(), m.state().q.y(), m.state().q.z(),
		    m.state().w;
		return v;
	};
	const auto ref = run(0.02 / 64);
	const double e1 = (run(0.02) - ref).norm();
	const double e2 = (run(0.01) - ref).norm();
	const double ratio = e1 / e2;
	std::printf("  rk4: error(h=20ms) %.3g, error(h=10ms) %.3g, ratio %.2f\n", e1, e2, ratio);
	CHECK(ratio > 13 && ratio < 19, "ratio %g", ratio);
}

// Gamma_o of eq. (14): [f; tau] = Gamma_o f for any rotor forces.
TEST(geometry_matches_gamma_o)
{
	VehicleParams p = ideal();
	Model m(p);
	const double l = p.arm_length, r2 = std::sqrt(2.0) / 2 * l, k = p.ktau / p.kf;
	const double G[4][8] = {
		{1, 1, 1, 1, 1, 1, 1, 1},
		{0, -r2, -l, -r2, 0, r2, l, r2},
		{-l, -r2, 0, r2, l, r2, 0, -r2},
		{k, -k, k, -k, k, -k, k, -k},
	};
	BodyState x;
	RotorArray s{{0.11, 0.32, 0.05, 0.27, 0.19, 0.08, 0.41, 0.14}};
	x.s = s;
	RotorOutputs o = m.rotor_outputs(x, 0.0);
	double want[4] = {0, 0, 0, 0};
	for (int i = 0; i < 4; i++)
		for (int j = 0; j < 8; j++)
			want[i] += G[i][j] * p.kf * s[j];
	CHECK(std::fabs(o.force - want[0]) < 1e-12, "f %g vs %g", o.force, want[0]);
	for (int i = 0; i < 3; i++)
		CHECK(std::fabs(o.torque_b(i) - want[i + 1]) < 1e-12, "tau[%d] %g vs %g", i, o.torque_b(i), want[i + 1]);
}

// ------------------------------------------------------------------ actuator

TEST(lag_reaches_63_percent_at_tau)
{
	VehicleParams p = ideal();
	p.motor_tau = 0.03;
	Model m(p);
	m.command(all(0.5));
	m.advance_to(0.03);
	CHECK(std::fabs(m.state().s[0] - 0.5 * (1 - std::exp(-1.0))) < 1e-7, "s = %.9f", m.state().s[0]);
}

TEST(transport_delay_shifts_the_step)
{
	VehicleParams p = ideal();
	p.delay = 0.005;
	Model m(p);
	m.command(all(0.3));
	m.advance_to(0.004);
	CHECK(m.state().s[2] == 0.0, "before the delay s = %g", m.state().s[2]);
	m.advance_to(0.006);
	CHECK(m.state().s[2] == 0.3, "after the delay s = %g", m.state().s[2]);
}

TEST(rotor_scale_curve_and_drift)
{
	VehicleParams p = ideal();
	p.rotor_scale[3] = 0.5;
	p.thrust_curve = 0.4;
	p.kf_drift_per_min = -0.06;
	Model m(p);
	BodyState x;
	x.s = all(0.5);
	RotorOutputs o = m.rotor_outputs(x, 30.0); // half a minute: factor 0.97
	const double g = 0.6 * 0.5 + 0.4 * 0.25;
	CHECK(std::fabs(o.thrust[0] - p.kf * 0.97 * g) < 1e-12, "thrust %g", o.thrust[0]);
	CHECK(std::fabs(o.thrust[3] - 0.5 * p.kf * 0.97 * g) < 1e-12, "thrust %g", o.thrust[3]);
	CHECK(std::fabs(o.torque[1] + p.ktau * 0.97 * g) < 1e-12, "torque %g", o.torque[1]);
}

TEST(command_clamps_and_rejects_nan)
{
	VehicleParams p = ideal();
	Model m(p);
	RotorArray u{{-1, 2, NAN, 0.5, INFINITY, 0, 1, 0.25}};
	m.command(u);
	const RotorArray &c = m.last_command();
	CHECK(c[0] == 0 && c[1] == 1 && c[2] == 0 && c[3] == 0.5 && c[4] == 0 && c[7] == 0.25, "clamped");
}

// ------------------------------------------------------------------ X-Plane frames

TEST(emitter_conventions)
{
	VehicleParams p = ideal();
	Model m(p);
	BodyState x;
	x.r = Eigen::Vector3d(3, 4, 5); // 3 m north, 4 m west, 5 m up
	x.v = Eigen::Vector3d(1, 2, 3);
	x.w = Eigen::Vector3d(0.1, 0.2, 0.3);
	// paper yaw +30 deg (counter-clockwise from above) -> heading 330
	x.q = Eigen::Quaterniond(Eigen::AngleAxisd(30 * M_PI / 180, Eigen::Vector3d::UnitZ()));
	m.set_state(x, 0.0);
	XpFrame f = xp_measure(m, all(0), 1, 0);
	CHECK(std::fabs(f.heading - 330) < 1e-9, "heading %g", f.heading);
	CHECK(std::fabs(f.P - 0.1) < 1e-12 && std::fabs(f.Q + 0.2) < 1e-12 && std::fabs(f.R + 0.3) < 1e-12, "PQR");
	xp::DataRow r21 = xp_row(f, 21, 12);
	// OpenGL's origin is at sea level: y is the field's elevation plus the height
	const float y21 = static_cast<float>(m.params().origin[2] + 5.0);
	CHECK(r21.col[0] == -4.0f && r21.col[1] == y21 && r21.col[2] == -3.0f, "local xyz %g %g %g", r21.col[0],
	      r21.col[1], r21.col[2]);
	CHECK(r21.col[3] == -2.0f && r21.col[4] == 3.0f && r21.col[5] == -1.0f, "local v");
	xp::DataRow r16_12 = xp_row(f, 16, 12), r16_11 = xp_row(f, 16, 11);
	CHECK(std::fabs(r16_12.col[0] - 0.1 * 180 / M_PI) < 1e-4, "v12 c1 = P deg/s");
	CHECK(r16_11.col[0] == -0.2f && r16_11.col[1] == 0.1f && r16_11.col[2] == -0.3f, "v11 Q P R rad/s");
	CHECK(r16_12.col[3] == xp::kNoData && r16_12.col[7] == xp::kNoData, "unused columns -999");
	// roll right (paper: negative rotation about X_B... i.e. positive about forward in FRD)
	x.q = Eigen::Quaterniond(Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX()));
	m.set_state(x, 0.0);
	f = xp_measure(m, all(0), 1, 0);
	CHECK(f.roll < -11 && f.roll > -12, "a left-side-down FLU rotation is a negative roll: %g", f.roll);
	x.q = Eigen::Quaterniond(Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitY()));
	m.set_state(x, 0.0);
	f = xp_measure(m, all(0), 1, 0);
	CHECK(f.pitch > 11 && f.pitch < 12, "a negative rotation about Y_B (left) is nose up: %g", f.pitch);
	// X-Plane q from the half angles equals the rotation NED <- FRD
	double q[4];
	xp_frame_quat(f, q);
	const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
	CHECK(std::fabs(n - 1) < 1e-12, "|q| = %g", n);
	CHECK(std::fabs(q[2] - std::sin(0.1)) < 1e-12, "q.y = %g", q[2]);
}

TEST(noise_depends_on_seed_and_frame_only)
{
	VehicleParams p; // default noise
	Model m(p);
	XpFrame a = xp_measure(m, all(0), 7, 3), b = xp_measure(m, all(0), 7, 3), c = xp_measure(m, all(0), 8, 3);
	CHECK(a.P == b.P && a.thrust_n[5] == b.thrust_n[5], "same seed and frame, same noise");
	CHECK(a.P != c.P, "another seed, other noise");
	// sigma of thrust noise: 1 % of hover thrust
	double s2 = 0;
	const int N = 4000;
	for (int k = 0; k < N; k++) {
		XpFrame f = xp_measure(m, all(0), 11, static_cast<uint64_t>(k));
		s2 += f.thrust_n[0] * f.thrust_n[0];
	}
	const double sigma = std::sqrt(s2 / N), want = 0.01 * p.mass * p.g / 8;
	CHECK(std::fabs(sigma / want - 1) < 0.05, "thrust sigma %g, want %g", sigma, want);
}

// A clock started at S (--start-time) changes what the plant shows as time, not its
// dynamics: the state after the same frames is the same bit for bit, row 1's mission time
// is the float32 of S + n / rate, and the crash time is on the clock.
TEST(start_time_moves_the_clock_not_the_dynamics)
{
	VehicleParams p;   // default noise
	for (double S : {40000.0, 1e6}) {
		Model a(p), b(p);
		b.set_clock_start(S);
		a.command(all(0.7));
		b.command(all(0.7));
		for (int n = 1; n <= 450; n++) {
			a.advance_to(n / 90.0);
			b.advance_to(n / 90.0);
		}
		CHECK(a.state().r == b.state().r && a.state().q.coeffs() == b.state().q.coeffs() &&
		      a.state().w == b.state().w, "S = %g: another state", S);
		CHECK(b.t() == a.t() && b.clock() == S + a.t(), "S = %g: t %.17g clock %.17g", S, b.t(), b.clock());
		XpFrame fa = xp_measure(a, all(0.7), 5, 450), fb = xp_measure(b, all(0.7), 5, 450);
		CHECK(fa.P == fb.P && fa.thrust_n[3] == fb.thrust_n[3], "S = %g: other noise", S);
		xp::DataRow r = xp_row(fb, 1, 12);
		CHECK(r.col[2] == static_cast<float>(S + 5.0), "S = %g: mission time %.9g", S, (double)r.col[2]);
	}
}

// The plant's per-frame form writes every field of the frame it is given: over a frame
// full of another frame's values it gives the very bytes of a fresh one.
TEST(measure_into_a_used_frame_writes_every_field)
{
	VehicleParams p;
	Model m(p);
	m.command(all(0.7));
	m.advance_to(0.5);
	static_assert(std::is_trivially_copyable<XpFrame>::value, "compared as bytes");
	XpFrame used, fresh = xp_measure(m, all(0.7), 3, 45);
	std::memset(static_cast<void *>(&used), 0x5a, sizeof used);   // all doubles: no padding
	xp_measure(m, all(0.7), 3, 45, used);
	CHECK(std::memcmp(&used, &fresh, sizeof used) == 0, "a field keeps the value it had");
}

// ------------------------------------------------------------------ byte vectors (xplane-udp.md)

TEST(data_out_vector_rows_16_17)
{
	xp::DataRow a{16, {1.5f, -2.25f, 10.0f, xp::kNoData, xp::kNoData, xp::kNoData, xp::kNoData, xp::kNoData}};
	xp::DataRow b{17, {2.0f, -4.5f, 237.75f, 259.25f, xp::kNoData, xp::kNoData, xp::kNoData, xp::kNoData}};
	const std::string want =
	    "444154412a100000000000c03f000010c00000204100c079c400c079c400c079c400c079c400c079c4"
	    "110000000000004000009" "0c000c06d4300a0814300c079c400c079c400c079c400c079c4";
	xp::Bytes d = xp::encode_data({a, b});
	CHECK(d.size() == 77, "size %zu", d.size());
	CHECK(hex(d) == want, "%s", hex(d).c_str());
}

TEST(data_row25_vector_bytes)
{
	xp::DataRow r{25, {0, .125f, .25f, .375f, .5f, .625f, .75f, 1.0f}};
	CHECK(hex(xp::encode_data({r}, 0)) ==
	          "444154410019000000000000000000003e0000803e0000c03e0000003f0000203f0000403f0000803f",
	      "%s", hex(xp::encode_data({r}, 0)).c_str());
}

TEST(rref_reply_vectors)
{
	auto one = xp::encode_rref_replies({{7, 0.25f}});
	CHECK(one.size() == 1 && hex(one[0]) == "525245462c070000000000803e", "%s", hex(one[0]).c_str());
	auto three = xp::encode_rref_replies({{1, 120100.0f}, {7, 0.25f}, {8, -1.5f}});
	CHECK(three.size() == 1 &&
	          hex(three[0]) == "525245462c010000000092ea47070000000000803e080000000000c0bf",
	      "%s", hex(three[0]).c_str());
	std::vector<std::pair<int32_t, float>> many;
	for (int i = 0; i < 400; i++)
		many.push_back({i, static_cast<float>(i)});
	auto split = xp::encode_rref_replies(many);
	CHECK(split.size() == 3 && split[0].size() == 5 + 8 * 183 && split[2].size() == 5 + 8 * 34, "split %zu",
	      split.size());
}

TEST(path_fields_and_indices)
{
	uint8_t f[8] = {'a', 'b', 0, ' ', ' ', ' ', ' ', ' '};
	std::string s;
	CHECK(xp::field_path(f, 8, s) && s == "ab", "NUL then spaces");
	uint8_t g[4] = {'a', 'b', 'c', 'd'};
	CHECK(!xp::field_path(g, 4, s), "unterminated");
	std::string base;
	int i;
	CHECK(xp::split_index("x/ENGN_thro_use[7]", base, i) && base == "x/ENGN_thro_use" && i == 7, "index");
	CHECK(!xp::split_index("x[]", base, i) && !xp::split_index("x[a]", base, i) &&
	          !xp::split_index("x[99999]", base, i) && !xp::split_index("x]", base, i),
	      "malformed subscripts");
}

// The definition field_path implements, one byte at a time.
static bool field_path_reference(const uint8_t *f, size_t n, size_t &len)
{
	for (size_t k = 0; k < n; k++) {
		if (f[k] == 0) {
			len = k;
			return k > 0;
		}
		if (f[k] < 0x21 || f[k] > 0x7e)
			return false;
	}
	return false;
}

// Every byte value at every position of paths of 0..24 bytes in fields of 1..40 bytes
// (the eight-byte words and the tail, the NUL anywhere or absent), and random fields,
// against the definition.
TEST(path_field_every_byte_everywhere)
{
	int wrong = 0, cases = 0;
	auto check = [&](const uint8_t *f, size_t n) {
		std::string_view out;
		size_t len = 0;
		const bool want = field_path_reference(f, n, len);
		const bool ok = xp::field_path(f, n, out);
		cases++;
		if (ok != want || (ok && (out.size() != len || out.data() != reinterpret_cast<const char *>(f))))
			wrong++;
	};
	for (size_t n = 1; n <= 40; n++)
		for (size_t nul = 0; nul <= n; nul++)   // nul == n: no NUL in the field
			for (size_t at = 0; at < n; at++)
				for (int v = 0; v < 256; v++) {
					uint8_t f[48];
					std::memset(f, 'a', sizeof f);
					for (size_t k = nul + 1; k < n; k++)
						f[k] = static_cast<uint8_t>(0xff - k);   // after the NUL: anything
					if (nul < n)
						f[nul] = 0;
					f[at] = static_cast<uint8_t>(v);
					if (at > 0)
						f[at - 1] = (v & 1) ? 0x7e : 0x21;   // neighbours at both edges of the range
					check(f, n);
				}
	Rng r(5, Stream::Noise, 0);
	for (int i = 0; i < 200000; i++) {
		uint8_t f[48];
		const size_t n = 1 + r.next() % 48;
		for (size_t k = 0; k < n; k++) {
			const uint64_t x = r.next();
			f[k] = static_cast<uint8_t>(x % 16 == 0 ? 0 : x % 16 == 1 ? x >> 8 : 0x21 + (x >> 8) % 0x5e);
		}
		check(f, n);
	}
	CHECK(wrong == 0, "%d of %d fields judged wrongly", wrong, cases);
}

// ------------------------------------------------------------------ JSON and vehicle files

TEST(json_reader)
{
	json::Value v = json::parse(R"({"a": [1, -2.5e1, true, null], "b": {"c": "x\u00e9\n"}})");
	CHECK(v.kind == json::Value::Kind::Object && v.obj.size() == 2, "object");
	CHECK(v.obj[0].second.arr[1].num == -25.0, "number");
	CHECK(v.obj[1].second.obj[0].second.str == "x\xc3\xa9\n", "string escapes");
	CHECK(std::isinf(json::parse("Infinity").num) && std::isnan(json::parse("NaN").num) &&
	          json::parse("-Infinity").num < 0,
	      "non-finite numbers as Python writes them");
	const char *bad[] = {"", "{", "{\"a\":}", "[1,]", "01", "{\"a\":1,\"a\":2}", "\"abc", "nul", "[1] x", "1e999"};
	for (const char *b : bad) {
		bool threw = false;
		try {
			json::parse(b);
		} catch (const json::ParseError &) {
			threw = true;
		}
		CHECK(threw, "'%s' must be rejected", b);
	}
	std::string deep(200, '[');
	bool threw = false;
	try {
		json::parse(deep);
	} catch (const json::ParseError &) {
		threw = true;
	}
	CHECK(threw, "deep nesting rejected");
}

TEST(vehicle_keys)
{
	VehicleParams p;
	vehicle_from_json(R"({"mass": 3, "inertia": [0.1, 0.2, 0.3], "noise": {"gyro": 0.01},
	                      "rotor_scale": [1,1,1,1,1,1,1,0], "origin": [10, 20, 30]})", p);
	CHECK(p.mass == 3 && p.inertia[2] == 0.3 && p.noise.gyro == 0.01 && p.rotor_scale[7] == 0, "applied");
	CHECK(p.kf == 28.0269, "absent keys keep defaults");
	struct {
		const char *text, *key;
	} bad[] = {
		{R"({"mass": 0})", "mass"},           {R"({"mass": -2})", "mass"},
		{R"({"inertia": [1, 0, 1]})", "inertia"}, {R"({"inertia": [1, 1]})", "inertia"},
		{R"({"bogus": 1})", "bogus"},         {R"({"noise": {"gyr": 1}})", "noise.gyr"},
		{R"({"kf": "x"})", "kf"},             {R"({"thrust_curve": 2})", "thrust_curve"},
		{R"({"rotor_scale": [1]})", "rotor_scale"}, {R"({"motor_tau": -1})", "motor_tau"},
		{R"({"g": NaN})", "g"},               {R"({"inertia": [1, Infinity, 1]})", "inertia"},
		{R"({"noise": {"gyro": -Infinity}})", "noise.gyro"},
	};
	for (const auto &b : bad) {
		std::string key = "?";
		try {
			VehicleParams q;
			vehicle_from_json(b.text, q);
		} catch (const VehicleError &e) {
			key = e.key;
		}
		CHECK(key == b.key, "%s: key '%s'", b.text, key.c_str());
	}
}

// ------------------------------------------------------------------ fuzz (most useful under make sim-asan)

TEST(fuzz_json_and_vehicle_never_crash)
{
	Rng r(1, Stream::Noise, 0);
	const std::string alphabet = "{}[]\",:.-+eE0123456789 \n\\truefalsnNaIinfy\"massgkfinertia";
	const std::string seed = R"({"mass": 2, "inertia": [0.1, 0.2, 0.3], "noise": {"gyro": 0.01}})";
	int parsed = 0;
	for (int k = 0; k < 20000; k++) {
		std::string t = seed;
		const int edits = 1 + static_cast<int>(r.next() % 6);
		for (int e = 0; e < edits; e++) {
			const size_t pos = r.next() % (t.size() + 1);
			const char c = alphabet[r.next() % alphabet.size()];
			switch (r.next() % 3) {
			case 0: t.insert(pos, 1, c); break;
			case 1: if (pos < t.size()) t.erase(pos, 1); break;
			default: if (pos < t.size()) t[pos] = c; break;
			}
		}
		try {
			VehicleParams p;
			vehicle_from_json(t, p);
			parsed++;
			if (!(p.mass > 0 && p.inertia[0] > 0 && p.inertia[1] > 0 && p.inertia[2] > 0 && std::isfinite(p.g)))
				CHECK(false, "accepted an impossible vehicle: %s", t.c_str());
		} catch (const VehicleError &) {
		}
	}
	CHECK(parsed > 0, "some mutations stay valid");
}

static std::vector<uint8_t> dref_bytes(float v, const char *path, size_t path_len)
{
	std::vector<uint8_t> b(xp::kDrefSize, 0);
	std::memcpy(b.data(), "DREF", 4);
	std::memcpy(b.data() + 5, &v, 4);
	std::memcpy(b.data() + 9, path, path_len);
	return b;
}

// The throttle DREFs taken by their bytes give what the full decoding gives: the same
// throttle written by "[d]" and by "[0d]" (decoded in full), and the counters of the
// full decoding for fields that only look like them.
TEST(dref_throttle_by_bytes_as_in_full)
{
	const float values[] = {0.0f, 0.37f, 1.0f, 1.5f, -0.2f, NAN, INFINITY};
	int differ = 0;
	for (int d = 0; d < 10; d++)
		for (float v : values) {
			Counters ca, cb;
			XpInput a(ca), b(cb);
			sockaddr_in from{};
			char p1[64], p2[64];
			std::snprintf(p1, sizeof p1, "sim/flightmodel/engine/ENGN_thro_use[%d]", d);
			std::snprintf(p2, sizeof p2, "sim/flightmodel/engine/ENGN_thro_use[0%d]", d);
			auto x = dref_bytes(v, p1, std::strlen(p1)), y = dref_bytes(v, p2, std::strlen(p2));
			x[9 + std::strlen(p1) + 1] = 'z';   // after the NUL: not part of the path
			a.handle(x.data(), x.size(), from);
			b.handle(y.data(), y.size(), from);
			if (a.thro_use != b.thro_use || a.cmd_mask != b.cmd_mask || std::memcmp(ca.v, cb.v, sizeof ca.v))
				differ++;
		}
	CHECK(differ == 0, "%d of 70 throttle DREFs decoded otherwise", differ);
	struct {
		const char *path;
		size_t len;
		Counters::Id counter;   // Count: a throttle written
	} near[] = {
	    {"sim/flightmodel/engine/ENGN_thro_use[7]x", 40, Counters::RxIgnoredDref},
	    {"sim/flightmodel/engine/ENGN_thro_use[7] ", 40, Counters::RxUnterminated},
	    {"sim/flightmodel/engine/ENGN_thro_use[a]", 39, Counters::RxIgnoredDref},
	    {"sim/flightmodel/engine/ENGN_thro_use[7", 38, Counters::RxIgnoredDref},
	    {"sim/flightmodel/engine/ENGN_thro_use[]", 38, Counters::RxIgnoredDref},
	    {"sim/flightmodel/engine/ENGN_thro_use[15]", 40, Counters::Count},
	    {"sim/flightmodel/engine/ENGN_thro_use[16]", 40, Counters::RxIgnoredDref},
	    {"sim/flightmodel/engine/ENGN_thro[7]", 35, Counters::Count},
	};
	for (const auto &n : near) {
		Counters c;
		XpInput in(c);
		sockaddr_in from{};
		auto x = dref_bytes(0.25f, n.path, n.len);
		in.handle(x.data(), x.size(), from);
		const bool wrote = in.thro_use[7] == 0.25f || in.thro_use[15] == 0.25f || in.thro[7] == 0.25f;
		const bool ok = n.counter == Counters::Count ? wrote && c[Counters::RxIgnoredDref] == 0
		                                             : !wrote && c[n.counter] == 1;
		CHECK(ok, "%s", n.path);
	}
}

TEST(fuzz_xplane_input_never_crashes)
{
	Counters c;
	XpInput in(c);
	Rng r(2, Stream::Noise, 0);
	sockaddr_in from{};
	std::vector<uint8_t> b;
	bool in_range = true;
	const char *tags[] = {"DATA", "DREF", "RREF", "DSEL", "USEL", "CMND", "ISE4", "XXXX"};
	for (int k = 0; k < 50000; k++) {
		const size_t sizes[] = {0, 3, 5, 9, 13, 37, 41, 77, 412, 413, 414, 508, 509, 510, 1500};
		size_t n = sizes[r.next() % 15];
		b.resize(n);
		for (auto &x : b)
			x = static_cast<uint8_t>(r.next() % 4 ? r.next() : 0);
		if (n >= 4)
			std::memcpy(b.data(), tags[r.next() % 8], 4);
		in.handle(b.data(), b.size(), from);
		for (size_t j = 0; j < 16; j++)
			in_range = in_range && in.thro[j] >= 0 && in.thro[j] <= 1 && in.thro_use[j] >= 0 && in.thro_use[j] <= 1;
	}
	CHECK(in_range, "throttles stay in [0, 1]");
	CHECK(c[Counters::RxDatagrams] == 50000, "all counted");
	CHECK(in.subs.size() <= XpInput::kMaxSubs, "subscriptions bounded");
}

int main()
{
	for (const auto &t : registry()) {
		g_test = t.name;
		int before = g_failed;
		t.fn();
		std::printf("%s %s\n", g_failed == before ? "ok  " : "FAIL", t.name);
	}
	std::printf("%zu tests, %d checks, %d failed\n", registry().size(), g_checks, g_failed);
	return g_failed ? 1 : 0;
}
