#include "datasets/synth/chessboard.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "datasets/internal/csv.h"
#include "tools/util/files.h"
#include "datasets/internal/png.h"
#include "tools/util/text.h"
#include "datasets/synth/noise.h"
#include "tools/util/angles.h"
#include "tools/util/parallel_for.h"

namespace hdabench::datasets::synth {

namespace {

using util::kPi;
using util::kDegToRad;

namespace fs = std::filesystem;

// Sample bearings: libmrcal unprojects a lattice of knots this far apart
// (pixels); samples start from the bilinear blend of the four knots around
// them, within ~0.03 px under strong distortion (k1 = -0.3), and converge in
// two or three steps. kMaxNewtonSteps leaves room for rougher lenses before a
// sample goes to libmrcal's unprojection.
constexpr double kKnotSpacingPx = 8.0;
constexpr int kMaxNewtonSteps = 8;
// A sample's bearing is accepted when it projects this close to the sample:
// far below anything a corner detector can see, and well above the rounding
// of libmrcal's projection (~1e-13 px).
constexpr double kBearingTolerancePx = 1e-9;
// Finite-difference step on the unit bearing for the projection's Jacobian
// at the knots. Its truncation error (~1e-6 relative) is far below that of
// blending the knots' derivatives; either only slows convergence, never
// moves the converged bearing. The rounding it amplifies (~1e-13 px / 1e-6)
// is negligible.
constexpr double kJacobianStep = 1e-6;

// Bisection steps when sliding a board toward its anchor: 2^-20 of the way.
constexpr int kSlideBisections = 20;
// Orientations tried for a view that aims at an imager corner or edge; the
// one that brings a corner nearest to the anchor wins. A board rolled or
// leaning the wrong way meets the border rule with its corners far from the
// imager's corner; a few tries find one that reaches it, which is what a
// calibration set needs there (mrcal: cover the corners of the imager).
constexpr int kPlacementCandidates = 6;

// Independent hash streams of one seed.
constexpr std::uint64_t kPoseStream = 0x706f736573ULL;   // "poses"
constexpr std::uint64_t kNoiseStream = 0x6e6f697365ULL;  // "noise"

// A portable sequence of uniforms in [0, 1): the n-th draw is a hash of
// (seed, stream, n), so it is the same on every platform and standard library
// (std::uniform_real_distribution is not).
class Uniforms {
 public:
  Uniforms(std::uint64_t seed, std::uint64_t stream) : seed_(seed), stream_(stream) {}
  double Next() { return HashUniform(seed_, stream_, counter_++); }
  double Between(double low, double high) { return low + (high - low) * Next(); }
  // A uniformly random permutation of 0 .. n - 1 (Fisher-Yates).
  std::vector<int> Permutation(int n) {
    std::vector<int> order(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) order[static_cast<size_t>(i)] = i;
    for (int i = n - 1; i > 0; --i) {
      const int j = std::min(i, static_cast<int>(Next() * (i + 1)));
      std::swap(order[static_cast<size_t>(i)], order[static_cast<size_t>(j)]);
    }
    return order;
  }

 private:
  std::uint64_t seed_;
  std::uint64_t stream_;
  std::uint64_t counter_ = 0;
};

// Bearings of arbitrary pixels through a camera model, each solving
// camera.Project(bearing) = pixel to kBearingTolerancePx. libmrcal's own
// unprojection is iterative and costs ~1-2 us per point for the OpenCV models,
// so a 640 x 480 grid of 4 x 4 samples would take ~8 s; its projection is
// tens of times cheaper. libmrcal therefore unprojects only a lattice of knots, where the
// derivative of the bearing with respect to the pixel is also measured; a
// sample starts from the knots' blended bearing and takes Newton steps with
// the blended derivative, one projection each, until the model's own
// projection lands on the sample.
class BearingSolver {
 public:
  explicit BearingSolver(const calib::CameraModel& camera) : camera_(camera) {
    knots_x_ = static_cast<int>(std::ceil(camera.WidthPx() / kKnotSpacingPx)) + 1;
    knots_y_ = static_cast<int>(std::ceil(camera.HeightPx() / kKnotSpacingPx)) + 1;
    const size_t knots = static_cast<size_t>(knots_x_) * knots_y_;
    std::vector<Eigen::Vector2d> pixels;
    pixels.reserve(knots);
    for (int j = 0; j < knots_y_; ++j) {
      for (int i = 0; i < knots_x_; ++i) {
        pixels.emplace_back(-0.5 + i * kKnotSpacingPx, -0.5 + j * kKnotSpacingPx);
      }
    }
    camera.Unproject(pixels, &knots_, &knot_valid_);
    // d(bearing)/d(pixel) at each knot: the inverse of the projection's
    // Jacobian in a tangent basis (e1, e2) of the bearing, by forward
    // differences.
    std::vector<std::array<Eigen::Vector3d, 2>> bases(knots);
    std::vector<Eigen::Vector3d> points;
    points.reserve(3 * knots);
    for (size_t k = 0; k < knots; ++k) {
      const Eigen::Vector3d& b = knots_[k];
      if (knot_valid_[k]) {
        const Eigen::Vector3d helper = std::abs(b.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
        const Eigen::Vector3d e1 = (helper - helper.dot(b) * b).normalized();
        bases[k] = {e1, b.cross(e1)};
      } else {
        bases[k] = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY()};
      }
      points.push_back(b);
      points.push_back(b + kJacobianStep * bases[k][0]);
      points.push_back(b + kJacobianStep * bases[k][1]);
    }
    std::vector<Eigen::Vector2d> projected;
    std::vector<unsigned char> valid;
    camera.Project(points, &projected, &valid);
    derivatives_.assign(knots, Eigen::Matrix<double, 3, 2>::Zero());
    for (size_t k = 0; k < knots; ++k) {
      if (!knot_valid_[k]) continue;
      if (!valid[3 * k] || !valid[3 * k + 1] || !valid[3 * k + 2]) {
        knot_valid_[k] = 0;
        continue;
      }
      Eigen::Matrix2d jacobian;
      jacobian.col(0) = (projected[3 * k + 1] - projected[3 * k]) / kJacobianStep;
      jacobian.col(1) = (projected[3 * k + 2] - projected[3 * k]) / kJacobianStep;
      const double det = jacobian.determinant();
      if (!(std::abs(det) > 0.0) || !std::isfinite(det)) {
        knot_valid_[k] = 0;
        continue;
      }
      Eigen::Matrix<double, 3, 2> tangent;
      tangent.col(0) = bases[k][0];
      tangent.col(1) = bases[k][1];
      derivatives_[k] = tangent * jacobian.inverse();
    }
  }

