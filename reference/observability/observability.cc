#include "reference/observability/observability.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <sstream>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "hda/geometry.h"
#include "hda/pipeline.h"
#include "reference/flight/hda_params.h"
#include "tools/util/files.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/parallel_for.h"
#include "tools/util/python_script.h"
#include "tools/util/random_vectors.h"
#include "tools/util/text.h"

namespace hdabench::reference {
namespace {

using util::kDegToRad;
using util::kRadToDeg;
using util::kInfinity;
constexpr double kMoonGravityMps2 = 1.62;
// Trials handed to a thread at a time.
constexpr int kTrialsPerItem = 64;

std::uint64_t SplitMix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

std::uint64_t Bits(double value) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof bits);
  return bits;
}

// The trial's seed from the study seed, the setting's values and the trial.
std::uint64_t TrialSeed(std::uint64_t seed, const StudySetting& s, int trial) {
  std::uint64_t h = SplitMix(seed);
  for (const std::uint64_t v : {static_cast<std::uint64_t>(s.geometry), static_cast<std::uint64_t>(s.points),
                                Bits(s.pixel_noise_px), Bits(s.baseline_m), static_cast<std::uint64_t>(trial)}) {
    h = SplitMix(h ^ v);
  }
  return h;
}

// A small rotation with each axis' angle drawn from N(0, sigma_rad).
Eigen::Quaterniond RandomSmallRotation(double sigma_rad, std::mt19937_64* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Vector3d w = sigma_rad * util::DrawVector3(normal, *rng);
  const double angle = w.norm();
  if (angle == 0.0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle));
}

// p-quantile of sorted values that may end in +infinity: linear between order
// statistics, infinite as soon as an infinite one takes part.
double QuantileOf(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return kInfinity;
  const double position = p * static_cast<double>(sorted.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(position));
  const double fraction = position - static_cast<double>(lo);
  if (fraction == 0.0 || lo + 1 >= sorted.size()) return sorted[lo];
  if (std::isinf(sorted[lo + 1])) return kInfinity;
  return sorted[lo] + fraction * (sorted[lo + 1] - sorted[lo]);
}

std::string NumberText(double value) {
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  return util::ShortestText(value);
}

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string field;
  while (std::getline(in, field, ',')) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

// A whole file's text; InputError naming it when it cannot be read.
std::string ReadText(const std::string& path) {
  std::string bytes, error;
  if (!util::ReadFileBytes(path, &bytes, &error)) throw InputError(path + ": " + error);
  return bytes;
}

}  // namespace

const char* ToString(StudyGeometry geometry) {
  switch (geometry) {
    case StudyGeometry::kLateral: return "lateral";
    case StudyGeometry::kBoresight: return "boresight";
    case StudyGeometry::kForward: return "forward";
  }
  return "unknown";
}

StudyGeometry ParseStudyGeometry(const std::string& name) {
  for (const StudyGeometry g : {StudyGeometry::kLateral, StudyGeometry::kForward, StudyGeometry::kBoresight}) {
    if (name == ToString(g)) return g;
  }
  throw InputError("unknown geometry '" + name + "': expected lateral, forward or boresight");
}

