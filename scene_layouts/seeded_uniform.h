// Portable seeded numbers for everything a scene draws (placements, starts, jitter, handheld
// shake): the standard distributions differ between libraries, so draws are splitmix64 of
// (seed, stream, counter), mapped to [0, 1) with 53 bits. A stream number per use keeps the uses
// apart: adding a draw to one never moves another's.
#pragma once

#include <cstdint>

namespace odyssey::scene {

class SeededUniform {
 public:
  SeededUniform(std::uint64_t seed, std::uint64_t stream) : state_(seed * 0x9e3779b97f4a7c15ull ^ (stream + 1) * 0xbf58476d1ce4e5b9ull) {}
  double next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * 0x1.0p-53;
  }
  double between(double low, double high) { return low + (high - low) * next(); }

 private:
  std::uint64_t state_;
};

}  // namespace odyssey::scene