  // Bearing of one pixel straight from libmrcal; zero when it has none.
  Eigen::Vector3d Exact(const Eigen::Vector2d& pixel) const {
    std::vector<Eigen::Vector3d> bearings;
    std::vector<unsigned char> valid;
    camera_.Unproject({pixel}, &bearings, &valid);
    return valid[0] ? bearings[0] : Eigen::Vector3d::Zero();
  }

  // Unit bearings of `pixels`; zero for a pixel the model cannot unproject.
  void Solve(const std::vector<Eigen::Vector2d>& pixels, std::vector<Eigen::Vector3d>* bearings) const {
    const size_t count = pixels.size();
    bearings->assign(count, Eigen::Vector3d::Zero());
    std::vector<Eigen::Matrix<double, 3, 2>> derivatives(count);
    std::vector<size_t> active;
    std::vector<size_t> fallback;
    active.reserve(count);
    for (size_t k = 0; k < count; ++k) {
      if (Interpolate(pixels[k], &(*bearings)[k], &derivatives[k])) {
        active.push_back(k);
      } else {
        fallback.push_back(k);
      }
    }
    std::vector<Eigen::Vector3d> points;
    std::vector<Eigen::Vector2d> projected;
    std::vector<unsigned char> valid;
    std::vector<size_t> next;
    for (int step = 0; !active.empty(); ++step) {
      points.clear();
      for (const size_t k : active) points.push_back((*bearings)[k]);
      camera_.Project(points, &projected, &valid);
      next.clear();
      for (size_t a = 0; a < active.size(); ++a) {
        const size_t k = active[a];
        const Eigen::Vector2d residual = pixels[k] - projected[a];
        if (!valid[a] || step == kMaxNewtonSteps) {
          if (!valid[a] || residual.norm() > kBearingTolerancePx) fallback.push_back(k);
          continue;
        }
        if (residual.norm() <= kBearingTolerancePx) continue;  // converged
        Eigen::Vector3d& b = (*bearings)[k];
        b = (b + derivatives[k] * residual).normalized();
        next.push_back(k);
      }
      active.swap(next);
    }
    if (fallback.empty()) return;
    // Where the lattice has holes or Newton did not settle, libmrcal decides.
    std::sort(fallback.begin(), fallback.end());
    std::vector<Eigen::Vector2d> hard;
    hard.reserve(fallback.size());
    for (const size_t k : fallback) hard.push_back(pixels[k]);
    std::vector<Eigen::Vector3d> exact;
    camera_.Unproject(hard, &exact, &valid);
    for (size_t f = 0; f < fallback.size(); ++f) {
      (*bearings)[fallback[f]] = valid[f] ? exact[f] : Eigen::Vector3d::Zero();
    }
  }

 private:
  // Bilinear blend of the four knots around `pixel` (extrapolated past the
  // last knot): the bearing, normalised, and its derivative. False when a
  // knot has no bearing.
  bool Interpolate(const Eigen::Vector2d& pixel, Eigen::Vector3d* bearing,
                   Eigen::Matrix<double, 3, 2>* derivative) const {
    const double gx = (pixel.x() + 0.5) / kKnotSpacingPx;
    const double gy = (pixel.y() + 0.5) / kKnotSpacingPx;
    if (!std::isfinite(gx) || !std::isfinite(gy)) return false;
    const int i = std::clamp(static_cast<int>(std::floor(gx)), 0, knots_x_ - 2);
    const int j = std::clamp(static_cast<int>(std::floor(gy)), 0, knots_y_ - 2);
    const double fx = gx - i;
    const double fy = gy - j;
    const size_t k00 = static_cast<size_t>(j) * knots_x_ + i;
    const size_t k10 = k00 + 1;
    const size_t k01 = k00 + static_cast<size_t>(knots_x_);
    const size_t k11 = k01 + 1;
    if (!knot_valid_[k00] || !knot_valid_[k10] || !knot_valid_[k01] || !knot_valid_[k11]) return false;
    const double w00 = (1.0 - fx) * (1.0 - fy);
    const double w10 = fx * (1.0 - fy);
    const double w01 = (1.0 - fx) * fy;
    const double w11 = fx * fy;
    const Eigen::Vector3d b = w00 * knots_[k00] + w10 * knots_[k10] + w01 * knots_[k01] + w11 * knots_[k11];
    const double norm = b.norm();
    if (!(norm > 0.0)) return false;
    *bearing = b / norm;
    *derivative = w00 * derivatives_[k00] + w10 * derivatives_[k10] + w01 * derivatives_[k01] +
                  w11 * derivatives_[k11];
    return true;
  }

