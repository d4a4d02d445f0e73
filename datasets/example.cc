#include "datasets/example.h"

#include "tools/util/options_check.h"

#include "datasets/synth/noise.h"
#include "tools/util/angles.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace hdabench::datasets {

namespace {

using util::DegToRad;
using util::kPi;

// Regolith-like albedo in [0, 1] at ground point (x, y): equally weighted
// octaves of value noise from 96 m down to 3 m wavelength, so that there is
// texture at every scale a feature detector looks at.
class AlbedoTexture {
 public:
  explicit AlbedoTexture(std::uint64_t seed) : seed_(seed) {}

  double operator()(double x_m, double y_m) const {
    // Equal weights (hurst 0); the fractal sum lies in [-1, 1] and clusters
    // around 0, so stretch it.
    const double sum = synth::FractalNoise(seed_, x_m, y_m, 3.0, 96.0, 0.0);
    return std::clamp(0.5 + 1.25 * sum, 0.0, 1.0);
  }

 private:
  std::uint64_t seed_;
};

// Where a ray from `origin` along `direction` meets the plane z = 0, if ahead.
bool HitGround(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
               Eigen::Vector3d* hit) {
  if (!(direction.z() < -1e-12) || !(origin.z() > 0.0)) return false;
  const double s = -origin.z() / direction.z();
  *hit = origin + s * direction;
  return true;
}

// prefix + index zero-padded to 6 digits + suffix.
std::string Numbered(const std::string& prefix, int index, const std::string& suffix) {
  std::string digits = std::to_string(index);
  if (digits.size() < 6) digits.insert(0, 6 - digits.size(), '0');
  return prefix + digits + suffix;
}

// The example's camera: a square imager of image_size_px with the requested
// horizontal field of view. Mild OPENCV8 distortion (k1, k2): about 2 px of
// barrel at the corners of 256 px.
calib::CameraModel MakeExampleCamera(const ExampleDatasetOptions& options) {
  const int size = options.image_size_px;
  const double focal_px = 0.5 * size / std::tan(0.5 * DegToRad(options.horizontal_fov_deg));
  const double center_px = 0.5 * (size - 1);
  return calib::CameraModel("LENSMODEL_OPENCV8",
                            {focal_px, focal_px, center_px, center_px, -0.05, 0.01, 0.0, 0.0, 0.0,
                             0.0, 0.0, 0.0},
                            size, size);
}

// Sets the camera mount, gravity, ILS and LRF origin. Returns the rotation of
// body_from_cam, whose third column (the optical axis) is the LRF boresight.
Eigen::Matrix3d SetExampleMount(const ExampleDatasetOptions& options, Dataset* dataset) {
  // Mount: optical axis theta off nadir, tilted toward body x (forward);
  // image x along body y (right). Columns of body_from_cam: cam x, y, z in body.
  const double theta = DegToRad(options.off_nadir_deg);
  Eigen::Matrix3d body_from_cam_rotation;
  body_from_cam_rotation.col(0) = Eigen::Vector3d(0.0, 1.0, 0.0);
  body_from_cam_rotation.col(1) = Eigen::Vector3d(-std::cos(theta), 0.0, std::sin(theta));
  body_from_cam_rotation.col(2) = Eigen::Vector3d(std::sin(theta), 0.0, std::cos(theta));
  const Eigen::Vector3d camera_center_in_body(0.5, 0.0, 0.3);
  const Eigen::Quaterniond cam_from_body_rotation =
      Eigen::Quaterniond(body_from_cam_rotation.transpose()).normalized();
  // (+ zero turns a -0 into 0, for tidier files.)
  dataset->cam_from_body = Rigid3d(
      cam_from_body_rotation,
      -(cam_from_body_rotation * camera_center_in_body) + Eigen::Vector3d::Zero());
  dataset->gravity_in_local_mps2 = Eigen::Vector3d(0.0, 0.0, -1.62);
  dataset->ils_in_local_m = Eigen::Vector3d::Zero();
  dataset->lrf_origin_in_body_m = Eigen::Vector3d(0.4, 0.1, 0.3);
  return body_from_cam_rotation;
}

// Trajectory: constant velocity east, centred on x = 0 at mid-collection, with
// a level attitude that wobbles by a fraction of a degree.
struct Trajectory {
  double first_frame_s = 0.0;  // time of frame 0
  double end_s = 0.0;          // end of the navigation and LRF records
  double mid_s = 0.0;          // mid-collection, when the body passes x = 0
  Eigen::Vector3d velocity;
  Eigen::Vector3d position_at_mid;
  Eigen::Quaterniond level_rotation;
  double wobble_rad = 0.0;