std::vector<std::string> StudyOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(!geometries.empty(), "geometries", static_cast<double>(geometries.size()), "at least one", &errors);
  RequireOption(!baselines_m.empty(), "baselines_m", static_cast<double>(baselines_m.size()), "at least one",
                &errors);
  for (const double b : baselines_m) {
    RequireOption(std::isfinite(b) && b >= 0.0, "baseline_m", b, ">= 0", &errors);
  }
  RequireOption(!pixel_noises_px.empty(), "pixel_noises_px", static_cast<double>(pixel_noises_px.size()),
                "at least one", &errors);
  for (const double n : pixel_noises_px) {
    RequireOption(std::isfinite(n) && n >= 0.0, "pixel_noise_px", n, ">= 0", &errors);
  }
  RequireOption(!points.empty(), "points", static_cast<double>(points.size()), "at least one", &errors);
  for (const int n : points) RequireOption(n >= 3, "points", n, ">= 3", &errors);
  RequireOption(trials >= 1 && trials <= kMaxStudyTrials, "trials", trials,
                "in [1, 10000000] (each setting's errors are kept in memory to rank them)", &errors);
  RequireOption(std::isfinite(altitude_m) && altitude_m > 0.0, "altitude_m", altitude_m, "> 0", &errors);
  RequireOption(std::isfinite(downrange_m) && downrange_m >= 0.0, "downrange_m", downrange_m, ">= 0", &errors);
  RequireOption(std::isfinite(site_size_m) && site_size_m > 0.0, "site_size_m", site_size_m, "> 0", &errors);
  RequireOption(min_slope_deg >= 0.0 && min_slope_deg <= max_slope_deg, "min_slope_deg", min_slope_deg,
                "in [0, max_slope_deg]", &errors);
  RequireOption(max_slope_deg < 60.0, "max_slope_deg", max_slope_deg, "< 60", &errors);
  RequireOption(std::isfinite(relief_sigma_m) && relief_sigma_m >= 0.0, "relief_sigma_m", relief_sigma_m, ">= 0",
                &errors);
  RequireOption(std::isfinite(nav_position_sigma_m) && nav_position_sigma_m >= 0.0, "nav_position_sigma_m",
                nav_position_sigma_m, ">= 0", &errors);
  RequireOption(std::isfinite(nav_attitude_sigma_deg) && nav_attitude_sigma_deg >= 0.0, "nav_attitude_sigma_deg",
                nav_attitude_sigma_deg, ">= 0", &errors);
  RequireOption(std::isfinite(lrf_sigma_m) && lrf_sigma_m >= 0.0, "lrf_sigma_m", lrf_sigma_m, ">= 0", &errors);
  RequireOption(std::isfinite(requirement_deg) && requirement_deg > 0.0, "requirement_deg", requirement_deg, "> 0",
                &errors);
  for (const std::string& e : hda.Validate()) errors.push_back("hda: " + e);
  return errors;
}

void ResolveStudyHdaOptions(const HdaSettings& settings, const calib::CameraModel& camera, StudyOptions* options) {
  PairGeometry geometry;
  geometry.lrf_range_m = std::hypot(options->altitude_m, options->downrange_m);
  geometry.baseline_m = options->baselines_m.empty() ? 0.0 : options->baselines_m.back();
  std::vector<DerivedParam> derived;
  options->hda = ResolveHdaOptions(settings, camera, geometry, &derived);
  if (settings.given.count("prediction.nav_position_sigma_m") == 0) {
    options->hda.prediction.nav_position_sigma_m = options->nav_position_sigma_m;
  }
  if (settings.given.count("prediction.nav_attitude_sigma_deg") == 0) {
    options->hda.prediction.nav_attitude_sigma_deg = options->nav_attitude_sigma_deg;
  }
  if (settings.given.count("prediction.range_sigma_m") == 0) {
    options->hda.prediction.range_sigma_m = std::max(options->lrf_sigma_m, 1e-6);
  }
}

std::vector<StudySetting> StudySettings(const StudyOptions& options) {
  std::vector<StudySetting> settings;
  for (const StudyGeometry geometry : options.geometries) {
    for (const int points : options.points) {
      for (const double noise : options.pixel_noises_px) {
        for (const double baseline : options.baselines_m) {
          StudySetting s;
          s.index = static_cast<int>(settings.size());
          s.geometry = geometry;
          s.points = points;
          s.pixel_noise_px = noise;
          s.baseline_m = baseline;
          settings.push_back(s);
        }
      }
    }
  }
  return settings;
}

