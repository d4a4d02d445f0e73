// Angle and number constants, so no file defines pi or infinity again.
#pragma once

#include <limits>

namespace hdabench::util {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;  // radians per degree
constexpr double kRadToDeg = 180.0 / kPi;  // degrees per radian
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// deg * pi / 180, in that order: what the synthetic scenes and the example
// dataset compute. It can differ from deg * kDegToRad in the last bit, so the
// two are not interchangeable where bytes must stay the same.
inline double DegToRad(double deg) { return deg * kPi / 180.0; }

}  // namespace hdabench::util
