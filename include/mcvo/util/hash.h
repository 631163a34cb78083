// Counter-based hashing and a portable seeded generator: the one source of
// randomness for synthetic data and any other deterministic draw. Unlike
// std::*_distribution, these give the same numbers on every platform and
// standard library, and a hash of (seed, frame, camera, pixel, ...) needs no
// shared generator state, so parallel work draws the same numbers in any
// order and at any thread count.
#pragma once

#include <cstdint>
#include <initializer_list>

namespace mcvo {

// SplitMix64 (Steele, Lea, Flood 2014): a bijection of 64-bit words with full
// avalanche, including its Weyl increment.
inline uint64_t SplitMix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

// An avalanching bijection on 32 bits (xor-shift / odd-multiply rounds), for
// hot loops that hash lattice points (procedural textures).
inline uint32_t Mix32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x2C1B3C6DU;
  x ^= x >> 12;
  x *= 0x297A2D39U;
  x ^= x >> 15;
  return x;
}

// Hash of a sequence of words; order matters.
inline uint64_t HashWords(std::initializer_list<uint64_t> words) {
  uint64_t h = 0x6D63766F72656E64ULL;  // "mcvorend"
  for (uint64_t w : words) h = SplitMix64(h ^ SplitMix64(w));
  return h;
}

// Uniform double in [0, 1) from the top 53 bits of a hash.
inline double UnitFromHash(uint64_t h) { return static_cast<double>(h >> 11) * 0x1.0p-53; }

// Uniform double in (0, 1), never 0 or 1 (for logarithms, Box-Muller).
inline double OpenUnitFromHash(uint64_t h) { return (static_cast<double>(h >> 11) + 0.5) * 0x1.0p-53; }

// A sequential generator: the SplitMix64 sequence of a scrambled seed.
class SplitMix64Rng {
 public:
  explicit SplitMix64Rng(uint64_t seed) : state_(seed * 0xD1B54A32D192ED03ULL + 0x8CB92BA72F3D8DD7ULL) {}
  uint64_t Next() {
    const uint64_t x = state_;
    state_ += 0x9E3779B97F4A7C15ULL;
    return SplitMix64(x);
  }
  // Uniform in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * UnitFromHash(Next()); }
  // Uniform integer in [lo, hi] (modulo bias below 2^-40 for small ranges).
  int UniformInt(int lo, int hi) {
    return lo + static_cast<int>(Next() % static_cast<uint64_t>(hi - lo + 1));
  }
  bool Bernoulli(double p) { return Uniform(0.0, 1.0) < p; }
  uint32_t Seed32() { return static_cast<uint32_t>(Next() >> 32); }

 private:
  uint64_t state_;
};

}  // namespace mcvo