namespace {

// The two cameras of a trial in the local frame (x east, y north, z up, the
// ILS at the origin). Camera 1 looks at the ILS from the south, body x east
// (the image's x). Camera 2 has its attitude and is moved by the baseline:
// lateral east, across the line of sight; forward north, level, toward the
// site (at 45 deg off nadir 0.71 of it across the line of sight and 0.71
// along it); boresight along the optical axis.
struct TrialCameras {
  Rigid3d local_from_cam1;
  Rigid3d local_from_cam2;
  Eigen::Vector3d axis1 = Eigen::Vector3d::UnitZ();  // camera 1's optical axis, local frame
};

TrialCameras PlaceCameras(const StudyOptions& options, const StudySetting& setting) {
  const double off_nadir = std::atan2(options.downrange_m, options.altitude_m);
  const Eigen::Vector3d c1(0.0, -options.downrange_m, options.altitude_m);
  const Eigen::Vector3d z_cam(0.0, std::sin(off_nadir), -std::cos(off_nadir));
  const Eigen::Vector3d x_cam(1.0, 0.0, 0.0);
  Eigen::Matrix3d local_r_cam;
  local_r_cam.col(0) = x_cam;
  local_r_cam.col(1) = z_cam.cross(x_cam);
  local_r_cam.col(2) = z_cam;
  const Eigen::Vector3d north(0.0, 1.0, 0.0);
  const Eigen::Vector3d direction = setting.geometry == StudyGeometry::kLateral   ? x_cam
                                    : setting.geometry == StudyGeometry::kForward ? north
                                                                                  : z_cam;
  TrialCameras cameras;
  cameras.local_from_cam1 = Rigid3d(Eigen::Quaterniond(local_r_cam), c1);
  cameras.local_from_cam2 = Rigid3d(cameras.local_from_cam1.rotation, c1 + setting.baseline_m * direction);
  cameras.axis1 = z_cam;
  return cameras;
}

}  // namespace