  Rigid3d LocalFromBodyAt(double t) const {
    const Eigen::Vector3d w(wobble_rad * std::sin(2.0 * kPi * 0.3 * t),
                            wobble_rad * std::sin(2.0 * kPi * 0.5 * t + 1.0),
                            wobble_rad * std::sin(2.0 * kPi * 0.4 * t + 2.0));
    const Eigen::Quaterniond wobble(Eigen::AngleAxisd(w.norm(), w.normalized()));
    return Rigid3d((level_rotation * wobble).normalized(),
                   position_at_mid + (t - mid_s) * velocity);
  }
};

Trajectory MakeTrajectory(const ExampleDatasetOptions& options) {
  Trajectory trajectory;
  trajectory.first_frame_s = options.margin_s;
  trajectory.end_s = options.duration_s + 2.0 * options.margin_s;
  trajectory.mid_s = trajectory.first_frame_s + 0.5 * options.duration_s;
  trajectory.velocity = Eigen::Vector3d(options.speed_mps, 0.0, 0.0);
  trajectory.position_at_mid = Eigen::Vector3d(0.0, -options.downrange_m, options.altitude_m);
  // Level attitude: body x north, y east, z down.
  Eigen::Matrix3d level;
  level.col(0) = Eigen::Vector3d(0.0, 1.0, 0.0);
  level.col(1) = Eigen::Vector3d(1.0, 0.0, 0.0);
  level.col(2) = Eigen::Vector3d(0.0, 0.0, -1.0);
  trajectory.level_rotation = Eigen::Quaterniond(level);
  trajectory.wobble_rad = DegToRad(0.2);
  return trajectory;
}

// Navigation samples at nav_rate_hz over the whole record, with the velocity
// and constant sigmas.
void AddNavigation(const ExampleDatasetOptions& options, const Trajectory& trajectory,
                   Dataset* dataset) {
  const int num_nav =
      static_cast<int>(std::floor(trajectory.end_s * options.nav_rate_hz + 1e-9)) + 1;
  for (int i = 0; i < num_nav; ++i) {
    NavSample sample;
    sample.time_s = i / options.nav_rate_hz;
    sample.local_from_body = trajectory.LocalFromBodyAt(sample.time_s);
    sample.velocity_in_local_mps = trajectory.velocity;
    sample.sigma_position_in_local_m = Eigen::Vector3d(0.5, 0.5, 1.0);
    sample.sigma_attitude_in_body_rad = Eigen::Vector3d(1e-3, 1e-3, 2e-3);
    dataset->nav.push_back(sample);
  }
  dataset->nav_has_velocity = true;
  dataset->nav_has_sigmas = true;
}

// LRF samples at lrf_rate_hz along the optical axis, each the range to the
// ground from the interpolated pose; none after the last navigation sample.
void AddLrf(const ExampleDatasetOptions& options, double end_s,
            const Eigen::Vector3d& boresight_in_body, Dataset* dataset) {
  const double nav_end_s = dataset->nav.back().time_s;
  const int num_lrf = static_cast<int>(std::floor(end_s * options.lrf_rate_hz + 1e-9)) + 1;
  for (int i = 0; i < num_lrf; ++i) {
    LrfSample sample;
    sample.time_s = std::min(i / options.lrf_rate_hz, nav_end_s);
    if (!dataset->lrf.empty() && !(sample.time_s > dataset->lrf.back().time_s)) break;
    const Rigid3d local_from_body = dataset->LocalFromBodyAt(sample.time_s);
    const Eigen::Vector3d origin = local_from_body * dataset->lrf_origin_in_body_m;
    const Eigen::Vector3d direction = local_from_body.rotation * boresight_in_body;
    Eigen::Vector3d hit;
    if (!HitGround(origin, direction, &hit)) {
      throw std::invalid_argument("ExampleDatasetOptions: the LRF beam misses the ground");
    }
    sample.range_m = (hit - origin).norm();
    sample.boresight_in_body = boresight_in_body;
    dataset->lrf.push_back(sample);
  }
}

// The frame records (no image yet), evenly spaced over duration_s.
void AddFrames(const ExampleDatasetOptions& options, double first_frame_s, Dataset* dataset) {
  const double frame_step_s = options.duration_s / (options.num_frames - 1);
  for (int k = 0; k < options.num_frames; ++k) {
    FrameRecord frame;
    frame.index = k;
    frame.time_s = first_frame_s + k * frame_step_s;
    frame.image_path = Numbered("images/frame_", k, ".png");
    dataset->frames.push_back(frame);
  }
}

// The camera's rays in the camera frame, the same for every frame.
struct PixelRays {
  int size = 0;                                    // square imager, pixels
  std::vector<Eigen::Vector3d> centre_bearings;    // one per pixel, row by row
  std::vector<Eigen::Vector3d> subpixel_bearings;  // the 2 x 2 anti-aliasing rays of each pixel
};

// Bearings of the pixel centres, unprojected once (the camera is the same for
// every frame; libmrcal's unprojection is iterative, hence the saving).
std::vector<Eigen::Vector3d> CentreBearings(const calib::CameraModel& camera, int size) {
  std::vector<Eigen::Vector2d> centres;
  centres.reserve(static_cast<size_t>(size) * size);
  for (int row = 0; row < size; ++row) {
    for (int col = 0; col < size; ++col) centres.emplace_back(col, row);
  }
  std::vector<Eigen::Vector3d> centre_bearings;
  std::vector<unsigned char> centre_valid;
  camera.Unproject(centres, &centre_bearings, &centre_valid);
  for (const unsigned char valid : centre_valid) {
    if (valid == 0) throw std::invalid_argument("ExampleDatasetOptions: a pixel does not unproject");
  }
  return centre_bearings;
}

// The 2 x 2 anti-aliasing rays of a pixel sit a quarter pixel off its centre;
// their bearings are interpolated from the neighbouring centres (the error,
// second order in the distortion, is far below a pixel's footprint).
std::vector<Eigen::Vector3d> SubpixelBearings(const std::vector<Eigen::Vector3d>& centre_bearings,
                                              int size) {
  auto bearing = [&](int col, int row) -> const Eigen::Vector3d& {
    return centre_bearings[static_cast<size_t>(row) * size + col];
  };
  // Neighbour index on the side of offset d, and its weight; at the border the
  // neighbour on the other side, with a negative weight (extrapolation).
  auto neighbour = [size](int i, double d, int* other, double* weight) {
    const int step = d > 0 ? 1 : -1;
    const bool inside = i + step >= 0 && i + step < size;
    *other = inside ? i + step : i - step;
    *weight = inside ? std::abs(d) : -std::abs(d);
  };
  auto subpixel_bearing = [&](int col, int row, double dx, double dy) {
    int col2 = 0;
    int row2 = 0;
    double u = 0.0;
    double v = 0.0;
    neighbour(col, dx, &col2, &u);
    neighbour(row, dy, &row2, &v);
    const Eigen::Vector3d b = (1 - u) * (1 - v) * bearing(col, row) +
                              u * (1 - v) * bearing(col2, row) + (1 - u) * v * bearing(col, row2) +
                              u * v * bearing(col2, row2);
    return Eigen::Vector3d(b.normalized());
  };
  std::vector<Eigen::Vector3d> subpixel_bearings;
  subpixel_bearings.reserve(static_cast<size_t>(size) * size * 4);
  for (int row = 0; row < size; ++row) {
    for (int col = 0; col < size; ++col) {
      for (int s = 0; s < 4; ++s) {
        subpixel_bearings.push_back(subpixel_bearing(col, row, (s & 1) != 0 ? 0.25 : -0.25,
                                                     (s & 2) != 0 ? 0.25 : -0.25));
      }
    }
  }
  return subpixel_bearings;
}

// The x-y extent of the ground points seen so far (empty: +inf .. -inf).
struct GroundExtent {
  Eigen::Vector2d min_xy;
  Eigen::Vector2d max_xy;
};

// Renders frame k: its image (the mean albedo under the 2 x 2 rays of each
// pixel) and its truth points (where each pixel centre's ray meets the ground,
// NaN where it misses), and grows `extent` by those points.
void RenderFrame(int k, const PixelRays& rays, const AlbedoTexture& albedo, Dataset* dataset,
                 GroundExtent* extent) {
  const int size = rays.size;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Rigid3d local_from_cam = dataset->CamFromLocal(k).Inverse();
  const Eigen::Matrix3d rotation = local_from_cam.RotationMatrix();
  const Eigen::Vector3d& center = local_from_cam.translation;

  cv::Mat image(size, size, CV_8UC1);
  cv::Mat points(size, size, CV_32FC3);
  for (int row = 0; row < size; ++row) {
    for (int col = 0; col < size; ++col) {
      const size_t p = static_cast<size_t>(row) * size + col;
      double sum = 0.0;
      for (size_t s = 4 * p; s < 4 * p + 4; ++s) {
        Eigen::Vector3d hit;
        if (HitGround(center, rotation * rays.subpixel_bearings[s], &hit)) {
          sum += albedo(hit.x(), hit.y());
        }
      }
      image.at<unsigned char>(row, col) =
          static_cast<unsigned char>(std::lround(std::clamp(255.0 * sum / 4.0, 0.0, 255.0)));
      cv::Vec3f& point = points.at<cv::Vec3f>(row, col);
      Eigen::Vector3d hit;
      if (HitGround(center, rotation * rays.centre_bearings[p], &hit)) {
        point = cv::Vec3f(static_cast<float>(hit.x()), static_cast<float>(hit.y()),
                          static_cast<float>(hit.z()));
        extent->min_xy = extent->min_xy.cwiseMin(hit.head<2>());
        extent->max_xy = extent->max_xy.cwiseMax(hit.head<2>());
      } else {
        point = cv::Vec3f(nan, nan, nan);
      }
    }
  }
  dataset->frames[static_cast<size_t>(k)].image = image;
  TruthPoints truth;
  truth.frame = k;
  truth.file = Numbered("truth/points_", k, ".npy");
  truth.points_in_local_m = points;
  dataset->truth.points.push_back(truth);
}

// Flat DEM (z = 0) on a 4 m grid covering every truth point, north-up; none
// when no pixel sees the ground.
void AddFlatDem(const GroundExtent& extent, Dataset* dataset) {
  const Eigen::Vector2d& min_xy = extent.min_xy;
  const Eigen::Vector2d& max_xy = extent.max_xy;
  if (!std::isfinite(min_xy.x())) return;
  TruthDem dem;
  dem.file = "truth/dem.npy";
  dem.spacing_m = 4.0;
  const double west = std::floor(min_xy.x() / dem.spacing_m) * dem.spacing_m;
  const double north = std::ceil(max_xy.y() / dem.spacing_m) * dem.spacing_m;
  dem.origin_in_local_m = Eigen::Vector2d(west, north);
  dem.width_cells = static_cast<int>(std::ceil((max_xy.x() - west) / dem.spacing_m)) + 1;
  dem.height_cells = static_cast<int>(std::ceil((north - min_xy.y()) / dem.spacing_m)) + 1;
  dem.height_in_local_m = cv::Mat::zeros(dem.height_cells, dem.width_cells, CV_32FC1);
  dataset->truth.dem = dem;
}

}  // namespace

