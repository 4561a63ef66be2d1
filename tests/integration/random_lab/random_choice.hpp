// The random choices the lab and step generators of the randomized whole-lab test share.
#pragma once

#include <cmath>
#include <random>
#include <vector>

namespace motion::random_lab {

inline int uniform_int(std::mt19937_64& rng, int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); }
inline double uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}
inline bool chance(std::mt19937_64& rng, double p) { return std::bernoulli_distribution(p)(rng); }
template <typename T>
const T& pick(std::mt19937_64& rng, const std::vector<T>& v) {
  return v[static_cast<std::size_t>(uniform_int(rng, 0, static_cast<int>(v.size()) - 1))];
}
inline double round_to(double v, double step) { return std::round(v / step) * step; }

}  // namespace motion::random_lab