TrialResult RunTrial(const StudyOptions& options, const calib::CameraModel& camera, const StudySetting& setting,
                     int trial) {
  std::mt19937_64 rng(TrialSeed(options.seed, setting, trial));
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);

  const TrialCameras cameras = PlaceCameras(options, setting);
  const Rigid3d& local_from_cam1 = cameras.local_from_cam1;
  const Rigid3d& local_from_cam2 = cameras.local_from_cam2;
  const Eigen::Vector3d& c1 = local_from_cam1.translation;
  const Eigen::Vector3d& z_cam = cameras.axis1;
  const Rigid3d cam1_from_local = local_from_cam1.Inverse();
  const Rigid3d cam2_from_local = local_from_cam2.Inverse();

  // The site: a plane through the ILS, its points, the truth.
  const double slope =
      (options.min_slope_deg + (options.max_slope_deg - options.min_slope_deg) * uniform(rng)) * kDegToRad;
  const double azimuth = 2.0 * util::kPi * uniform(rng);
  const Eigen::Vector3d n(std::sin(slope) * std::cos(azimuth), std::sin(slope) * std::sin(azimuth), std::cos(slope));
  const Eigen::Vector3d e1 =
      Eigen::Vector3d(std::cos(slope) * std::cos(azimuth), std::cos(slope) * std::sin(azimuth), -std::sin(slope));
  const Eigen::Vector3d e2 = n.cross(e1);
  const double half = 0.5 * options.site_size_m;
  std::vector<Eigen::Vector3d> points(static_cast<size_t>(setting.points));
  for (Eigen::Vector3d& p : points) {
    const double u = half * (2.0 * uniform(rng) - 1.0), v = half * (2.0 * uniform(rng) - 1.0);
    p = u * e1 + v * e2 + options.relief_sigma_m * normal(rng) * n;
  }
  const Eigen::Vector3d gravity(0.0, 0.0, -kMoonGravityMps2);
  TrialResult result;
  const hda::PlaneFitResult truth = hda::FitPlane(points, gravity, 3);
  result.true_slope_deg = truth.status == hda::PlaneFitStatus::kOk ? truth.slope_deg : slope * kRadToDeg;

  // Both images, with pixel noise; points either image misses are dropped.
  std::vector<Eigen::Vector3d> in_cam1, in_cam2;
  for (const Eigen::Vector3d& p : points) {
    in_cam1.push_back(cam1_from_local * p);
    in_cam2.push_back(cam2_from_local * p);
  }
  std::vector<Eigen::Vector2d> pixels1, pixels2;
  std::vector<unsigned char> valid1, valid2;
  camera.Project(in_cam1, &pixels1, &valid1);
  camera.Project(in_cam2, &pixels2, &valid2);
  const double w = camera.WidthPx() - 0.5, h = camera.HeightPx() - 0.5;
  std::vector<cv::Point2d> matched1, matched2;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d q1 = pixels1[i] + setting.pixel_noise_px * util::DrawVector2(normal, rng);
    const Eigen::Vector2d q2 = pixels2[i] + setting.pixel_noise_px * util::DrawVector2(normal, rng);
    const auto inside = [&](const Eigen::Vector2d& q) { return q.x() > -0.5 && q.y() > -0.5 && q.x() < w && q.y() < h; };
    if (!valid1[i] || !valid2[i] || !inside(q1) || !inside(q2)) continue;
    matched1.emplace_back(q1.x(), q1.y());
    matched2.emplace_back(q2.x(), q2.y());
  }

  // The site's box in image 1: its corners' bounds.
  std::vector<Eigen::Vector3d> corners;
  for (const double su : {-1.0, 1.0}) {
    for (const double sv : {-1.0, 1.0}) corners.push_back(cam1_from_local * (su * half * e1 + sv * half * e2));
  }
  std::vector<Eigen::Vector2d> corner_pixels;
  std::vector<unsigned char> corner_valid;
  if (camera.Project(corners, &corner_pixels, &corner_valid) != 4) {
    throw InputError("observability: the site is not in front of camera 1");
  }
  double x0 = kInfinity, y0 = kInfinity, x1 = -kInfinity, y1 = -kInfinity;
  for (const Eigen::Vector2d& q : corner_pixels) {
    x0 = std::min(x0, q.x());
    y0 = std::min(y0, q.y());
    x1 = std::max(x1, q.x());
    y1 = std::max(y1, q.y());
  }
  const cv::Rect whole(0, 0, camera.WidthPx(), camera.HeightPx());
  const cv::Rect box = cv::Rect(cv::Point(static_cast<int>(std::floor(x0 + 0.5)), static_cast<int>(std::floor(y0 + 0.5))),
                                cv::Point(static_cast<int>(std::floor(x1 + 0.5)) + 1,
                                          static_cast<int>(std::floor(y1 + 0.5)) + 1)) &
                       whole;
  if (box.empty()) throw InputError("observability: the site is outside camera 1's image");

  // What the navigation and the LRF say.
  const Rigid3d true_cam2_from_cam1 = cam2_from_local * local_from_cam1;
  const double position_sigma = options.nav_position_sigma_m;
  const double attitude_sigma = options.nav_attitude_sigma_deg * kDegToRad;
  hda::HdaInput input;
  const Eigen::Vector3d position_error = position_sigma * util::DrawVector3(normal, rng);  // drawn first
  input.cam2_from_cam1 =
      Rigid3d((RandomSmallRotation(attitude_sigma, &rng) * true_cam2_from_cam1.rotation).normalized(),
              true_cam2_from_cam1.translation + position_error);
  input.local_from_cam1 =
      Rigid3d((RandomSmallRotation(attitude_sigma, &rng) * local_from_cam1.rotation).normalized(), c1);
  input.gravity_in_local_mps2 = gravity;
  const double true_range = n.dot(-c1) / n.dot(z_cam);
  input.lrf_range_m = std::max(1e-3, true_range + options.lrf_sigma_m * normal(rng));
  input.ils_in_local_m = Eigen::Vector3d::Zero();

  // Fault injection (tests of the gate): noise on image 2's matches, drawn
  // last so that a study without it draws what it always drew.
  if (options.hda.fault_match_noise_px > 0.0) {
    for (cv::Point2d& p : matched2) {
      p.x += options.hda.fault_match_noise_px * normal(rng);
      p.y += options.hda.fault_match_noise_px * normal(rng);
    }
  }
  const hda::RoiResult roi = hda::EvaluateMatchedSite(input, camera, options.hda, box, matched1, matched2);
  result.has_fit = roi.has_fit && std::isfinite(roi.slope_deg);
  result.has_slope = result.has_fit && hda::HasSlope(roi.status);
  if (result.has_fit) {
    result.error_deg = roi.slope_deg - result.true_slope_deg;
    result.sigma_deg = roi.slope_sigma_deg;
  }
  return result;
}

