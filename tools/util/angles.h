// Angle constants, so no file defines pi again.
#pragma once

namespace hdabench::util {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;  // radians per degree
constexpr double kRadToDeg = 180.0 / kPi;  // degrees per radian

}  // namespace hdabench::util