std::vector<std::string> ExampleDatasetOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(image_size_px >= 16 && image_size_px <= 4096, "image_size_px", image_size_px, "in [16, 4096]",
                &errors);
  RequireOption(horizontal_fov_deg > 1.0 && horizontal_fov_deg < 120.0, "horizontal_fov_deg", horizontal_fov_deg,
                "in (1, 120)", &errors);
  RequireOption(num_frames >= 2 && num_frames <= 1000, "num_frames", num_frames, "in [2, 1000]", &errors);
  RequireOption(duration_s > 0.0 && duration_s < 1000.0, "duration_s", duration_s, "in (0, 1000)", &errors);
  RequireOption(std::abs(speed_mps) < 1e4, "speed_mps", speed_mps, "in (-1e4, 1e4)", &errors);
  RequireOption(altitude_m > 1.0 && altitude_m < 1e5, "altitude_m", altitude_m, "in (1, 1e5)", &errors);
  RequireOption(std::abs(downrange_m) < 1e5, "downrange_m", downrange_m, "in (-1e5, 1e5)", &errors);
  RequireOption(off_nadir_deg >= 0.0 && off_nadir_deg < 80.0, "off_nadir_deg", off_nadir_deg, "in [0, 80)",
                &errors);
  RequireOption(nav_rate_hz >= 1.0 && nav_rate_hz <= 1000.0, "nav_rate_hz", nav_rate_hz, "in [1, 1000]", &errors);
  RequireOption(lrf_rate_hz >= 1.0 && lrf_rate_hz <= 1000.0, "lrf_rate_hz", lrf_rate_hz, "in [1, 1000]", &errors);
  RequireOption(margin_s > 0.0 && margin_s < 100.0, "margin_s", margin_s, "in (0, 100)", &errors);
  return errors;
}