SettingStats RunSetting(const StudyOptions& options, const calib::CameraModel& camera, const StudySetting& setting,
                        int threads) {
  std::vector<TrialResult> trials(static_cast<size_t>(options.trials));
  const int items = (options.trials + kTrialsPerItem - 1) / kTrialsPerItem;
  util::ParallelFor("observability trials", items, threads, [&](int item) {
    const int end = std::min(options.trials, (item + 1) * kTrialsPerItem);
    for (int t = item * kTrialsPerItem; t < end; ++t) trials[static_cast<size_t>(t)] = RunTrial(options, camera, setting, t);
  });
  SettingStats stats;
  stats.setting = setting;
  stats.trials = options.trials;
  std::vector<double> abs_errors;
  double sum_abs = 0.0, sum = 0.0, sum_sigma2 = 0.0;
  int within = 0;
  for (const TrialResult& t : trials) {
    if (!t.has_fit) {
      abs_errors.push_back(kInfinity);
      continue;
    }
    ++stats.fits;
    if (t.has_slope) ++stats.with_slope;
    abs_errors.push_back(std::abs(t.error_deg));
    sum_abs += std::abs(t.error_deg);
    sum += t.error_deg;
    sum_sigma2 += t.sigma_deg * t.sigma_deg;
    if (std::abs(t.error_deg) <= 2.0 * t.sigma_deg) ++within;
  }
  std::sort(abs_errors.begin(), abs_errors.end());
  stats.median_abs_error_deg = QuantileOf(abs_errors, 0.5);
  stats.p90_abs_error_deg = QuantileOf(abs_errors, 0.9);
  stats.p95_abs_error_deg = QuantileOf(abs_errors, 0.95);
  if (stats.fits > 0) {
    const double fits = stats.fits;
    stats.mean_abs_error_deg = sum_abs / fits;
    const double mean = sum / fits;
    double squares = 0.0;
    for (const TrialResult& t : trials) {
      if (t.has_fit) squares += (t.error_deg - mean) * (t.error_deg - mean);
    }
    stats.sd_error_deg = stats.fits > 1 ? std::sqrt(squares / (fits - 1.0)) : 0.0;
    stats.rms_sigma_deg = std::sqrt(sum_sigma2 / fits);
    stats.within_2_sigma = within / fits;
  }
  return stats;
}

std::string SettingsCsvHeader() {
  return "index,geometry,points,pixel_noise_px,baseline_m,trials,fits,with_slope,median_abs_error_deg,"
         "p90_abs_error_deg,p95_abs_error_deg,mean_abs_error_deg,sd_error_deg,rms_sigma_deg,sd_over_sigma,"
         "within_2_sigma";
}

std::string SettingsCsvRow(const SettingStats& s) {
  std::ostringstream row;
  const bool fits = s.fits > 0;
  const auto defined = [&](double v) { return fits ? NumberText(v) : std::string(); };
  row << s.setting.index << ',' << ToString(s.setting.geometry) << ',' << s.setting.points << ','
      << NumberText(s.setting.pixel_noise_px) << ',' << NumberText(s.setting.baseline_m) << ',' << s.trials << ','
      << s.fits << ',' << s.with_slope << ',' << NumberText(s.median_abs_error_deg) << ','
      << NumberText(s.p90_abs_error_deg) << ',' << NumberText(s.p95_abs_error_deg) << ','
      << defined(s.mean_abs_error_deg) << ',' << defined(s.sd_error_deg) << ',' << defined(s.rms_sigma_deg) << ','
      << (fits && s.rms_sigma_deg > 0.0 ? NumberText(s.sd_error_deg / s.rms_sigma_deg) : std::string()) << ','
      << defined(s.within_2_sigma);
  return row.str();
}