  const calib::CameraModel& camera_;
  int knots_x_ = 0;
  int knots_y_ = 0;
  std::vector<Eigen::Vector3d> knots_;
  std::vector<unsigned char> knot_valid_;
  std::vector<Eigen::Matrix<double, 3, 2>> derivatives_;  // d(bearing)/d(pixel) per knot
};

// The randomly drawn part of a pose.
struct PoseDraw {
  double distance_m = 0.0;
  double tilt_rad = 0.0;
  double tilt_axis_rad = 0.0;  // direction of the tilt axis in the board plane
  double roll_rad = 0.0;
};

// Places boards and checks the border rule.
class Placer {
 public:
  Placer(const calib::CameraModel& camera, const BearingSolver& solver, const ChessboardBoard& board,
         const ChessboardViewsOptions& options)
      : camera_(camera), solver_(solver), board_(board), options_(options) {
    for (int j = 0; j < board.corners_y; ++j) {
      for (int i = 0; i < board.corners_x; ++i) {
        corners_in_board_.emplace_back(i * board.spacing_m, j * board.spacing_m, 0.0);
      }
    }
    centre_in_board_ = Eigen::Vector3d((board.corners_x - 1) * board.spacing_m / 2.0,
                                       (board.corners_y - 1) * board.spacing_m / 2.0, 0.0);
    const double low = -(1.0 + board.margin_squares) * board.spacing_m;
    const double high_x = (board.corners_x + board.margin_squares) * board.spacing_m;
    const double high_y = (board.corners_y + board.margin_squares) * board.spacing_m;
    outline_in_board_ = {Eigen::Vector3d(low, low, 0.0), Eigen::Vector3d(high_x, low, 0.0),
                         Eigen::Vector3d(high_x, high_y, 0.0), Eigen::Vector3d(low, high_y, 0.0)};
    // The region in pixel coordinates: its edges (the whole imager spans
    // -0.5 .. W - 0.5), and its centre and half size over pixel centres.
    const double w = camera.WidthPx();
    const double h = camera.HeightPx();
    left_ = options.region_x0 * w - 0.5;
    right_ = options.region_x1 * w - 0.5;
    top_ = options.region_y0 * h - 0.5;
    bottom_ = options.region_y1 * h - 0.5;
    imager_centre_ = Eigen::Vector2d((options.region_x0 + options.region_x1) / 2.0 * (w - 1),
                                     (options.region_y0 + options.region_y1) / 2.0 * (h - 1));
    half_size_ = Eigen::Vector2d((options.region_x1 - options.region_x0) * (w - 1) / 2.0,
                                 (options.region_y1 - options.region_y0) * (h - 1) / 2.0);
  }

  // The centre of the region the boards stay in (the imager's by default), and its half size.
  const Eigen::Vector2d& ImagerCentre() const { return imager_centre_; }
  const Eigen::Vector2d& HalfSize() const { return half_size_; }
  const Eigen::Vector3d& CentreInBoard() const { return centre_in_board_; }

  // The distance at which a face-on board at the imager centre shows squares
  // of fill x the largest size that still obeys the border rule there. Zero
  // when the camera cannot unproject the pixels this needs.
  double DistanceForFill(double fill) const {
    const double width = (options_.region_x1 - options_.region_x0) * camera_.WidthPx();
    const double height = (options_.region_y1 - options_.region_y0) * camera_.HeightPx();
    const double border = 2.0 * options_.min_border_squares;
    const double square_px =
        fill * std::min(width / (board_.corners_x - 1 + border), height / (board_.corners_y - 1 + border));
    const double half_px = square_px * (board_.corners_x - 1) / 2.0;
    const Eigen::Vector3d left = solver_.Exact(imager_centre_ - Eigen::Vector2d(half_px, 0.0));
    const Eigen::Vector3d right = solver_.Exact(imager_centre_ + Eigen::Vector2d(half_px, 0.0));
    if (left.squaredNorm() == 0.0 || right.squaredNorm() == 0.0) return 0.0;
    const double angle = std::acos(std::clamp(left.dot(right), -1.0, 1.0));
    if (!(angle > 0.0) || angle >= kPi) return 0.0;
    return (board_.corners_x - 1) * board_.spacing_m / 2.0 / std::tan(angle / 2.0);
  }

  // The pose with the centre of the inner corners at distance_m along the
  // line of sight through `pixel`, its normal turned from that line by the
  // tilt, then rolled about the normal. False when the pixel has no bearing.
  bool PoseAt(const PoseDraw& draw, const Eigen::Vector2d& pixel, Rigid3d* cam_from_board) const {
    const Eigen::Vector3d sight = solver_.Exact(pixel);
    if (sight.squaredNorm() == 0.0) return false;
    const Eigen::Quaterniond face = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), sight);
    const Eigen::Vector3d axis(std::cos(draw.tilt_axis_rad), std::sin(draw.tilt_axis_rad), 0.0);
    const Eigen::Quaterniond rotation =
        (face * Eigen::Quaterniond(Eigen::AngleAxisd(draw.tilt_rad, axis)) *
         Eigen::Quaterniond(Eigen::AngleAxisd(draw.roll_rad, Eigen::Vector3d::UnitZ())))
            .normalized();
    cam_from_board->rotation = rotation;
    cam_from_board->translation = draw.distance_m * sight - rotation * centre_in_board_;
    return true;
  }

