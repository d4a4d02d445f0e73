#include "datasets/synth/imagery_check.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "calib/rigid3.h"
#include "datasets/synth/optics.h"
#include "datasets/synth/raycast.h"
#include "datasets/synth/scene.h"
#include "datasets/synth/truth.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/statistics.h"

namespace hdabench::datasets::synth {

namespace {

using util::kPi;

void RequirePair(const Dataset& dataset, int frame1, int frame2, bool images) {
  const int frames = static_cast<int>(dataset.frames.size());
  if (frame1 < 0 || frame1 >= frames || frame2 < 0 || frame2 >= frames || frame1 == frame2) {
    throw InputError("frames " + std::to_string(frame1) + "," + std::to_string(frame2) +
                     ": expected two different frames of 0.." + std::to_string(frames - 1));
  }
  if (dataset.truth.navigation.empty()) {
    throw InputError("dataset '" + dataset.name + "' has no truth navigation (truth.navigation)");
  }
  if (images && (dataset.frames[static_cast<size_t>(frame1)].image.empty() ||
                 dataset.frames[static_cast<size_t>(frame2)].image.empty())) {
    throw InputError("the images of frames " + std::to_string(frame1) + "," + std::to_string(frame2) +
                     " are not in memory");
  }
}

double Pixel(const cv::Mat& image, int row, int col) {
  return image.depth() == CV_16U ? static_cast<double>(image.at<std::uint16_t>(row, col))
                                 : static_cast<double>(image.at<std::uint8_t>(row, col));
}

bool PointAt(const cv::Mat& points, int row, int col, Eigen::Vector3d* point) {
  if (row < 0 || col < 0 || row >= points.rows || col >= points.cols) return false;
  const cv::Vec3f& p = points.at<cv::Vec3f>(row, col);
  if (!std::isfinite(p[0])) return false;
  *point = Eigen::Vector3d(p[0], p[1], p[2]);
  return true;
}

// The distance between the truth points of neighbouring pixels at (row, col)
// (the larger of the two axes); false without neighbours.
bool FootprintAt(const cv::Mat& points, int row, int col, double* footprint_m) {
  Eigen::Vector3d p, right, down;
  if (!PointAt(points, row, col, &p)) return false;
  const bool has_right = PointAt(points, row, col + 1, &right) || PointAt(points, row, col - 1, &right);
  const bool has_down = PointAt(points, row + 1, col, &down) || PointAt(points, row - 1, col, &down);
  if (!has_right || !has_down) return false;
  *footprint_m = std::max((right - p).norm(), (down - p).norm());
  return true;
}

// Least-squares y = gain * x + offset and the RMS of what is left.
struct LineFit {
  double gain = 0.0;
  double offset = 0.0;
  double rms = 0.0;
};
LineFit FitLine(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  double mx = 0.0, my = 0.0;
  for (size_t i = 0; i < x.size(); ++i) {
    mx += x[i];
    my += y[i];
  }
  mx /= n;
  my /= n;
  double sxx = 0.0, sxy = 0.0;
  for (size_t i = 0; i < x.size(); ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  LineFit fit;
  fit.gain = sxx > 0.0 ? sxy / sxx : 0.0;
  fit.offset = my - fit.gain * mx;
  double sum = 0.0;
  for (size_t i = 0; i < x.size(); ++i) {
    const double r = y[i] - (fit.gain * x[i] + fit.offset);
    sum += r * r;
  }
  fit.rms = std::sqrt(sum / n);
  return fit;
}

double NoiseVarianceDn(const TruthImaging& imaging, double dn) {
  const double shot = imaging.gain_electrons_per_dn > 0.0 ? std::max(dn, 0.0) / imaging.gain_electrons_per_dn : 0.0;
  return shot + imaging.read_noise_dn * imaging.read_noise_dn + 1.0 / 12.0;
}

double RobustSigma(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const double median = util::Quantile(values, 0.5);
  for (double& v : values) v = std::abs(v - median);
  std::sort(values.begin(), values.end());
  return 1.4826 * util::Quantile(values, 0.5);
}

}  // namespace

std::vector<PhotometricRoi> PhotometricResidual(const Dataset& dataset, int frame1, int frame2,
                                                const std::vector<std::pair<int, cv::Rect>>& boxes) {
  RequirePair(dataset, frame1, frame2, true);
  if (!dataset.truth.imaging.has_value()) {
    throw InputError("dataset '" + dataset.name + "' has no truth.imaging (sun and sensor noise): only "
                     "synthetic datasets made since it was recorded can be checked");
  }
  const TruthImaging& imaging = *dataset.truth.imaging;
  const cv::Mat& points1 = TruthPointsOf(dataset, frame1);
  const cv::Mat& points2 = TruthPointsOf(dataset, frame2);
  const cv::Mat& image1 = dataset.frames[static_cast<size_t>(frame1)].image;
  const cv::Mat& image2 = dataset.frames[static_cast<size_t>(frame2)].image;
  const Rigid3d cam2_from_local = dataset.TrueCamFromLocal(frame2);
  const Eigen::Vector3d centre1 = dataset.TrueCamFromLocal(frame1).Inverse().translation;
  const Eigen::Vector3d centre2 = cam2_from_local.Inverse().translation;
  const Eigen::Vector3d sun = imaging.sun_in_local.normalized();

  std::vector<PhotometricRoi> results;
  for (const auto& [id, box_in] : boxes) {
    PhotometricRoi roi;
    roi.id = id;
    roi.box = box_in & cv::Rect(0, 0, image1.cols, image1.rows);
    // The box's pixels with a truth point and a normal, into image 2.
    std::vector<Eigen::Vector3d> in_cam2;
    std::vector<cv::Point> pixels1;
    std::vector<Eigen::Vector3d> normals;
    for (int row = roi.box.y; row < roi.box.y + roi.box.height; ++row) {
      for (int col = roi.box.x; col < roi.box.x + roi.box.width; ++col) {
        Eigen::Vector3d p, left, right, up, down;
        if (!PointAt(points1, row, col, &p) || !PointAt(points1, row, col - 1, &left) ||
            !PointAt(points1, row, col + 1, &right) || !PointAt(points1, row - 1, col, &up) ||
            !PointAt(points1, row + 1, col, &down)) {
          continue;
        }
        Eigen::Vector3d normal = (right - left).cross(down - up);
        if (!(normal.norm() > 0.0)) continue;
        normal.normalize();
        if (normal.z() < 0.0) normal = -normal;
        pixels1.emplace_back(col, row);
        normals.push_back(normal);
        in_cam2.push_back(cam2_from_local * p);
      }
    }
    std::vector<Eigen::Vector2d> projected;
    std::vector<unsigned char> valid;
    dataset.camera.Project(in_cam2, &projected, &valid);
    std::vector<double> values1, values2, modelled, noise_variance;
    for (size_t k = 0; k < pixels1.size(); ++k) {
      const Eigen::Vector2d& q = projected[k];
      if (!valid[k] || !(q.x() >= 0.0 && q.y() >= 0.0 && q.x() < image2.cols - 1 && q.y() < image2.rows - 1)) {
        ++roi.hidden;
        continue;
      }
      const int row2 = static_cast<int>(std::lround(q.y()));
      const int col2 = static_cast<int>(std::lround(q.x()));
      Eigen::Vector3d p1, p2;
      double footprint_m = 0.0;
      PointAt(points1, pixels1[k].y, pixels1[k].x, &p1);
      if (!PointAt(points2, row2, col2, &p2) || !FootprintAt(points2, row2, col2, &footprint_m) ||
          (p2 - p1).norm() > 2.0 * footprint_m) {
        ++roi.hidden;
        continue;
      }
      const int c0 = static_cast<int>(std::floor(q.x()));
      const int r0 = static_cast<int>(std::floor(q.y()));
      const double fx = q.x() - c0;
      const double fy = q.y() - r0;
      const double w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
      const double v[4] = {Pixel(image2, r0, c0), Pixel(image2, r0, c0 + 1), Pixel(image2, r0 + 1, c0),
                           Pixel(image2, r0 + 1, c0 + 1)};
      double sample = 0.0, variance2 = 0.0;
      for (int i = 0; i < 4; ++i) {
        sample += w[i] * v[i];
        variance2 += w[i] * w[i] * NoiseVarianceDn(imaging, v[i]);
      }
      const double value1 = Pixel(image1, pixels1[k].y, pixels1[k].x);
      // The photometric model from each camera (albedo cancels in the ratio).
      const Eigen::Vector3d& n = normals[k];
      const Eigen::Vector3d view1 = (centre1 - p1).normalized();
      const Eigen::Vector3d view2 = (centre2 - p1).normalized();
      const double r1 = LunarLambertReflectance(1.0, n.dot(sun), n.dot(view1), std::acos(std::clamp(sun.dot(view1), -1.0, 1.0)));
      const double r2 = LunarLambertReflectance(1.0, n.dot(sun), n.dot(view2), std::acos(std::clamp(sun.dot(view2), -1.0, 1.0)));
      values1.push_back(value1);
      values2.push_back(sample);
      modelled.push_back(r1 > 0.0 ? value1 * r2 / r1 : value1);
      noise_variance.push_back(variance2);  // the image-1 part needs the gain: below
    }
    roi.pixels = static_cast<int>(values1.size());
    if (roi.pixels < 20) {
      roi.why = "only " + std::to_string(roi.pixels) + " pixels seen in both frames";
      results.push_back(roi);
      continue;
    }
    const LineFit fit = FitLine(values1, values2);
    const LineFit model_fit = FitLine(values1, modelled);
    double noise_sum = 0.0, mean1 = 0.0, spread = 0.0;
    for (size_t k = 0; k < values1.size(); ++k) {
      noise_sum += noise_variance[k] + fit.gain * fit.gain * NoiseVarianceDn(imaging, values1[k]);
      mean1 += values1[k];
    }
    mean1 /= static_cast<double>(values1.size());
    for (const double v : values1) spread += (v - mean1) * (v - mean1);
    roi.spread_dn = std::sqrt(spread / static_cast<double>(values1.size()));
    roi.gain = fit.gain;
    roi.offset_dn = fit.offset;
    roi.residual_rms_dn = fit.rms;
    roi.noise_rms_dn = std::sqrt(noise_sum / static_cast<double>(values1.size()));
    roi.view_rms_dn = model_fit.rms;
    roi.explained_rms_dn = std::hypot(roi.noise_rms_dn, roi.view_rms_dn);
    roi.ratio = roi.residual_rms_dn / roi.explained_rms_dn;
    results.push_back(roi);
  }
  return results;
}

MatchErrors MatchErrorsAgainstTruth(const Dataset& dataset, int frame1, int frame2,
                                    const std::vector<Eigen::Vector2d>& points1_px,
                                    const std::vector<Eigen::Vector2d>& points2_px) {
  RequirePair(dataset, frame1, frame2, false);
  if (points1_px.size() != points2_px.size()) throw InputError("matches: image-1 and image-2 lists differ in length");
  const cv::Mat& points1 = TruthPointsOf(dataset, frame1);
  const Rigid3d cam2_from_local = dataset.TrueCamFromLocal(frame2);
  MatchErrors result;
  result.matches = static_cast<int>(points1_px.size());
  std::vector<Eigen::Vector3d> in_cam2;
  std::vector<size_t> which;
  for (size_t k = 0; k < points1_px.size(); ++k) {
    const Eigen::Vector2d& p = points1_px[k];
    const int c = static_cast<int>(std::floor(p.x()));
    const int r = static_cast<int>(std::floor(p.y()));
    Eigen::Vector3d p00, p01, p10, p11;
    if (!PointAt(points1, r, c, &p00) || !PointAt(points1, r, c + 1, &p01) || !PointAt(points1, r + 1, c, &p10) ||
        !PointAt(points1, r + 1, c + 1, &p11)) {
      continue;
    }
    const double edges[4] = {(p01 - p00).norm(), (p10 - p00).norm(), (p11 - p01).norm(), (p11 - p10).norm()};
    if (*std::max_element(edges, edges + 4) > 3.0 * *std::min_element(edges, edges + 4)) continue;  // a depth edge
    const double fx = p.x() - c;
    const double fy = p.y() - r;
    const Eigen::Vector3d truth = (1 - fy) * ((1 - fx) * p00 + fx * p01) + fy * ((1 - fx) * p10 + fx * p11);
    in_cam2.push_back(cam2_from_local * truth);
    which.push_back(k);
  }
  std::vector<Eigen::Vector2d> projected;
  std::vector<unsigned char> valid;
  dataset.camera.Project(in_cam2, &projected, &valid);
  std::vector<double> ex, ey;
  for (size_t i = 0; i < which.size(); ++i) {
    if (!valid[i]) continue;
    const Eigen::Vector2d error = points2_px[which[i]] - projected[i];
    result.errors_px.push_back(error);
    ex.push_back(error.x());
    ey.push_back(error.y());
  }
  result.compared = static_cast<int>(result.errors_px.size());
  result.robust_sigma_x_px = RobustSigma(ex);
  result.robust_sigma_y_px = RobustSigma(ey);
  return result;
}

namespace {

// A flat plane at height 0, DEM nodes every 0.5 m over +-20 m, uniform albedo 0.12.
Scene FlatScene() {
  Scene scene;
  scene.dem.width = 81;
  scene.dem.height = 81;
  scene.dem.spacing_m = 0.5;
  scene.dem.origin_x_m = -20.0;
  scene.dem.origin_y_m = 20.0;
  scene.dem.height_m.assign(81 * 81, 0.0f);
  scene.albedo.mean = 0.12;
  scene.albedo.relative_variation = 0.0;
  return scene;
}

// The 10-90 % rise distance of a rising profile sampled at `distances`.
double RiseWidth(const std::vector<double>& distances, const std::vector<double>& values) {
  const auto crossing = [&](double level) {
    for (size_t i = 1; i < values.size(); ++i) {
      if (values[i - 1] < level && values[i] >= level) {
        const double t = (level - values[i - 1]) / (values[i] - values[i - 1]);
        return distances[i - 1] + t * (distances[i] - distances[i - 1]);
      }
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  return crossing(0.9) - crossing(0.1);
}

}  // namespace

EdgeSpreadCheck CheckEdgeSpread(const RenderOptions& options_in) {
  const double slant_rad = 5.0 * kPi / 180.0;
  const double focal_px = 1000.0;
  const double height_m = 100.0;
  const int size_px = 96;
  const calib::CameraModel camera("LENSMODEL_PINHOLE",
                                  {focal_px, focal_px, (size_px - 1) / 2.0, (size_px - 1) / 2.0}, size_px, size_px);
  // Nadir: cam x = east, cam y = south, cam z = down.
  const Eigen::Quaterniond rotation(0.0, 1.0, 0.0, 0.0);
  const Rigid3d cam_from_local(rotation, -(rotation * Eigen::Vector3d(0.0, 0.0, height_m)));
  RenderOptions options = options_in;
  options.shot_noise = false;
  options.read_noise_dn = 0.0;
  options.bit_depth = 16;
  options.sun_elevation_deg = 60.0;
  options.dn_per_reflectance = 250000.0;
  options.gain_electrons_per_dn = 0.1;  // the full well (10000 e-) at 100000 DN: no clipping
  options.ambient_reflectance = 0.0;
  Scene scene = FlatScene();
  const SceneRaycaster uniform_raycaster(scene);
  const RenderedFrame uniform = RenderFrame(uniform_raycaster, scene, camera, cam_from_local, options, 1);
  scene.albedo.edge = true;
  scene.albedo.relative_variation = 0.5;
  scene.albedo.edge_normal = Eigen::Vector2d(std::cos(slant_rad), std::sin(slant_rad));
  const SceneRaycaster edge_raycaster(scene);
  const RenderedFrame edge = RenderFrame(edge_raycaster, scene, camera, cam_from_local, options, 1);

  // Expected: P(u cos + v sin < d) for u, v drawn from the 1-D response.
  const PixelResponse1d response{std::sqrt(options.fill_factor), options.PsfSigmaPx()};
  const auto expected = [&](double d_px) {
    double sum = 0.0;
    const double step = 0.002;
    for (double v = -5.0; v <= 5.0; v += step) {
      sum += response.CellWeight(v, step) * response.EdgeSpread((d_px - v * std::sin(slant_rad)) / std::cos(slant_rad));
    }
    return sum;
  };
  const int bins = 61;
  std::vector<double> sum(bins, 0.0);
  std::vector<int> count(bins, 0);
  const double metres_per_px = height_m / focal_px;
  for (int r = 8; r < size_px - 8; ++r) {
    for (int c = 8; c < size_px - 8; ++c) {
      const cv::Vec3f& p = edge.points_in_local_m.at<cv::Vec3f>(r, c);
      const double d_px = scene.albedo.edge_normal.dot(Eigen::Vector2d(p[0], p[1])) / metres_per_px;
      const long bin = std::lround(d_px * 10.0) + bins / 2;
      if (bin < 0 || bin >= bins) continue;
      const double ratio = static_cast<double>(edge.image.at<std::uint16_t>(r, c)) /
                           static_cast<double>(uniform.image.at<std::uint16_t>(r, c));
      sum[static_cast<size_t>(bin)] += ratio - 0.5;  // albedo 1 -+ 0.5 of the mean: 0 .. 1
      ++count[static_cast<size_t>(bin)];
    }
  }
  EdgeSpreadCheck check;
  std::vector<double> distances, measured, wanted;
  for (int bin = 0; bin < bins; ++bin) {
    if (count[static_cast<size_t>(bin)] < 5) continue;
    EdgeSpreadBin b;
    b.distance_px = (bin - bins / 2) / 10.0;
    b.pixels = count[static_cast<size_t>(bin)];
    b.measured = sum[static_cast<size_t>(bin)] / b.pixels;
    b.expected = expected(b.distance_px);
    check.max_error = std::max(check.max_error, std::abs(b.measured - b.expected));
    check.bins.push_back(b);
    distances.push_back(b.distance_px);
    measured.push_back(b.measured);
    wanted.push_back(b.expected);
  }
  check.width_10_90_px = RiseWidth(distances, measured);
  check.expected_width_10_90_px = RiseWidth(distances, wanted);
  return check;
}

}  // namespace hdabench::datasets::synth