std::vector<SettingStats> ParseSettingsCsv(const std::string& text, const std::string& path) {
  std::vector<SettingStats> rows;
  std::stringstream in(text);
  std::string line;
  int number = 0;
  const auto fail = [&](const std::string& what) {
    throw InputError(path + ":" + std::to_string(number) + ": " + what);
  };
  while (std::getline(in, line)) {
    ++number;
    if (number == 1) {
      if (line != SettingsCsvHeader()) fail("not the header of an observability settings.csv");
      continue;
    }
    if (line.empty()) continue;
    const std::vector<std::string> f = SplitCsv(line);
    if (f.size() != 16) fail(std::to_string(f.size()) + " fields: expected 16");
    const auto number_of = [&](size_t i, bool may_be_empty) {
      if (f[i].empty()) {
        if (!may_be_empty) fail("field " + std::to_string(i + 1) + " is empty");
        return 0.0;
      }
      if (f[i] == "inf") return kInfinity;
      double v = 0.0;
      if (util::ParseDouble(f[i], &v) != util::ParseStatus::kOk || !std::isfinite(v)) {
        fail("field " + std::to_string(i + 1) + " '" + f[i] + "' is not a number");
      }
      return v;
    };
    SettingStats s;
    s.setting.index = static_cast<int>(number_of(0, false));
    try {
      s.setting.geometry = ParseStudyGeometry(f[1]);
    } catch (const InputError& e) {
      fail(e.what());
    }
    s.setting.points = static_cast<int>(number_of(2, false));
    s.setting.pixel_noise_px = number_of(3, false);
    s.setting.baseline_m = number_of(4, false);
    s.trials = static_cast<int>(number_of(5, false));
    s.fits = static_cast<int>(number_of(6, false));
    s.with_slope = static_cast<int>(number_of(7, false));
    s.median_abs_error_deg = number_of(8, false);
    s.p90_abs_error_deg = number_of(9, false);
    s.p95_abs_error_deg = number_of(10, false);
    s.mean_abs_error_deg = number_of(11, true);
    s.sd_error_deg = number_of(12, true);
    s.rms_sigma_deg = number_of(13, true);
    s.within_2_sigma = number_of(15, true);
    if (SettingsCsvRow(s) != line) fail("the row does not read back to itself");
    rows.push_back(s);
  }
  if (number == 0) fail("empty file");
  return rows;
}

std::vector<BaselineVerdict> SmallestBaselines(const std::vector<SettingStats>& stats, double requirement_deg) {
  std::vector<BaselineVerdict> verdicts;
  std::map<std::tuple<int, int, double>, size_t> verdict_of;  // (geometry, points, noise)
  for (const SettingStats& s : stats) {
    const auto key = std::make_tuple(static_cast<int>(s.setting.geometry), s.setting.points, s.setting.pixel_noise_px);
    auto it = verdict_of.find(key);
    if (it == verdict_of.end()) {
      BaselineVerdict v;
      v.geometry = s.setting.geometry;
      v.points = s.setting.points;
      v.pixel_noise_px = s.setting.pixel_noise_px;
      it = verdict_of.emplace(key, verdicts.size()).first;
      verdicts.push_back(v);
    }
    BaselineVerdict& v = verdicts[it->second];
    if (s.MeetsRequirement(requirement_deg) && (!v.met || s.setting.baseline_m < v.baseline_m)) {
      v.met = true;
      v.baseline_m = s.setting.baseline_m;
      v.p95_abs_error_deg = s.p95_abs_error_deg;
    }
  }
  for (BaselineVerdict& v : verdicts) {
    if (!v.met) continue;
    for (const SettingStats& s : stats) {
      if (s.setting.geometry != v.geometry && s.setting.points == v.points &&
          s.setting.pixel_noise_px == v.pixel_noise_px && s.setting.baseline_m == v.baseline_m) {
        v.others_p95_deg.emplace_back(s.setting.geometry, s.p95_abs_error_deg);
      }
    }
  }
  return verdicts;
}