  // Whether the board is wholly in front of the camera and every inner corner
  // obeys the border rule; the corners' pixels go to *corners_px.
  bool Fits(const Rigid3d& cam_from_board, std::vector<Eigen::Vector2d>* corners_px) const {
    for (const Eigen::Vector3d& point : outline_in_board_) {
      if (!((cam_from_board * point).z() > 0.0)) return false;
    }
    std::vector<Eigen::Vector3d> points;
    points.reserve(corners_in_board_.size());
    for (const Eigen::Vector3d& corner : corners_in_board_) points.push_back(cam_from_board * corner);
    std::vector<unsigned char> valid;
    if (camera_.Project(points, corners_px, &valid) != static_cast<int>(points.size())) return false;
    const int nx = board_.corners_x;
    const int ny = board_.corners_y;
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const Eigen::Vector2d& p = (*corners_px)[static_cast<size_t>(j * nx + i)];
        double square = 0.0;
        const auto neighbour = [&](int ni, int nj) {
          if (ni < 0 || nj < 0 || ni >= nx || nj >= ny) return;
          square = std::max(square, ((*corners_px)[static_cast<size_t>(nj * nx + ni)] - p).norm());
        };
        neighbour(i - 1, j);
        neighbour(i + 1, j);
        neighbour(i, j - 1);
        neighbour(i, j + 1);
        const double to_edge = std::min({p.x() - left_, right_ - p.x(), p.y() - top_, bottom_ - p.y()});
        if (!(to_edge >= options_.min_border_squares * square)) return false;
      }
    }
    return true;
  }

  // Slides the board from `from` (where it fits) toward `to` and returns the
  // farthest pixel found by bisection where it still fits.
  Eigen::Vector2d Slide(const PoseDraw& draw, const Eigen::Vector2d& from, const Eigen::Vector2d& to) const {
    std::vector<Eigen::Vector2d> corners_px;
    Rigid3d pose;
    const auto fits_at = [&](double s) {
      return PoseAt(draw, from + s * (to - from), &pose) && Fits(pose, &corners_px);
    };
    if (fits_at(1.0)) return to;
    double low = 0.0;
    double high = 1.0;
    for (int step = 0; step < kSlideBisections; ++step) {
      const double mid = 0.5 * (low + high);
      (fits_at(mid) ? low : high) = mid;
    }
    return from + low * (to - from);
  }

 private:
  const calib::CameraModel& camera_;
  const BearingSolver& solver_;
  const ChessboardBoard& board_;
  const ChessboardViewsOptions& options_;
  std::vector<Eigen::Vector3d> corners_in_board_;
  Eigen::Vector3d centre_in_board_;
  std::array<Eigen::Vector3d, 4> outline_in_board_;
  Eigen::Vector2d imager_centre_;
  Eigen::Vector2d half_size_;
  double left_ = 0.0, right_ = 0.0, top_ = 0.0, bottom_ = 0.0;
};

// Anchors in units of the imager's half size: four corners, four edge
// middles, the centre (the edge and centre ones get jittered per view).
constexpr std::array<std::array<double, 2>, 4> kCornerAnchors = {{{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}};
constexpr std::array<std::array<double, 2>, 4> kEdgeAnchors = {{{0, -1}, {1, 0}, {0, 1}, {-1, 0}}};

// Per view: which anchor, in rounds of nine (corners, then edges, then the
// centre, each group in a seeded order), so that any nine consecutive views
// visit all nine and the first four take the corners.
std::vector<std::array<double, 2>> AnchorSequence(int views, Uniforms* random) {
  std::vector<std::array<double, 2>> sequence;
  while (static_cast<int>(sequence.size()) < views) {
    for (const int k : random->Permutation(4)) sequence.push_back(kCornerAnchors[static_cast<size_t>(k)]);
    for (const int k : random->Permutation(4)) {
      std::array<double, 2> anchor = kEdgeAnchors[static_cast<size_t>(k)];
      // Somewhere along that edge, not always its middle.
      (anchor[0] == 0.0 ? anchor[0] : anchor[1]) = random->Between(-0.6, 0.6);
      sequence.push_back(anchor);
    }
    sequence.push_back({random->Between(-0.3, 0.3), random->Between(-0.3, 0.3)});
  }
  sequence.resize(static_cast<size_t>(views));
  return sequence;
}

// Everything the renderer needs about one view.
struct ViewShading {
  Eigen::Vector3d row_x;  // rows of the rotation board_from_cam
  Eigen::Vector3d row_y;
  Eigen::Vector3d row_z;
  Eigen::Vector3d camera_in_board;  // board_from_cam translation, metres
  double gradient_x = 0.0;          // background change per pixel along x and y, grey levels
  double gradient_y = 0.0;
  std::uint64_t noise_key = 0;
};

// Normalised weights of a sampled Gaussian of sigma pixels over +-ceil(3 sigma);
// a single 1 (no blur) for sigma 0.
std::vector<float> GaussianKernel(double sigma_px) {
  if (!(sigma_px > 0.0)) return {1.0F};
  const int radius = static_cast<int>(std::ceil(3.0 * sigma_px));
  std::vector<double> weights(static_cast<size_t>(2 * radius + 1));
  double total = 0.0;
  for (int d = -radius; d <= radius; ++d) {
    const double weight = std::exp(-0.5 * d * d / (sigma_px * sigma_px));
    weights[static_cast<size_t>(d + radius)] = weight;
    total += weight;
  }
  std::vector<float> kernel;
  for (const double weight : weights) kernel.push_back(static_cast<float>(weight / total));
  return kernel;
}

}  // namespace

std::vector<std::string> ChessboardBoard::Validate() const {
  std::vector<std::string> errors;
  RequireOption(corners_x >= 2, "corners_x", corners_x, ">= 2 inner corners", &errors);
  RequireOption(corners_y >= 2, "corners_y", corners_y, ">= 2 inner corners", &errors);
  RequireOption(spacing_m > 0.0, "spacing_m", spacing_m, "> 0 metres", &errors);
  RequireOption(margin_squares >= 0.0, "margin_squares", margin_squares, ">= 0 squares", &errors);
  return errors;
}

