// The two models a pair of views can follow, fitted to matched bearings and
// weighed against each other:
//  - the general model, an essential matrix E = [t12]x R12 (OpenGV's
//    convention: X1 = R12 X2 + t12, so f1^T E f2 = 0), 5 degrees of freedom;
//  - the plane-induced homography, 8 degrees of freedom.
//
// Both are measured by their Sampson distance (the first-order distance of a
// match, in the 4-d space of its two image positions, to the model's
// manifold) in tangent-plane coordinates around each view's mean bearing,
// scaled by the focal length to pixels.
//
// Which one the matches follow is decided by Torr's geometric robust
// information criterion (GRIC; P. H. S. Torr, "Bayesian model estimation and
// selection for epipolar geometry and generic manifold fitting", IJCV 50(1),
// 2002), with the matching noise measured on the general model's residuals:
//   GRIC = sum_i min(d_i^2 / sigma^2, 2 (r - m)) + ln(r) m n + ln(r n) k
// with r = 4 (two image positions), m the manifold's dimension (3 for E,
// 2 for the homography), k the parameters (5 for E, 8 for the homography) and
// n the matches. The lower GRIC wins: the homography wins when the relief of
// the scene does not move the matches off it by more than their noise.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace hdabench::reference {

// Matched bearings in tangent-plane coordinates around each view's mean
// bearing (tan of the angle: pixels = focal * distance near the centre).
// Matches more than 90 degrees off their view's mean are left out.
struct TangentMatches {
  Eigen::Matrix3d to_z1 = Eigen::Matrix3d::Identity();  // view-1 bearings to the tangent frame
  Eigen::Matrix3d to_z2 = Eigen::Matrix3d::Identity();
  std::vector<size_t> index;        // per kept match: its index in the input
  std::vector<Eigen::Vector2d> u1;  // per kept match
  std::vector<Eigen::Vector2d> u2;
  bool valid = false;               // both means non-zero
};
TangentMatches ToTangentPlanes(const std::vector<Eigen::Vector3d>& bearings1,
                               const std::vector<Eigen::Vector3d>& bearings2);

// A relative pose in OpenGV's convention, t12 of unit norm.
struct EpipolarPose {
  Eigen::Matrix3d r12 = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t12 = Eigen::Vector3d::UnitX();
};

// The Sampson distance (pixels) of each kept match of `matches` to the pose's
// essential matrix: the same order as matches.u1.
std::vector<double> EpipolarSampsonPx(const TangentMatches& matches, const EpipolarPose& pose,
                                      double focal_px);

// Levenberg-Marquardt on the sum of squared Sampson distances of the kept
// matches listed in `subset` (positions in matches.u1), over the rotation and
// the translation direction (5 degrees of freedom), from `pose`. Returns the
// refined pose; false (pose unchanged) when the subset has fewer than 5
// matches or the result is not finite.
bool RefineEpipolarPose(const TangentMatches& matches, const std::vector<size_t>& subset,
                        double focal_px, EpipolarPose* pose);

// The homography fitted by the direct linear transform on Hartley-normalised
// coordinates, refitted on the matches within trim times the median transfer
// error, `refits` times.
struct HomographyModel {
  Eigen::Matrix3d h = Eigen::Matrix3d::Identity();  // tangent plane 1 -> tangent plane 2
  std::vector<double> transfer_px;  // per kept match: image-2 transfer error
  std::vector<double> sampson_px;   // per kept match: Sampson distance
  std::vector<bool> used;           // per kept match: in the final fit
  bool valid = false;               // at least 4 matches and a finite fit
};
HomographyModel FitHomographyModel(const TangentMatches& matches, double focal_px, int refits,
                                   double trim);

// The general model fitted to the matches from a starting pose (the nav's):
// Sampson refinement on the matches within kTrim robust sigmas, three times.
struct GeneralModel {
  EpipolarPose pose;
  std::vector<double> sampson_px;  // per kept match
};
GeneralModel FitGeneralModel(const TangentMatches& matches, const EpipolarPose& start,
                             double focal_px);

// GRIC of both models over the same matches.
struct ModelSelection {
  double noise_px = 0.0;         // 1.4826 median |Sampson distance to the general model|
  double gric_general = 0.0;
  double gric_homography = 0.0;
  int num_matches = 0;
  bool homography_wins() const { return num_matches > 0 && gric_homography <= gric_general; }
};
// The noise is floored at kMinNoisePx, so that exact (noise-free) matches
// still give finite scores. No matches: everything zero, the general model
// kept.
constexpr double kMinNoisePx = 1e-6;
ModelSelection SelectTwoViewModel(const std::vector<double>& general_sampson_px,
                                  const std::vector<double>& homography_sampson_px);

}  // namespace hdabench::reference
