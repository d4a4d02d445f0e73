// Vectors of independent random draws whose numbers do not depend on the
// compiler.
//
// The arguments of one call are evaluated in an order each compiler chooses
// (GCC goes right to left, clang left to right), so
// `Eigen::Vector3d(d(rng), d(rng), d(rng))` fills x, y and z from different
// draws under each. These draw one component per statement, the last component
// first: GCC's order, the one the bench's seeded studies and test scenes were
// first drawn in, so their numbers stay the same.
#pragma once

#include <Eigen/Core>

namespace hdabench::util {

// (x, y), drawn y first.
template <typename Distribution, typename Generator>
Eigen::Vector2d DrawVector2(Distribution& x_distribution, Distribution& y_distribution,
                            Generator& generator) {
  const double y = y_distribution(generator);
  const double x = x_distribution(generator);
  return Eigen::Vector2d(x, y);
}
template <typename Distribution, typename Generator>
Eigen::Vector2d DrawVector2(Distribution& distribution, Generator& generator) {
  return DrawVector2(distribution, distribution, generator);
}

// (x, y, z), drawn z first.
template <typename Distribution, typename Generator>
Eigen::Vector3d DrawVector3(Distribution& x_distribution, Distribution& y_distribution,
                            Distribution& z_distribution, Generator& generator) {
  const double z = z_distribution(generator);
  const double y = y_distribution(generator);
  const double x = x_distribution(generator);
  return Eigen::Vector3d(x, y, z);
}
template <typename Distribution, typename Generator>
Eigen::Vector3d DrawVector3(Distribution& distribution, Generator& generator) {
  return DrawVector3(distribution, distribution, distribution, generator);
}

}  // namespace hdabench::util
