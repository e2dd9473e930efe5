// rng: counter-based, seeded random numbers. Every random draw is a function of
// (seed, stream, frame index) only, so a lockstep run is reproducible whatever
// the wall-clock timing (how often the first frame is repeated, when a client
// selects rows) and switching one fault flag does not shift the noise.
#pragma once

#include <cmath>
#include <cstdint>

namespace sim
{

// Noise: the white noise of rows 16, 17, 20/21, 35 and 36 (its draws and their order are
// fixed); the IMU's and ESCs' own draws come from their own streams, so adding or
// changing them does not move the others.
enum class Stream : uint64_t {
	Noise = 1,
	Fault = 2,
	ImuSetup = 3, // once per run (frame 0): scale errors, constant biases, rotor phases
	ImuWalk = 4,  // per frame: bias random-walk increments
	ImuNoise = 5, // per frame: accelerometer white noise
	Esc = 6,      // per frame: rpm report and current noise
	ImuSpike = 7, // per frame: whether an IMU sample is an outlier, which one, its sign
};

inline uint64_t splitmix64(uint64_t &x)
{
	uint64_t z = (x += 0x9E3779B97F4A7C15ull);
	z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
	z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
	return z ^ (z >> 31);
}

// xoshiro256** seeded through splitmix64 from (seed, stream, frame).
class Rng
{
      public:
	Rng(uint64_t seed, Stream stream, uint64_t frame)
	{
		uint64_t x = seed ^ (static_cast<uint64_t>(stream) * 0xD1B54A32D192ED03ull);
		splitmix64(x);
		x ^= frame * 0x8CB92BA72F3D8DD7ull;
		for (auto &w : s_)
			w = splitmix64(x);
	}

	uint64_t next()
	{
		const uint64_t r = rotl(s_[1] * 5, 7) * 9;
		const uint64_t t = s_[1] << 17;
		s_[2] ^= s_[0];
		s_[3] ^= s_[1];
		s_[1] ^= s_[2];
		s_[0] ^= s_[3];
		s_[2] ^= t;
		s_[3] = rotl(s_[3], 45);
		return r;
	}

	// uniform in [0, 1)
	double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }

	// standard normal (Box-Muller; one value per call, always two uniforms)
	double gauss()
	{
		double u1 = uniform(), u2 = uniform();
		return std::sqrt(-2.0 * std::log(1.0 - u1)) * std::cos(6.283185307179586 * u2);
	}

      private:
	uint64_t s_[4];
	static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
};

} // namespace sim
