// Checks that a synthetic dataset's imagery behaves like a camera's
// (`hdabench imagery`, docs/synthetic-scenes.md "Checking the imagery"):
//  - the photometric residual at true correspondences: the same ground seen
//    in two frames, through the truth, against what the sensor noise and the
//    photometric model's own change with the view explain;
//  - the error of image matches against the truth correspondence;
//  - the rendered edge-spread function of a sharp albedo step against the
//    configured pixel response.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/types.hpp>

#include "datasets/dataset.h"
#include "datasets/synth/render.h"

namespace hdabench::datasets::synth {

// One ROI's photometric agreement between frame 1 and frame 2. Each image-1
// pixel of the box with a truth point is mapped through that point and the
// true pose of frame 2 into image 2 and sampled there (bilinear); pixels the
// truth shows hidden in frame 2 (its own truth point there is more than two
// pixel footprints away) or outside image 2 are left out. A gain and offset
// are fitted (image 2 = gain * image 1 + offset, least squares) and the RMS
// of what is left is the residual.
struct PhotometricRoi {
  int id = 0;
  cv::Rect box;                  // image 1 pixels
  int pixels = 0;                // pixels compared
  int hidden = 0;                // pixels hidden in frame 2 or outside it
  double spread_dn = 0.0;        // standard deviation of the compared image-1 pixels
  double gain = 0.0;
  double offset_dn = 0.0;
  double residual_rms_dn = 0.0;
  // What noise explains: the RMS of gain * (image-1 noise) and the
  // bilinear-weighted image-2 noise, from each pixel's value (shot noise:
  // DN / gain_electrons_per_dn; read noise; rounding 1/12 DN^2).
  double noise_rms_dn = 0.0;
  // What the photometric model's change with the view explains: the RMS
  // left by the same fit of image 1 times the ratio of the lunar-Lambert
  // reflectances from the two cameras (normals from the truth points, the
  // dataset's sun) to image 1.
  double view_rms_dn = 0.0;
  double explained_rms_dn = 0.0;  // hypot(noise, view)
  double ratio = 0.0;             // residual / explained
  std::string why;                // not empty: the ROI could not be checked, and why
};

// The photometric check of `boxes` (with their ids) of frame1 against frame2.
// Needs the images, the truth points of both frames, the truth navigation
// and truth.imaging. Throws InputError naming what is missing.
std::vector<PhotometricRoi> PhotometricResidual(const Dataset& dataset, int frame1, int frame2,
                                                const std::vector<std::pair<int, cv::Rect>>& boxes);

// Match error against truth: each match's image-1 position, through the
// truth point there (bilinear between the four truth points around it, left
// out where they are more than two footprints apart: an edge) and the true
// pose of frame 2, against its image-2 position.
struct MatchErrors {
  int matches = 0;                  // matches given
  int compared = 0;                 // with a truth correspondence
  std::vector<Eigen::Vector2d> errors_px;  // image-2 position minus the truth, per compared match
  double robust_sigma_x_px = 0.0;   // 1.4826 * median absolute deviation, along image x
  double robust_sigma_y_px = 0.0;
};
MatchErrors MatchErrorsAgainstTruth(const Dataset& dataset, int frame1, int frame2,
                                    const std::vector<Eigen::Vector2d>& points1_px,
                                    const std::vector<Eigen::Vector2d>& points2_px);

// The edge-spread check: a flat plane with a straight albedo step slanted
// 5 deg to the image columns, seen from nadir by a 96 x 96 pinhole camera,
// rendered with `options` (noise off, 16-bit, sun 60 deg up) and divided by
// the same plane of uniform albedo; the step's profile, binned at 0.1 px of
// distance from the edge within 3 px, against the pixel response the options
// configure (aperture sqrt(fill_factor), Gaussian PsfSigmaPx()).
struct EdgeSpreadBin {
  double distance_px = 0.0;
  int pixels = 0;
  double measured = 0.0;  // 0 on the dark side, 1 on the bright side
  double expected = 0.0;
};
struct EdgeSpreadCheck {
  std::vector<EdgeSpreadBin> bins;  // bins with at least 5 pixels
  double max_error = 0.0;           // largest |measured - expected|, fraction of the step
  double width_10_90_px = 0.0;      // measured 10-90 % rise distance
  double expected_width_10_90_px = 0.0;
};
EdgeSpreadCheck CheckEdgeSpread(const RenderOptions& options);

}  // namespace hdabench::datasets::synth