std::vector<std::string> ChessboardViewsOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(views >= 1, "views", views, ">= 1", &errors);
  RequireOption(noise_sigma >= 0.0, "noise_sigma", noise_sigma, ">= 0 grey levels", &errors);
  RequireOption(supersampling >= 1 && supersampling <= 16, "supersampling", supersampling, "1 to 16", &errors);
  RequireOption(blur_sigma_px >= 0.0 && blur_sigma_px <= 10.0, "blur_sigma_px", blur_sigma_px,
                "in [0, 10] pixels", &errors);
  RequireOption(black >= 0.0 && black <= 255.0, "black", black, "in [0, 255]", &errors);
  RequireOption(white >= 0.0 && white <= 255.0, "white", white, "in [0, 255]", &errors);
  if (std::isfinite(black) && std::isfinite(white)) {
    RequireOption(white > black, "white", white, "> black (" + util::ShortestText(black) + ")", &errors);
  }
  RequireOption(background >= 0.0 && background <= 255.0, "background", background, "in [0, 255]", &errors);
  RequireOption(background_gradient >= 0.0, "background_gradient", background_gradient, ">= 0 grey levels",
                &errors);
  RequireOption(min_fill > 0.0 && min_fill <= 1.0, "min_fill", min_fill, "in (0, 1]", &errors);
  RequireOption(max_fill >= min_fill && max_fill <= 1.0, "max_fill", max_fill, "in [min_fill, 1]", &errors);
  const bool no_distances = min_distance_m == 0.0 && max_distance_m == 0.0;
  RequireOption(no_distances || min_distance_m > 0.0, "min_distance_m", min_distance_m,
                "0 (distances from the fill) or > 0 metres", &errors);
  RequireOption(no_distances || max_distance_m >= min_distance_m, "max_distance_m", max_distance_m,
                "0 (distances from the fill) or >= min_distance_m metres", &errors);
  RequireOption(min_tilt_deg >= 0.0 && min_tilt_deg < 80.0, "min_tilt_deg", min_tilt_deg, "in [0, 80) degrees",
                &errors);
  RequireOption(max_tilt_deg >= min_tilt_deg && max_tilt_deg < 80.0, "max_tilt_deg", max_tilt_deg,
                "in [min_tilt_deg, 80) degrees", &errors);
  RequireOption(max_roll_deg >= 0.0 && max_roll_deg <= 180.0, "max_roll_deg", max_roll_deg, "in [0, 180] degrees",
                &errors);
  RequireOption(coverage > 0.0 && coverage <= 1.0, "coverage", coverage, "in (0, 1]", &errors);
  if (!(region_x0 >= 0.0 && region_x0 < region_x1 && region_x1 <= 1.0)) {
    errors.push_back("region x " + util::ShortestText(region_x0) + ".." + util::ShortestText(region_x1) +
                     ": expected 0 <= x0 < x1 <= 1");
  }
  if (!(region_y0 >= 0.0 && region_y0 < region_y1 && region_y1 <= 1.0)) {
    errors.push_back("region y " + util::ShortestText(region_y0) + ".." + util::ShortestText(region_y1) +
                     ": expected 0 <= y0 < y1 <= 1");
  }
  RequireOption(min_border_squares >= 1.0, "min_border_squares", min_border_squares,
                ">= 1 (the outer squares must be in view)", &errors);
  RequireOption(max_attempts >= 1, "max_attempts", max_attempts, ">= 1", &errors);
  RequireOption(threads >= 0, "threads", threads, ">= 0 (0: every core this process may use)", &errors);
  return errors;
}

namespace {

// Throws InputError listing every problem of the board and the options.
void ThrowIfInvalid(const ChessboardBoard& board, const ChessboardViewsOptions& options) {
  std::vector<std::string> errors = board.Validate();
  for (const std::string& error : options.Validate()) errors.push_back(error);
  hdabench::ThrowIfInvalid("RenderChessboardViews: invalid board or options: ", errors);
}

// One view's placement: the board pose and the pixels of its inner corners.
struct Placement {
  Rigid3d pose;
  std::vector<Eigen::Vector2d> corners_px;
};

// Draws the random part of a pose, in this order: where in the view's slice
// (`stratum`) of the distance range, tilt, tilt axis, roll.
PoseDraw DrawPose(const Placer& placer, const ChessboardViewsOptions& options, int stratum, bool by_fill,
                  Uniforms* random) {
  PoseDraw draw;
  // Distances spread evenly: each view has its own slice of the range.
  const double where = (stratum + random->Next()) / options.views;
  draw.distance_m =
      by_fill ? placer.DistanceForFill(options.min_fill + where * (options.max_fill - options.min_fill))
              : options.min_distance_m + where * (options.max_distance_m - options.min_distance_m);
  draw.tilt_rad = random->Between(options.min_tilt_deg, options.max_tilt_deg) * kDegToRad;
  draw.tilt_axis_rad = random->Between(0.0, 2.0 * kPi);
  draw.roll_rad = random->Between(-options.max_roll_deg, options.max_roll_deg) * kDegToRad;
  return draw;
}

// Places view v: draws poses until kPlacementCandidates (one for the centre
// anchor) fit at the centre of the region the boards stay in, slides each
// toward the view's anchor and keeps the one whose corners come nearest to
// it. Throws InputError when no draw out of max_attempts fits.
Placement PlaceView(const Placer& placer, const ChessboardViewsOptions& options, const std::array<double, 2>& anchor,
                    int stratum, size_t v, bool by_fill, Uniforms* random) {
  const Eigen::Vector2d& half_size = placer.HalfSize();
  const Eigen::Vector2d target =
      placer.ImagerCentre() +
      options.coverage * Eigen::Vector2d(anchor[0] * half_size.x(), anchor[1] * half_size.y());
  // How far a placement leaves the corners from the anchor: along both axes
  // for an imager corner, across the edge for an edge anchor.
  const double weight_x = std::abs(anchor[0]) == 1.0 ? 1.0 : 0.0;
  const double weight_y = std::abs(anchor[1]) == 1.0 ? 1.0 : 0.0;
  const auto shortfall = [&](const std::vector<Eigen::Vector2d>& corners) {
    double best = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector2d& p : corners) {
      const Eigen::Vector2d d = p - target;
      best = std::min(best, std::sqrt(weight_x * d.x() * d.x() + weight_y * d.y() * d.y()));
    }
    return best;
  };
  const int candidates = weight_x + weight_y > 0.0 ? kPlacementCandidates : 1;
  Placement best;
  double best_shortfall = std::numeric_limits<double>::infinity();
  int fitted = 0;
  for (int attempt = 0; attempt < options.max_attempts && fitted < candidates; ++attempt) {
    const PoseDraw draw = DrawPose(placer, options, stratum, by_fill, random);
    Rigid3d candidate;
    std::vector<Eigen::Vector2d> candidate_corners;
    if (!(draw.distance_m > 0.0) || !placer.PoseAt(draw, placer.ImagerCentre(), &candidate) ||
        !placer.Fits(candidate, &candidate_corners)) {
      continue;  // redraw
    }
    ++fitted;
    // Toward the anchor, then along each axis, so that the board hugs an
    // imager corner.
    Eigen::Vector2d at = placer.Slide(draw, placer.ImagerCentre(), target);
    at = placer.Slide(draw, at, Eigen::Vector2d(target.x(), at.y()));
    at = placer.Slide(draw, at, Eigen::Vector2d(at.x(), target.y()));
    if (!placer.PoseAt(draw, at, &candidate) || !placer.Fits(candidate, &candidate_corners)) {
      // Slide() only returns points where the board fits.
      throw std::logic_error("RenderChessboardViews: the slid pose does not fit");
    }
    const double miss = shortfall(candidate_corners);
    if (miss < best_shortfall || fitted == 1) {
      best_shortfall = miss;
      best.pose = candidate;
      best.corners_px = candidate_corners;
    }
  }
  if (fitted == 0) {
    throw InputError("RenderChessboardViews: view " + std::to_string(v + 1) + ": no pose out of " +
                     std::to_string(options.max_attempts) +
                     " keeps the whole board in front of the camera with every corner " +
                     util::ShortestText(options.min_border_squares) +
                     " squares inside the imager; expected a smaller board, a larger distance or fill, or "
                     "less tilt");
  }
  return best;
}