Dataset MakeExampleDataset(std::uint64_t seed) {
  ExampleDatasetOptions options;
  options.seed = seed;
  return MakeExampleDataset(options);
}

Dataset MakeExampleDataset(const ExampleDatasetOptions& options) {
  ThrowIfInvalid("invalid ExampleDatasetOptions: ", options.Validate());
  const calib::CameraModel camera = MakeExampleCamera(options);
  Dataset dataset(camera);
  dataset.name = "example-lateral-seed" + std::to_string(options.seed);
  dataset.description =
      "hdabench built-in example: lateral pass at constant altitude, camera off nadir toward the "
      "ILS, flat ground with procedural albedo (seed " +
      std::to_string(options.seed) + ").";
  const Eigen::Matrix3d body_from_cam_rotation = SetExampleMount(options, &dataset);

  const Trajectory trajectory = MakeTrajectory(options);
  AddNavigation(options, trajectory, &dataset);
  // LRF along the optical axis.
  AddLrf(options, trajectory.end_s, body_from_cam_rotation.col(2), &dataset);
  AddFrames(options, trajectory.first_frame_s, &dataset);

  const int size = options.image_size_px;
  PixelRays rays;
  rays.size = size;
  rays.centre_bearings = CentreBearings(camera, size);
  rays.subpixel_bearings = SubpixelBearings(rays.centre_bearings, size);
  const AlbedoTexture albedo(options.seed);

  GroundExtent extent;
  extent.min_xy = Eigen::Vector2d(std::numeric_limits<double>::infinity(),
                                  std::numeric_limits<double>::infinity());
  extent.max_xy = -extent.min_xy;
  for (int k = 0; k < options.num_frames; ++k) RenderFrame(k, rays, albedo, &dataset, &extent);

  AddFlatDem(extent, &dataset);
  return dataset;
}

}  // namespace hdabench::datasets
