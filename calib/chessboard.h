// Chessboard corner detection for camera calibration, and mrcal's corners.vnl.
//
// Two detectors: mrgingham (the finder mrcal's own tools use; square N x N
// boards only) and OpenCV's cv::findChessboardCorners followed by
// cv::cornerSubPix (any W x H board). kAuto takes mrgingham for square boards
// and OpenCV otherwise. Corners come out row-major in mrcal's pixel convention
// (centre of the top-left pixel at (0,0), which both detectors use): `width`
// corners per row, `height` rows, as mrcal's --object-width-n and
// --object-height-n describe the board.
//
// Ordering. OpenCV may report a W x H board's corners (W != H) in either of
// two orders, a half turn apart. A camera pair's joint calibration needs both
// cameras to number one board alike, so the bench fixes the order: when
// W + H is odd the board's two ends differ in colour (the inner squares at
// the first and the last corner are one dark, one light), and the dark end
// comes first; when W + H is even the board looks the same after a half turn
// and the first corner is the one nearer the image's top-left (smaller x + y).
// mrgingham's order is kept as it reports it (the order mrcal's tools use).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

namespace hdabench::calib {

enum class CornerDetector { kAuto, kOpenCv, kMrgingham };

// "auto", "opencv", "mrgingham".
std::string CornerDetectorName(CornerDetector detector);
// The inverse; throws InputError listing the names when `name` is none of them.
CornerDetector ParseCornerDetector(const std::string& name);

// A planar chessboard: `width` x `height` inner corners (OpenCV's patternSize,
// mrcal's object-width-n x object-height-n), `spacing` between neighbouring
// corners in the user's length unit (metres, or squares).
struct ChessboardSpec {
  int width = 0;
  int height = 0;
  double spacing = 0.0;

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
  // "9x6".
  std::string SizeText() const;
};

// The result of looking for the board in one image.
struct CornerDetection {
  bool found = false;
  // Why the board was not found (empty when found).
  std::string reason;
  // The detector that produced the corners ("opencv" or "mrgingham").
  std::string detector;
  // width * height corners, row-major, in pixels (mrcal's convention).
  std::vector<Eigen::Vector2d> corners;
  // Per corner, the image-pyramid level it was found at (0: full resolution).
  // mrcal weights a corner by 0.5^level.
  std::vector<int> levels;
};

// Looks for the board in an 8-bit grey image (CV_8UC1). Never throws for an
// image without the board: found = false with the reason. Throws InputError
// when the image is empty or not 8-bit grey, or the spec is invalid, or
// kMrgingham is asked for a non-square board.
CornerDetection DetectChessboard(const cv::Mat& gray, const ChessboardSpec& board,
                                 CornerDetector detector);

// One row of corners.vnl: the name mrcal knows the image by, and its detection
// (a detection without the board is written as "name - - -", as mrcal expects).
struct CornersVnlEntry {
  std::string name;
  const CornerDetection* detection = nullptr;
};

// mrcal's corners cache ("# filename x y level", one row per corner). Names
// must not contain whitespace (InputError otherwise). Coordinates are printed
// with 17 significant digits, so nothing is lost.
std::string CornersVnlText(const std::vector<CornersVnlEntry>& entries);

}  // namespace hdabench::calib