// Fills the view's pose, true corners, and the distance and tilt they imply.
void DescribeView(const Placement& placement, const Placer& placer, int width, int height, ChessboardView* view) {
  const Rigid3d& pose = placement.pose;
  const std::vector<Eigen::Vector2d>& corners_px = placement.corners_px;
  view->cam_from_board = pose;
  view->true_corners_px = corners_px;
  const Eigen::Vector3d centre = pose * placer.CentreInBoard();
  view->distance_m = centre.norm();
  const Eigen::Vector3d normal = pose.rotation * Eigen::Vector3d::UnitZ();
  view->tilt_deg = std::acos(std::clamp(normal.dot(centre.normalized()), -1.0, 1.0)) / kDegToRad;
  view->all_corners_visible = std::all_of(corners_px.begin(), corners_px.end(), [&](const Eigen::Vector2d& p) {
    return p.x() >= -0.5 && p.y() >= -0.5 && p.x() <= width - 0.5 && p.y() <= height - 0.5;
  });
}

// What the renderer needs about view v at `pose`; draws the direction of its
// background gradient.
ViewShading ShadingFor(const Rigid3d& pose, const ChessboardViewsOptions& options, size_t v, int width, int height,
                       Uniforms* random) {
  const Rigid3d board_from_cam = pose.Inverse();
  const Eigen::Matrix3d rotation = board_from_cam.RotationMatrix();
  ViewShading shade;
  shade.row_x = rotation.row(0).transpose();
  shade.row_y = rotation.row(1).transpose();
  shade.row_z = rotation.row(2).transpose();
  shade.camera_in_board = board_from_cam.translation;
  const double gradient_angle = random->Between(0.0, 2.0 * kPi);
  shade.gradient_x = options.background_gradient * std::cos(gradient_angle) / std::max(1, width - 1);
  shade.gradient_y = options.background_gradient * std::sin(gradient_angle) / std::max(1, height - 1);
  shade.noise_key = Mix64(Mix64(options.seed ^ kNoiseStream) + v);
  return shade;
}

// Render workers: options.threads, or every core this process may use when it is 0.
int RenderThreads(const ChessboardViewsOptions& options) {
  return util::WorkerThreads(options.threads);
}

// The imager, the sampling and the board's squares, as the noise-free render reads them.
struct BoardRaster {
  int width = 0;
  int height = 0;
  int n = 1;                     // samples per pixel along each axis
  double inverse_spacing = 0.0;  // 1 / square side, 1/metres
  double squares_x = 0.0;        // squares span u in [-1, corners_x)
  double squares_y = 0.0;
  double margin = 0.0;           // margin width, squares
  double inverse_samples = 0.0;  // 1 / (n * n)
  double centre_x = 0.0;         // imager centre, pixels
  double centre_y = 0.0;
};

// The raster of `board` through a width x height imager.
BoardRaster MakeBoardRaster(const ChessboardBoard& board, const ChessboardViewsOptions& options, int width,
                            int height) {
  BoardRaster raster;
  raster.width = width;
  raster.height = height;
  raster.n = options.supersampling;
  raster.inverse_spacing = 1.0 / board.spacing_m;
  raster.squares_x = board.corners_x;
  raster.squares_y = board.corners_y;
  raster.margin = board.margin_squares;
  raster.inverse_samples = 1.0 / (raster.n * raster.n);
  raster.centre_x = (width - 1) / 2.0;
  raster.centre_y = (height - 1) / 2.0;
  return raster;
}