std::string BaselinesCsv(const std::vector<BaselineVerdict>& verdicts) {
  std::ostringstream csv;
  csv << "geometry,points,pixel_noise_px,smallest_baseline_m,p95_abs_error_deg,other_geometry,"
         "other_p95_abs_error_deg,other_over_this\n";
  for (const BaselineVerdict& v : verdicts) {
    const std::string head = std::string(ToString(v.geometry)) + "," + std::to_string(v.points) + "," +
                             NumberText(v.pixel_noise_px) + ",";
    if (!v.met) {
      csv << head << ",,,,\n";
      continue;
    }
    const std::string met = head + NumberText(v.baseline_m) + "," + NumberText(v.p95_abs_error_deg) + ",";
    if (v.others_p95_deg.empty()) csv << met << ",,\n";
    for (const auto& [geometry, p95] : v.others_p95_deg) {
      csv << met << ToString(geometry) << "," << NumberText(p95) << ","
          << (v.p95_abs_error_deg > 0.0 ? NumberText(p95 / v.p95_abs_error_deg) : std::string()) << "\n";
    }
  }
  return csv.str();
}

std::string StudyJsonText(const StudyOptions& o, const calib::CameraModel& camera, const StudyShard& shard) {
  using Json = nlohmann::ordered_json;
  Json geometries = Json::array();
  for (const StudyGeometry g : o.geometries) geometries.push_back(ToString(g));
  Json j;
  j["format"] = "hdabench-observability";
  j["format_version"] = 1;
  j["geometries"] = geometries;
  j["baselines_m"] = o.baselines_m;
  j["pixel_noises_px"] = o.pixel_noises_px;
  j["points"] = o.points;
  j["trials"] = o.trials;
  j["altitude_m"] = o.altitude_m;
  j["downrange_m"] = o.downrange_m;
  j["site_size_m"] = o.site_size_m;
  j["min_slope_deg"] = o.min_slope_deg;
  j["max_slope_deg"] = o.max_slope_deg;
  j["relief_sigma_m"] = o.relief_sigma_m;
  j["nav_position_sigma_m"] = o.nav_position_sigma_m;
  j["nav_attitude_sigma_deg"] = o.nav_attitude_sigma_deg;
  j["lrf_sigma_m"] = o.lrf_sigma_m;
  j["requirement_deg"] = o.requirement_deg;
  j["seed"] = o.seed;
  j["camera"] = {{"lens_model", camera.LensModelName()},
                 {"intrinsics", camera.Intrinsics()},
                 {"width_px", camera.WidthPx()},
                 {"height_px", camera.HeightPx()}};
  j["hda"] = HdaOptionsJson(o.hda);
  j["settings"] = StudySettings(o).size();
  j["shard"] = {{"index", shard.index}, {"count", shard.count}};
  return j.dump(1) + "\n";
}

std::vector<SettingStats> RunStudy(const StudyOptions& options, const calib::CameraModel& camera,
                                   const StudyShard& shard, int threads,
                                   const std::function<void(const SettingStats&, int done, int total)>& progress) {
  ThrowIfInvalid("observability: ", options.Validate());
  std::vector<StudySetting> mine;
  for (const StudySetting& s : StudySettings(options)) {
    if (shard.Holds(s.index)) mine.push_back(s);
  }
  std::vector<SettingStats> stats;
  for (const StudySetting& s : mine) {
    stats.push_back(RunSetting(options, camera, s, threads));
    if (progress) progress(stats.back(), static_cast<int>(stats.size()), static_cast<int>(mine.size()));
  }
  return stats;
}

std::vector<std::string> WriteStudyFolder(const std::string& dir, const std::string& study_json_text,
                                          const std::vector<SettingStats>& stats, bool whole,
                                          double requirement_deg) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError(dir + ": cannot create the folder: " + ec.message());
  std::string csv = SettingsCsvHeader() + "\n";
  for (const SettingStats& s : stats) csv += SettingsCsvRow(s) + "\n";
  std::vector<std::string> written;
  util::WriteFileAtomically((std::filesystem::path(dir) / "study.json").string(), study_json_text);
  written.push_back("study.json");
  util::WriteFileAtomically((std::filesystem::path(dir) / "settings.csv").string(), csv);
  written.push_back("settings.csv");
  if (whole) {
    util::WriteFileAtomically((std::filesystem::path(dir) / "baselines.csv").string(),
                              BaselinesCsv(SmallestBaselines(stats, requirement_deg)));
    written.push_back("baselines.csv");
  }
  return written;
}

