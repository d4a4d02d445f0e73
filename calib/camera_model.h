// A camera's intrinsics and imager, as a mrcal .cameramodel holds them.
//
// Loading, projection and unprojection go through libmrcal, so every lens model
// libmrcal 2.2 parses works, splined ones included. Pixels use mrcal's origin
// (centre of the top-left pixel at (0,0)); points are in the camera frame with
// OpenCV axes (docs/conventions.md).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "calib/rigid3.h"

namespace hdabench::calib {

class CameraModel {
 public:
  // Builds a model from a full (configured) mrcal lens model name, e.g.
  // "LENSMODEL_OPENCV8" or
  // "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=100",
  // its intrinsics (core fx, fy, cx, cy first where the model has one, then the
  // distortion, in mrcal's order), the imager size in pixels and mrcal's
  // extrinsics rt_cam_ref (zero: the camera is the reference).
  // Throws InputError naming `origin` (a file name or "<memory>") when the model
  // name is unknown, the intrinsics count is wrong, a value is not finite, or
  // the imager size is not positive.
  CameraModel(const std::string& lensmodel, std::vector<double> intrinsics, int width_px,
              int height_px, const std::array<double, 6>& rt_cam_ref = {},
              const std::string& origin = "<memory>");

  // Reads a .cameramodel file through libmrcal. Throws InputError whose message
  // starts with the path (and line:column where the parser gives a position)
  // and says what is wrong: missing or unreadable file, empty file, missing key,
  // unknown lens model, wrong number of intrinsics, non-finite value, garbage
  // after the closing brace. libmrcal's own stderr output is captured and
  // folded into that message, never printed.
  static CameraModel Load(const std::string& path);
  // The same, from text already in memory; `origin` names it in messages.
  static CameraModel Parse(const std::string& text, const std::string& origin);

  // Writes the model in mrcal's format with every double printed so that it
  // reads back bit-identical (shortest round-trip decimal). The file is written
  // to a temporary name and renamed, so a failure never leaves a partial file.
  // Throws InputError when the path cannot be written.
  void Save(const std::string& path) const;
  std::string ToText() const;

  const std::string& LensModelName() const { return lensmodel_; }
  const std::vector<double>& Intrinsics() const { return intrinsics_; }
  int WidthPx() const { return width_px_; }
  int HeightPx() const { return height_px_; }
  // mrcal's extrinsics rt_cam_ref (Rodrigues rotation in radians, then
  // translation), kept exactly as read so that a round trip is lossless.
  const std::array<double, 6>& RtCamRef() const { return rt_cam_ref_; }
  // The same extrinsics as a transform cam_from_ref.
  Rigid3d CamFromRef() const;
  // True for models whose first four intrinsics are fx, fy, cx, cy.
  bool HasCore() const { return has_core_; }
  // True when the model can project points with z <= 0 (stereographic family).
  bool CanProjectBehindCamera() const { return can_project_behind_camera_; }

  // Projects points in the camera frame to pixels: q = project(p).
  // pixels and valid are resized to points.size(). valid[i] is 0 when point i
  // cannot be projected by this lens model (z <= 0 for pinhole-like models,
  // the origin, a non-finite input, or a non-finite result); its pixel is then
  // (0,0) and must not be used. Returns the number of valid points.
  int Project(const std::vector<Eigen::Vector3d>& points_in_cam,
              std::vector<Eigen::Vector2d>* pixels, std::vector<unsigned char>* valid) const;

  // Unprojects pixels to unit bearing vectors in the camera frame, so that
  // Project(Unproject(q)) == q. libmrcal solves this iteratively. valid[i] is 0
  // when the input is not finite or the solve gives no finite direction; the
  // bearing is then (0,0,0). Returns the number of valid pixels. CAHVORE is not
  // unprojectable in libmrcal: Unproject throws UnsupportedError for it.
  int Unproject(const std::vector<Eigen::Vector2d>& pixels,
                std::vector<Eigen::Vector3d>* bearings_in_cam,
                std::vector<unsigned char>* valid) const;

  // OpenCV equivalent: K (3x3, CV_64F) and distortion (1xN, CV_64F, empty for
  // PINHOLE) such that cv::projectPoints gives the same pixels as Project().
  // Allowed for LENSMODEL_PINHOLE and LENSMODEL_OPENCV4/5/8/12; any other model
  // throws UnsupportedError naming the model and saying why.
  void ToOpenCv(cv::Mat* camera_matrix, cv::Mat* distortion) const;
  // Whether ToOpenCv() is allowed for this model.
  bool HasOpenCvEquivalent() const;

 private:
  std::string lensmodel_;
  std::vector<double> intrinsics_;
  int width_px_ = 0;
  int height_px_ = 0;
  std::array<double, 6> rt_cam_ref_{};
  bool has_core_ = false;
  bool can_project_behind_camera_ = false;
  bool is_cahvore_ = false;
  bool has_opencv_equivalent_ = false;
};

// The number of intrinsics of a full (configured) mrcal lens model name.
// Throws InputError naming `origin` when libmrcal does not know the model or
// its configuration is missing or invalid.
int LensModelParameterCount(const std::string& lensmodel, const std::string& origin = "<memory>");

// Every unconfigured lens model name libmrcal supports ("..." for config values).
std::vector<std::string> SupportedLensModels();

}  // namespace hdabench::calib