// Sample pixels of one image row: sub-row k, then column, then sub-column l.
std::vector<Eigen::Vector2d> RowSamplePixels(const BoardRaster& raster, int row) {
  const int n = raster.n;
  const size_t row_samples = static_cast<size_t>(raster.width) * n;
  std::vector<Eigen::Vector2d> pixels;
  pixels.reserve(row_samples * n);
  for (int k = 0; k < n; ++k) {
    const double y = row + (k + 0.5) / n - 0.5;
    for (int col = 0; col < raster.width; ++col) {
      for (int l = 0; l < n; ++l) pixels.emplace_back(col + (l + 0.5) / n - 0.5, y);
    }
  }
  return pixels;
}

// Noise-free grey level of pixel (row, col) of one view: the mean of what its
// samples (bearings of RowSamplePixels(row)) hit: square, margin or background.
float PixelMean(const BoardRaster& raster, const ViewShading& shade, const ChessboardViewsOptions& options,
                const std::vector<Eigen::Vector3d>& bearings, int row, int col) {
  const int n = raster.n;
  const size_t row_samples = static_cast<size_t>(raster.width) * n;
  int black_samples = 0;
  int white_samples = 0;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d* sample = &bearings[static_cast<size_t>(k) * row_samples + static_cast<size_t>(col) * n];
    for (int l = 0; l < n; ++l) {
      const Eigen::Vector3d& b = sample[l];
      // The camera sits on the board's -z side: only rays going toward
      // +z in the board frame meet the printed side.
      const double toward = shade.row_z.dot(b);
      if (!(toward > 0.0)) continue;
      const double range = -shade.camera_in_board.z() / toward;
      const double u = (shade.camera_in_board.x() + range * shade.row_x.dot(b)) * raster.inverse_spacing;
      const double w = (shade.camera_in_board.y() + range * shade.row_y.dot(b)) * raster.inverse_spacing;
      if (u >= -1.0 && u < raster.squares_x && w >= -1.0 && w < raster.squares_y) {
        // Square (floor(u), floor(w)); both are >= -1 here, so the
        // truncation of u + 1 is floor(u) + 1 (and cheaper than floor).
        const long parity = static_cast<long>(u + 1.0) + static_cast<long>(w + 1.0);
        ((parity & 1) == 0 ? black_samples : white_samples) += 1;
      } else if (u >= -1.0 - raster.margin && u <= raster.squares_x + raster.margin &&
                 w >= -1.0 - raster.margin && w <= raster.squares_y + raster.margin) {
        ++white_samples;
      }
    }
  }
  // The background is linear in the pixel position, so the mean over
  // the pixel's samples is its value at the pixel centre.
  const double background = options.background + shade.gradient_x * (col - raster.centre_x) +
                            shade.gradient_y * (row - raster.centre_y);
  const int background_samples = n * n - black_samples - white_samples;
  return static_cast<float>(
      (black_samples * options.black + white_samples * options.white + background_samples * background) *
      raster.inverse_samples);
}

// The noise-free images of every view (CV_32FC1, grey levels), row by row:
// the row's sample bearings are solved once and shaded for every view.
std::vector<cv::Mat> RenderMeans(const BearingSolver& solver, const BoardRaster& raster,
                                 const std::vector<ViewShading>& shading, const ChessboardViewsOptions& options,
                                 int threads) {
  std::vector<cv::Mat> means(shading.size());
  for (cv::Mat& mean : means) mean = cv::Mat(raster.height, raster.width, CV_32FC1);
  util::ParallelFor("chessboard rows", raster.height, threads, [&](int row) {
    std::vector<Eigen::Vector3d> bearings;
    solver.Solve(RowSamplePixels(raster, row), &bearings);
    for (size_t v = 0; v < shading.size(); ++v) {
      auto* out = means[v].ptr<float>(row);
      for (int col = 0; col < raster.width; ++col) {
        out[col] = PixelMean(raster, shading[v], options, bearings, row, col);
      }
    }
  });
  return means;
}

// Blurs `mean` along rows with `kernel` into `across`. The border repeats the
// edge pixel (the scene goes on beyond the imager).
void BlurRows(const cv::Mat& mean, const std::vector<float>& kernel, int threads, cv::Mat* across) {
  const int width = mean.cols;
  const int radius = static_cast<int>(kernel.size() / 2);
  util::ParallelFor("chessboard rows", mean.rows, threads, [&](int row) {
    const float* in = mean.ptr<float>(row);
    float* out = across->ptr<float>(row);
    for (int col = 0; col < width; ++col) {
      float sum = 0.0F;
      for (int d = -radius; d <= radius; ++d) {
        sum += kernel[static_cast<size_t>(d + radius)] * in[std::clamp(col + d, 0, width - 1)];
      }
      out[col] = sum;
    }
  });
}

// The sensor at one pixel: Gaussian noise (Box-Muller from two hashed
// uniforms of (view, pixel)), clamping to [0, 255] and rounding.
unsigned char NoisyGrey(double value, std::uint64_t noise_key, std::uint64_t pixel, double noise_sigma) {
  const double u1 = 1.0 - HashUniform(noise_key, pixel, 0);  // (0, 1]
  const double u2 = HashUniform(noise_key, pixel, 1);
  const double noise = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  const double noisy = std::clamp(value + noise_sigma * noise, 0.0, 255.0);
  return static_cast<unsigned char>(std::lround(noisy));
}