MergedStudy MergeStudyFolders(const std::vector<std::string>& dirs) {
  using Json = nlohmann::ordered_json;
  if (dirs.empty()) throw InputError("observability merge: no folder given");
  MergedStudy merged;
  Json reference;
  std::string reference_dir;
  int count = 0;
  std::vector<std::string> shard_dir;
  std::map<int, SettingStats> by_index;
  for (const std::string& dir : dirs) {
    const std::filesystem::path folder(dir);
    const std::string json_path = (folder / "study.json").string();
    Json j;
    try {
      j = Json::parse(ReadText(json_path));
    } catch (const nlohmann::json::exception& e) {
      throw InputError(json_path + ": not JSON: " + util::JsonErrorText(e.what()));
    }
    if (!j.is_object() || j.value("format", "") != "hdabench-observability" || !j.contains("shard")) {
      throw InputError(json_path + ": not an observability study's study.json");
    }
    const int index = j["shard"].value("index", 0), n = j["shard"].value("count", 0);
    Json rest = j;
    rest.erase("shard");
    if (reference_dir.empty()) {
      reference = rest;
      reference_dir = dir;
      count = n;
      shard_dir.assign(static_cast<size_t>(std::max(n, 0)) + 1, "");
    } else if (rest != reference) {
      throw InputError(json_path + ": another study than " + reference_dir + "'s (its options differ)");
    }
    if (n != count || index < 1 || index > count) {
      throw InputError(json_path + ": shard " + std::to_string(index) + "/" + std::to_string(n) + " of a study in " +
                       std::to_string(count) + " shards");
    }
    if (!shard_dir[static_cast<size_t>(index)].empty()) {
      throw InputError(json_path + ": shard " + std::to_string(index) + " is also in " +
                       shard_dir[static_cast<size_t>(index)]);
    }
    shard_dir[static_cast<size_t>(index)] = dir;
    const std::string csv_path = (folder / "settings.csv").string();
    for (const SettingStats& s : ParseSettingsCsv(ReadText(csv_path), csv_path)) {
      if (s.setting.index % count != index - 1 || by_index.count(s.setting.index) > 0) {
        throw InputError(csv_path + ": setting " + std::to_string(s.setting.index) + " does not belong to shard " +
                         std::to_string(index) + "/" + std::to_string(count) + " or is there twice");
      }
      by_index[s.setting.index] = s;
    }
  }
  for (int k = 1; k <= count; ++k) {
    if (shard_dir[static_cast<size_t>(k)].empty()) {
      throw InputError("observability merge: shard " + std::to_string(k) + "/" + std::to_string(count) +
                       " is missing");
    }
  }
  const int settings = reference.value("settings", 0);
  for (int i = 0; i < settings; ++i) {
    const auto it = by_index.find(i);
    if (it == by_index.end()) {
      throw InputError(shard_dir[static_cast<size_t>(i % count + 1)] + "/settings.csv: setting " +
                       std::to_string(i) + " is missing (a shard that did not finish?)");
    }
    merged.stats.push_back(it->second);
  }
  if (by_index.size() != static_cast<size_t>(settings)) {
    throw InputError(reference_dir + ": the shards hold settings beyond the study's " + std::to_string(settings));
  }
  Json whole = reference;
  whole["shard"] = {{"index", 1}, {"count", 1}};
  merged.study_json_text = whole.dump(1) + "\n";
  merged.requirement_deg = reference.value("requirement_deg", 2.0);
  return merged;
}

std::string WriteStudyPlots(const std::string& dir, const std::string& python) {
  const std::filesystem::path figures = std::filesystem::path(dir) / "figures";
  return util::RunPlotScript(python, "observability", "observability_plots.py", ObservabilityPlotsScript(),
                             {std::filesystem::absolute(dir).string(), std::filesystem::absolute(figures).string()},
                             300.0, figures.string());
}

}  // namespace hdabench::reference
