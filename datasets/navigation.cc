#include "datasets/navigation.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "tools/util/text.h"

namespace hdabench::datasets {

namespace {

// Index i of the interval [times[i], times[i + 1]] holding time_s, with
// fraction u in [0, 1]; a single-sample table holds only its own time.
template <typename Sample>
void Locate(const std::vector<Sample>& samples, double time_s, const char* what, size_t* index,
            double* fraction) {
  if (samples.empty()) {
    throw std::out_of_range(std::string(what) + " has no samples");
  }
  const double first = samples.front().time_s;
  const double last = samples.back().time_s;
  if (!std::isfinite(time_s) || time_s < first || time_s > last) {
    throw std::out_of_range("time " + util::ShortestText(time_s) + " s is outside the " + what +
                            " span [" + util::ShortestText(first) + ", " +
                            util::ShortestText(last) + "] s");
  }
  if (samples.size() == 1) {
    *index = 0;
    *fraction = 0.0;
    return;
  }
  // First sample strictly after time_s; time_s == last falls in the last interval.
  const auto after = std::upper_bound(
      samples.begin(), samples.end(), time_s,
      [](double t, const Sample& sample) { return t < sample.time_s; });
  size_t upper = static_cast<size_t>(after - samples.begin());
  upper = std::clamp<size_t>(upper, 1, samples.size() - 1);
  *index = upper - 1;
  const double t0 = samples[*index].time_s;
  const double t1 = samples[upper].time_s;
  *fraction = std::clamp((time_s - t0) / (t1 - t0), 0.0, 1.0);
}

}  // namespace

Rigid3d InterpolateLocalFromBody(const std::vector<NavSample>& nav, double time_s) {
  size_t i = 0;
  double u = 0.0;
  Locate(nav, time_s, "navigation", &i, &u);
  const Rigid3d& a = nav[i].local_from_body;
  if (u == 0.0) return a;
  const Rigid3d& b = nav[i + 1].local_from_body;
  if (u == 1.0) return b;
  // Shorter arc: flip b into a's hemisphere (Eigen's slerp does the same; this
  // states it).
  Eigen::Quaterniond qb = b.rotation;
  if (a.rotation.dot(qb) < 0.0) qb.coeffs() = -qb.coeffs();
  Eigen::Quaterniond rotation = a.rotation.slerp(u, qb);
  rotation.normalize();
  const Eigen::Vector3d translation = (1.0 - u) * a.translation + u * b.translation;
  return Rigid3d(rotation, translation);
}

double InterpolateLrfRange(const std::vector<LrfSample>& lrf, double time_s) {
  size_t i = 0;
  double u = 0.0;
  Locate(lrf, time_s, "LRF", &i, &u);
  if (u == 0.0) return lrf[i].range_m;
  if (u == 1.0) return lrf[i + 1].range_m;
  return (1.0 - u) * lrf[i].range_m + u * lrf[i + 1].range_m;
}

double RotationAngleRad(const Eigen::Quaterniond& rotation) {
  // atan2 form: accurate for tiny angles, where acos(w) is not.
  const double sin_half = rotation.vec().norm();
  const double cos_half = std::abs(rotation.w());
  return 2.0 * std::atan2(sin_half, cos_half);
}

}  // namespace hdabench::datasets