// Blurs `across` along columns (or, without blur, takes `mean` as it is),
// then the sensor, into the view's 8-bit `image`.
void BlurColumnsAndSense(const cv::Mat& mean, const cv::Mat& across, const std::vector<float>& kernel,
                         const ViewShading& shade, const ChessboardViewsOptions& options, int threads,
                         cv::Mat* image) {
  const int width = mean.cols;
  const int height = mean.rows;
  const int radius = static_cast<int>(kernel.size() / 2);
  util::ParallelFor("chessboard rows", height, threads, [&](int row) {
    auto* out = image->ptr<unsigned char>(row);
    for (int col = 0; col < width; ++col) {
      double value = 0.0;
      if (radius > 0) {
        for (int d = -radius; d <= radius; ++d) {
          value += static_cast<double>(kernel[static_cast<size_t>(d + radius)] *
                                       across.at<float>(std::clamp(row + d, 0, height - 1), col));
        }
      } else {
        value = mean.at<float>(row, col);
      }
      const std::uint64_t pixel = static_cast<std::uint64_t>(row) * width + col;
      out[col] = NoisyGrey(value, shade.noise_key, pixel, options.noise_sigma);
    }
  });
}

// Optics, then the sensor, for every view: blur, noise, clamping, rounding,
// from the noise-free `means` into each view's image.
void ExposeViews(const std::vector<cv::Mat>& means, const std::vector<ViewShading>& shading,
                 const ChessboardViewsOptions& options, int width, int height, int threads,
                 std::vector<ChessboardView>* views) {
  const std::vector<float> kernel = GaussianKernel(options.blur_sigma_px);
  const int radius = static_cast<int>(kernel.size() / 2);
  cv::Mat across(height, width, CV_32FC1);
  for (size_t v = 0; v < views->size(); ++v) {
    const cv::Mat& mean = means[v];
    // Separable: along rows into `across`, then along columns.
    if (radius > 0) BlurRows(mean, kernel, threads, &across);
    BlurColumnsAndSense(mean, across, kernel, shading[v], options, threads, &(*views)[v].image);
  }
}

}  // namespace

std::vector<ChessboardView> RenderChessboardViews(const calib::CameraModel& camera,
                                                  const ChessboardBoard& board,
                                                  const ChessboardViewsOptions& options) {
  ThrowIfInvalid(board, options);
  const int width = camera.WidthPx();
  const int height = camera.HeightPx();
  const BearingSolver solver(camera);
  const Placer placer(camera, solver, board, options);

  // Poses, one view after the other from one generator.
  Uniforms random(options.seed, kPoseStream);
  const std::vector<std::array<double, 2>> anchors = AnchorSequence(options.views, &random);
  const std::vector<int> strata = random.Permutation(options.views);
  const bool by_fill = options.min_distance_m == 0.0 && options.max_distance_m == 0.0;
  std::vector<ChessboardView> views(static_cast<size_t>(options.views));
  std::vector<ViewShading> shading(views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    const Placement placement =
        PlaceView(placer, options, anchors[v], strata[v], v, by_fill, &random);
    DescribeView(placement, placer, width, height, &views[v]);
    shading[v] = ShadingFor(placement.pose, options, v, width, height, &random);
    views[v].image = cv::Mat(height, width, CV_8UC1);
  }

  // Rendering, then optics and the sensor.
  const int threads = RenderThreads(options);
  const std::vector<cv::Mat> means =
      RenderMeans(solver, MakeBoardRaster(board, options, width, height), shading, options, threads);
  ExposeViews(means, shading, options, width, height, threads, &views);
  return views;
}

void WriteChessboardViews(const std::vector<ChessboardView>& views, const std::string& dir,
                          const std::string& stem) {
  if (views.empty()) throw InputError(dir + ": no chessboard views to write");
  if (stem.find('/') != std::string::npos || stem.find('\0') != std::string::npos) {
    throw InputError(dir + ": file stem '" + stem + "' contains '/'; expected a plain file-name prefix");
  }
  const fs::path folder(dir);
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec || !fs::is_directory(folder)) {
    throw InputError(dir + ": cannot create the folder (" + (ec ? ec.message() : "not a folder") + ")");
  }
  const size_t digits = std::max<size_t>(2, std::to_string(views.size()).size());
  const auto number = [&](size_t v) {
    std::string text = std::to_string(v + 1);
    return std::string(digits - text.size(), '0') + text;
  };
  std::string truth = "view,corner,x_px,y_px\n";
  std::string poses = "view,image,qw,qx,qy,qz,tx_m,ty_m,tz_m,distance_m,tilt_deg\n";
  for (size_t v = 0; v < views.size(); ++v) {
    const ChessboardView& view = views[v];
    const std::string image_name = stem + number(v) + ".png";
    if (view.image.empty() || view.image.type() != CV_8UC1) {
      throw InputError((folder / image_name).string() + ": view " + std::to_string(v + 1) +
                       " has no 8-bit grey image (CV_8UC1)");
    }
    util::WriteFileAtomically(folder / image_name, internal::EncodePng(view.image));
    for (size_t c = 0; c < view.true_corners_px.size(); ++c) {
      truth += std::to_string(v + 1) + "," + std::to_string(c) + "," + util::ShortestText(view.true_corners_px[c].x()) +
               "," + util::ShortestText(view.true_corners_px[c].y()) + "\n";
    }
    const Eigen::Quaterniond& q = view.cam_from_board.rotation;
    const Eigen::Vector3d& t = view.cam_from_board.translation;
    poses += internal::CsvLine({std::to_string(v + 1), image_name, util::ShortestText(q.w()), util::ShortestText(q.x()),
                                util::ShortestText(q.y()), util::ShortestText(q.z()), util::ShortestText(t.x()), util::ShortestText(t.y()),
                                util::ShortestText(t.z()), util::ShortestText(view.distance_m), util::ShortestText(view.tilt_deg)});
  }
  util::WriteFileAtomically(folder / "truth.csv", truth);
  util::WriteFileAtomically(folder / "poses.csv", poses);
}

}  // namespace hdabench::datasets::synth
