// physics.cpp - octo-sim's physics alone (sim::Model from build/sim/*.o, the sim's flags),
// for `make bench`: frames of 1/90 s (RK4 at h <= 2 ms: 5 steps of 2 ms + one of
// 1.111 ms, i.e. 6 RK4 steps per frame) flown as fast as possible at a hover throttle
// with a small varying command. Prints one JSON line:
//   {"frames": N, "rk4_steps": S, "wall_s": T, "frames_per_s": F, "rk4_steps_per_s": R,
//    "sim_s_per_wall_s": X}
// Usage: bench-physics [SIM_SECONDS]   (default 600)
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "model.hpp"
#include "vehicle.hpp"

int main(int argc, char **argv)
{
	double seconds = argc > 1 ? std::atof(argv[1]) : 600.0;
	const double rate = 90.0;
	long frames = static_cast<long>(seconds * rate);
	sim::VehicleParams p;
	sim::Model m(p);
	double hover = p.hover_throttle();
	// lift off first so that the ground-contact shortcut does not flatter the figure
	sim::RotorArray u{};
	for (auto &x : u)
		x = hover * 1.2;
	m.command(u);
	m.advance_to(1.0);
	long n0 = static_cast<long>(rate);
	auto t0 = std::chrono::steady_clock::now();
	volatile double sink = 0;
	for (long n = 0; n < frames; n++) {
		for (int j = 0; j < sim::kRotors; j++)
			u[j] = hover * (1.0 + 0.02 * ((n + j) % 7 - 3) / 3.0);
		m.command(u);
		m.advance_to(static_cast<double>(n0 + n + 1) / rate);
		sink = sink + m.state().r.z();
	}
	double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
	long steps = frames * 6; // ceil((1/90) / 0.002) = 6 RK4 steps per frame
	std::printf("{\"frames\": %ld, \"rk4_steps\": %ld, \"wall_s\": %.6f, \"frames_per_s\": %.1f, "
		    "\"rk4_steps_per_s\": %.1f, \"sim_s_per_wall_s\": %.1f, \"z_end_m\": %.3f}\n",
		    frames, steps, wall, frames / wall, steps / wall, seconds / wall, (double)sink / frames);
	return 0;
}
