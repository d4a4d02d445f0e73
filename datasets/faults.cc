#include "datasets/faults.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/text.h"

namespace hdabench::datasets {

namespace {

std::uint64_t SplitMix64(std::uint64_t* state) {
  std::uint64_t z = (*state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Uniform in (0, 1): 53 random bits, never 0.
double Uniform(std::uint64_t* state) {
  return (static_cast<double>(SplitMix64(state) >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

// Standard normal by Box-Muller: the same numbers on every platform, which
// std::normal_distribution does not promise.
double Gaussian(std::uint64_t* state) {
  const double u1 = Uniform(state);
  const double u2 = Uniform(state);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * util::kPi * u2);
}

[[noreturn]] void Refuse(const Fault& fault, const std::string& why) {
  throw InputError("fault " + FaultLabel(fault) + ": " + why);
}

void RequireFiniteMagnitude(const Fault& fault) {
  if (!std::isfinite(fault.magnitude)) Refuse(fault, "the magnitude is not finite");
}

// Unit vector up (against gravity) in the local frame.
Eigen::Vector3d UpOf(const Dataset& dataset) {
  const double g = dataset.gravity_in_local_mps2.norm();
  if (!(g > 0.0) || !std::isfinite(g)) throw InputError("the dataset's gravity is zero or not finite");
  return -dataset.gravity_in_local_mps2 / g;
}

// The horizontal direction of the camera's motion from frame1 to frame2 in
// the local frame (unit); the local x axis made horizontal when the motion is
// vertical.
Eigen::Vector3d MotionDirection(const Dataset& dataset, int frame1, int frame2) {
  const Eigen::Vector3d up = UpOf(dataset);
  Eigen::Vector3d d = dataset.CameraCenterInLocal(frame2) - dataset.CameraCenterInLocal(frame1);
  d -= d.dot(up) * up;
  if (!(d.norm() > 1e-9)) {
    d = Eigen::Vector3d::UnitX() - up.x() * up;
    if (!(d.norm() > 1e-9)) d = Eigen::Vector3d::UnitY() - up.y() * up;
  }
  return d.normalized();
}

// Every LRF range passed through `change`; throws when one comes out not
// finite or not > 0.
template <typename Change>
void ChangeRanges(const Fault& fault, Dataset* dataset, Change change) {
  for (LrfSample& sample : dataset->lrf) {
    const double range = change(sample);
    if (!std::isfinite(range) || !(range > 0.0)) {
      Refuse(fault, "it makes the LRF range at t = " + util::FixedText(sample.time_s, 3) + " s " +
                        util::FixedText(range, 3) + " m: a range must be > 0");
    }
    sample.range_m = range;
  }
}

// Turns every navigation attitude from `from_time_s` on by `angle_deg` about
// the horizontal axis across the motion (local frame).
void TurnAttitudes(double angle_deg, double from_time_s, const Eigen::Vector3d& motion,
                   const Eigen::Vector3d& up, Dataset* dataset) {
  const Eigen::Vector3d axis = up.cross(motion).normalized();
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(angle_deg * util::kDegToRad, axis));
  for (NavSample& sample : dataset->nav) {
    if (sample.time_s < from_time_s) continue;
    sample.local_from_body.rotation = (turn * sample.local_from_body.rotation).normalized();
  }
}

void ApplyFaultInPlace(const Fault& fault, int frame1, int frame2, std::uint64_t seed, Dataset* dataset);

// kFrameDropped: frame2 removed from the frames and the truth, the later
// frames numbered one lower, so that frame2 names the next frame.
void DropFrame(const Fault& fault, int frame1, int frame2, Dataset* dataset) {
  if (frame2 <= frame1) Refuse(fault, "image 2 (frame " + std::to_string(frame2) + ") must come after image 1");
  if (frame2 + 1 >= static_cast<int>(dataset->frames.size())) {
    Refuse(fault, "frame " + std::to_string(frame2) + " is the last: no frame after it takes its place");
  }
  if (!dataset->frames[static_cast<size_t>(frame2) + 1].HasImage()) {
    Refuse(fault, "frame " + std::to_string(frame2 + 1) + ", which would take frame " + std::to_string(frame2) +
                      "'s place, has no image (render it: hdabench synth --frames)");
  }
  dataset->frames.erase(dataset->frames.begin() + frame2);
  for (size_t i = 0; i < dataset->frames.size(); ++i) dataset->frames[i].index = static_cast<int>(i);
  std::vector<TruthPoints>& points = dataset->truth.points;
  points.erase(std::remove_if(points.begin(), points.end(), [&](const TruthPoints& p) { return p.frame == frame2; }),
               points.end());
  for (TruthPoints& p : points) p.frame -= p.frame > frame2 ? 1 : 0;
}

cv::Mat& PairImage(Dataset* dataset, int frame, const Fault& fault) {
  cv::Mat& image = dataset->frames[static_cast<size_t>(frame)].image;
  if (image.empty()) Refuse(fault, "the image of frame " + std::to_string(frame) + " is not loaded");
  return image;
}

}  // namespace

const std::vector<FaultInfo>& FaultCatalogue() {
  static const std::vector<FaultInfo> catalogue = {
      {FaultKind::kLrfAbsent, "lrf-absent", "", "no LRF sample at all", {1.0}},
      {FaultKind::kLrfStuck, "lrf-stuck", "s", "the LRF repeats the range it measured this long before image 1",
       {0.05, 0.1, 0.2}},
      {FaultKind::kLrfScale, "lrf-scale", "fraction", "LRF ranges times (1 + magnitude)",
       {-0.2, -0.1, -0.05, -0.02, 0.02, 0.05, 0.1, 0.2}},
      {FaultKind::kLrfOffset, "lrf-offset", "m", "LRF ranges plus the magnitude", {-50.0, -20.0, -5.0, 5.0, 20.0, 50.0}},
      {FaultKind::kLrfNoise, "lrf-noise", "m", "Gaussian noise on every LRF range, this sigma", {1.0, 5.0, 20.0, 50.0}},
      {FaultKind::kLrfRock, "lrf-rock", "m", "the beam hits a rock this tall: every range short by it along the beam",
       {0.5, 1.0, 2.0, 5.0}},
      {FaultKind::kNavPositionBias, "nav-position-bias", "m",
       "every navigation position moved this far along the pair's motion", {1.0, 5.0, 20.0}},
      {FaultKind::kNavDrift, "nav-drift", "m/s",
       "navigation position error growing at this rate along the pair's motion, from image 1",
       {0.05, 0.1, 0.2, 0.5, 1.0}},
      {FaultKind::kAttitudeBias, "attitude-bias", "deg",
       "every navigation attitude turned this far about the horizontal axis across the motion",
       {0.05, 0.1, 0.2, 0.5, 1.0}},
      {FaultKind::kAttitudeJump, "attitude-jump", "deg",
       "the same turn from halfway between the two images on", {0.02, 0.05, 0.1, 0.2, 0.5}},
      {FaultKind::kClockOffset, "clock-offset", "s", "the camera's time stamps late on the navigation's by this much",
       {0.005, 0.01, 0.02, 0.05, 0.1}},
      {FaultKind::kImageBlur, "image-blur", "px", "both images blurred by a Gaussian of this sigma", {0.5, 1.0, 2.0, 4.0}},
      {FaultKind::kImageSaturated, "image-saturated", "x", "both images' signal times this gain, clipped at full scale",
       {1.5, 2.0, 4.0, 8.0}},
      {FaultKind::kImageDark, "image-dark", "x", "both images' signal divided by this factor, requantized",
       {2.0, 4.0, 8.0, 16.0}},
      {FaultKind::kFrameRepeated, "frame-repeated", "", "image 2 is image 1 again (the camera sent one frame twice)",
       {1.0}},
      {FaultKind::kFrameDropped, "frame-dropped", "",
       "image 2 never arrived: the next frame the camera delivered takes its place", {1.0}},
  };
  return catalogue;
}

const FaultInfo& InfoOf(FaultKind kind) {
  for (const FaultInfo& info : FaultCatalogue()) {
    if (info.kind == kind) return info;
  }
  throw std::logic_error("fault kind missing from the catalogue");
}

FaultKind ParseFaultKind(const std::string& name) {
  std::string names;
  for (const FaultInfo& info : FaultCatalogue()) {
    if (name == info.name) return info.kind;
    names += (names.empty() ? "" : ", ") + std::string(info.name);
  }
  throw InputError("unknown fault '" + name + "': expected one of " + names);
}

std::string FaultLabel(const Fault& fault) {
  const FaultInfo& info = InfoOf(fault.kind);
  if (info.unit[0] == '\0') return info.name;
  return std::string(info.name) + "=" + util::ShortestText(fault.magnitude);
}

std::vector<Fault> ParseFaults(const std::string& text) {
  const size_t equals = text.find('=');
  const std::string name = text.substr(0, equals);
  const FaultKind kind = ParseFaultKind(name);
  const FaultInfo& info = InfoOf(kind);
  std::vector<Fault> faults;
  if (equals == std::string::npos) {
    for (const double m : info.sweep) faults.push_back({kind, m});
    return faults;
  }
  if (info.unit[0] == '\0') throw InputError("'" + text + "': " + name + " takes no magnitude");
  const std::string rest = text.substr(equals + 1);
  size_t start = 0;
  while (start <= rest.size()) {
    const size_t comma = rest.find(',', start);
    const std::string item = rest.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    double value = 0.0;
    if (util::ParseDouble(item, &value) != util::ParseStatus::kOk) {
      throw InputError("'" + text + "': '" + item + "' is not a finite number (" + info.unit + ")");
    }
    faults.push_back({kind, value});
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return faults;
}

void CheckFaultMagnitude(const Fault& fault) {
  RequireFiniteMagnitude(fault);
  const double m = fault.magnitude;
  switch (fault.kind) {
    case FaultKind::kLrfStuck:
      if (!(m >= 0.0)) Refuse(fault, "expected >= 0 seconds");
      return;
    case FaultKind::kLrfNoise:
      if (!(m >= 0.0 && m <= 1e7)) Refuse(fault, "expected a sigma >= 0 and at most 1e7 metres");
      return;
    case FaultKind::kLrfRock:
      if (!(m >= 0.0 && m <= 1e7)) Refuse(fault, "expected a height >= 0 and at most 1e7 metres");
      return;
    case FaultKind::kImageBlur:
      // Past 100 px nothing is left to match, and the kernel's cost grows with it.
      if (!(m > 0.0 && m <= 100.0)) Refuse(fault, "expected a sigma > 0 and at most 100 pixels");
      return;
    case FaultKind::kImageSaturated:
    case FaultKind::kImageDark:
      if (!(m > 1.0 && m <= 1e6)) Refuse(fault, "expected a factor > 1 and at most 1e6");
      return;
    // The rest: a bias, an offset or a scale, within what a sensor could be
    // off by (beyond, the arithmetic of the frames overflows before the method
    // sees anything).
    case FaultKind::kLrfScale:
      if (!(m > -1.0 && m <= 100.0)) Refuse(fault, "expected a fraction > -1 (a range stays > 0) and at most 100");
      return;
    case FaultKind::kLrfOffset:
    case FaultKind::kNavPositionBias:
      if (!(std::abs(m) <= 1e7)) Refuse(fault, "expected at most 1e7 metres either way");
      return;
    case FaultKind::kNavDrift:
      if (!(std::abs(m) <= 1e4)) Refuse(fault, "expected at most 1e4 m/s either way");
      return;
    case FaultKind::kAttitudeBias:
    case FaultKind::kAttitudeJump:
      if (!(std::abs(m) <= 180.0)) Refuse(fault, "expected at most 180 degrees either way");
      return;
    case FaultKind::kClockOffset:
      if (!(std::abs(m) <= 1e6)) Refuse(fault, "expected at most 1e6 seconds either way");
      return;
    default:
      return;  // no magnitude
  }
}

Fault ParseOneFault(const std::string& text) {
  const std::vector<Fault> faults = ParseFaults(text);
  if (faults.size() != 1) {
    throw InputError("'" + text + "' is a sweep of " + std::to_string(faults.size()) + " magnitudes: give one, NAME=M");
  }
  return faults.front();
}

void ApplyFault(const Fault& fault, int frame1, int frame2, std::uint64_t seed, Dataset* target) {
  // Worked on a copy (the pixels and truth arrays are shared, not copied) and
  // moved into place at the end: a fault refused halfway leaves the dataset as
  // it was.
  Dataset work = *target;
  ApplyFaultInPlace(fault, frame1, frame2, seed, &work);
  *target = std::move(work);
}

namespace {

void ApplyFaultInPlace(const Fault& fault, int frame1, int frame2, std::uint64_t seed, Dataset* dataset) {
  const int n = static_cast<int>(dataset->frames.size());
  for (const int frame : {frame1, frame2}) {
    if (frame < 0 || frame >= n) {
      Refuse(fault, "frame " + std::to_string(frame) + " is not in the dataset (frames 0.." +
                        std::to_string(n - 1) + ")");
    }
  }
  CheckFaultMagnitude(fault);
  const double m = fault.magnitude;
  const double t1 = dataset->frames[static_cast<size_t>(frame1)].time_s;
  const double t2 = dataset->frames[static_cast<size_t>(frame2)].time_s;
  switch (fault.kind) {
    case FaultKind::kLrfAbsent:
      dataset->lrf.clear();
      return;
    case FaultKind::kLrfStuck: {
      if (dataset->lrf.empty() || t1 - m < dataset->lrf.front().time_s) {
        Refuse(fault, "the LRF log does not reach back to " + util::FixedText(t1 - m, 3) + " s");
      }
      const double stuck_s = t1 - m;
      const double stuck_range = dataset->LrfRangeAt(stuck_s);
      ChangeRanges(fault, dataset,
                   [&](const LrfSample& s) { return s.time_s >= stuck_s ? stuck_range : s.range_m; });
      return;
    }
    case FaultKind::kLrfScale:
      ChangeRanges(fault, dataset, [&](const LrfSample& s) { return s.range_m * (1.0 + m); });
      return;
    case FaultKind::kLrfOffset:
      ChangeRanges(fault, dataset, [&](const LrfSample& s) { return s.range_m + m; });
      return;
    case FaultKind::kLrfNoise: {
      std::uint64_t state = seed ^ 0x4c5246u;  // "LRF"
      ChangeRanges(fault, dataset, [&](const LrfSample& s) { return s.range_m + m * Gaussian(&state); });
      return;
    }
    case FaultKind::kLrfRock: {
      const Eigen::Vector3d down = -UpOf(*dataset);
      ChangeRanges(fault, dataset, [&](const LrfSample& s) {
        Rigid3d local_from_body;
        try {
          local_from_body = dataset->LocalFromBodyAt(s.time_s);
        } catch (const std::out_of_range&) {
          return s.range_m;  // no attitude to say where the beam points: left as measured
        }
        const double cos_to_vertical = (local_from_body.rotation * s.boresight_in_body).normalized().dot(down);
        if (!(cos_to_vertical > 0.0)) return s.range_m;  // a beam that does not point down meets no rock
        return s.range_m - m / cos_to_vertical;
      });
      return;
    }
    case FaultKind::kNavPositionBias: {
      const Eigen::Vector3d shift = m * MotionDirection(*dataset, frame1, frame2);
      for (NavSample& sample : dataset->nav) sample.local_from_body.translation += shift;
      return;
    }
    case FaultKind::kNavDrift: {
      const Eigen::Vector3d direction = MotionDirection(*dataset, frame1, frame2);
      for (NavSample& sample : dataset->nav) {
        if (sample.time_s <= t1) continue;
        sample.local_from_body.translation += m * (sample.time_s - t1) * direction;
        sample.velocity_in_local_mps += m * direction;
      }
      return;
    }
    case FaultKind::kAttitudeBias:
    case FaultKind::kAttitudeJump: {
      const Eigen::Vector3d motion = MotionDirection(*dataset, frame1, frame2);
      const double from_s = fault.kind == FaultKind::kAttitudeBias ? -std::numeric_limits<double>::infinity()
                                                                   : 0.5 * (t1 + t2);
      TurnAttitudes(m, from_s, motion, UpOf(*dataset), dataset);
      return;
    }
    case FaultKind::kClockOffset: {
      for (FrameRecord& frame : dataset->frames) frame.time_s += m;
      for (const int frame : {frame1, frame2}) {
        try {
          (void)dataset->CamFromLocal(frame);
        } catch (const std::out_of_range&) {
          Refuse(fault, "frame " + std::to_string(frame) + " moves to " +
                            util::FixedText(dataset->frames[static_cast<size_t>(frame)].time_s, 3) +
                            " s, outside the navigation");
        }
      }
      return;
    }
    case FaultKind::kImageBlur:
      for (const int frame : {frame1, frame2}) {
        cv::Mat& image = PairImage(dataset, frame, fault);
        cv::Mat blurred;
        cv::GaussianBlur(image, blurred, cv::Size(0, 0), m, m, cv::BORDER_REFLECT_101);
        image = blurred;
      }
      return;
    case FaultKind::kImageSaturated:
    case FaultKind::kImageDark:
      for (const int frame : {frame1, frame2}) {
        cv::Mat& image = PairImage(dataset, frame, fault);
        cv::Mat changed;
        image.convertTo(changed, image.type(), fault.kind == FaultKind::kImageSaturated ? m : 1.0 / m);
        image = changed;
      }
      return;
    case FaultKind::kFrameRepeated:
      PairImage(dataset, frame2, fault) = PairImage(dataset, frame1, fault);
      return;
    case FaultKind::kFrameDropped:
      DropFrame(fault, frame1, frame2, dataset);
      return;
  }
}

}  // namespace

}  // namespace hdabench::datasets
