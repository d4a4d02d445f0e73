#include "calib/chessboard.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <mrgingham/mrgingham.hh>

#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/shared_library.h"

namespace hdabench::calib {

namespace {

// Half-size of cornerSubPix's search window from the smallest distance between
// neighbouring corners: about a third of a square, so the window holds the
// corner's four squares but not the next corners; 3..11 px.
int SubPixelHalfWindow(const std::vector<cv::Point2f>& corners, int width, int height) {
  double smallest = 1e30;
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const cv::Point2f& p = corners[r * width + c];
      if (c + 1 < width) smallest = std::min(smallest, cv::norm(corners[r * width + c + 1] - p));
      if (r + 1 < height) smallest = std::min(smallest, cv::norm(corners[(r + 1) * width + c] - p));
    }
  }
  return std::clamp(static_cast<int>(std::lround(smallest / 3.0)), 3, 11);
}

// Mean grey level over a small disc at the centre of the square between
// corners a, b, c, d (its four corners).
double SquareBrightness(const cv::Mat& gray, const cv::Point2f& a, const cv::Point2f& b,
                        const cv::Point2f& c, const cv::Point2f& d) {
  const cv::Point2f centre = 0.25f * (a + b + c + d);
  const double side = 0.5 * (cv::norm(b - a) + cv::norm(d - c));
  const int radius = std::max(1, static_cast<int>(side / 5.0));
  double sum = 0.0;
  int count = 0;
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      if (dx * dx + dy * dy > radius * radius) continue;
      const int x = static_cast<int>(std::lround(centre.x)) + dx;
      const int y = static_cast<int>(std::lround(centre.y)) + dy;
      if (x < 0 || y < 0 || x >= gray.cols || y >= gray.rows) continue;
      sum += gray.at<unsigned char>(y, x);
      ++count;
    }
  }
  return count > 0 ? sum / count : 0.0;
}

// Whether to reverse OpenCV's corner order (see the header, "Ordering"). When
// width + height is odd, the first and the last inner square of the board
// differ in colour, so the board's own pattern says which end is which: the
// bench puts the end with the dark square first, whatever the view. When the
// board is symmetric under a half turn, the image position decides: the first
// corner nearer the image's top-left.
bool ShouldReverse(const cv::Mat& gray, const std::vector<cv::Point2f>& corners, int width) {
  const int n = static_cast<int>(corners.size());
  const int height = n / width;
  if ((width + height) % 2 == 1) {
    const double first = SquareBrightness(gray, corners[0], corners[1], corners[width],
                                          corners[width + 1]);
    const double last = SquareBrightness(gray, corners[n - 1], corners[n - 2],
                                         corners[n - 1 - width], corners[n - 2 - width]);
    // A clear difference only; a washed-out image falls back to the position.
    if (std::abs(first - last) > 20.0) return first > last;
  }
  const cv::Point2f& a = corners.front();
  const cv::Point2f& z = corners.back();
  return a.x + a.y > z.x + z.y;
}

CornerDetection DetectWithOpenCv(const cv::Mat& gray, const ChessboardSpec& board) {
  CornerDetection result;
  result.detector = "opencv";
  std::vector<cv::Point2f> corners;
  const bool found = cv::findChessboardCorners(
      gray, cv::Size(board.width, board.height), corners,
      cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
  if (!found || corners.size() != static_cast<size_t>(board.width * board.height)) {
    result.reason = "no " + board.SizeText() + " chessboard found (OpenCV's detector)";
    return result;
  }
  const int half = SubPixelHalfWindow(corners, board.width, board.height);
  cv::cornerSubPix(gray, corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.001));
  if (ShouldReverse(gray, corners, board.width)) std::reverse(corners.begin(), corners.end());
  for (const cv::Point2f& p : corners) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) {
      result.reason = "the sub-pixel refinement gave a non-finite corner";
      return result;
    }
    result.corners.emplace_back(p.x, p.y);
  }
  result.levels.assign(result.corners.size(), 0);
  result.found = true;
  return result;
}

// mrgingham::find_chessboard_from_image_array, from libmrgingham loaded on the
// first call, by the name calib/CMakeLists.txt gives and checks the library
// defines. The cast compiles only if mrgingham.hh declares a function of this
// type (an unevaluated operand: nothing here links the library).
using FindChessboardFn = int (*)(std::vector<mrgingham::PointDouble>&, signed char**, int, const cv::Mat&, int,
                                 bool, mrgingham::debug_sequence_t, const char*);
static_assert(sizeof(static_cast<FindChessboardFn>(&mrgingham::find_chessboard_from_image_array)) > 0,
              "mrgingham::find_chessboard_from_image_array's declaration changed");
constexpr const char* kFindChessboardSymbol = HDABENCH_MRGINGHAM_FIND_CHESSBOARD_SYMBOL;

FindChessboardFn FindChessboardWithMrgingham() {
  static const FindChessboardFn find = [] {
    void* library = util::LoadSharedLibrary(HDABENCH_MRGINGHAM_SONAME, "mrgingham, the chessboard corner finder");
    return util::SharedLibraryFunction<FindChessboardFn>(library, HDABENCH_MRGINGHAM_SONAME, kFindChessboardSymbol,
                                                         "mrgingham::find_chessboard_from_image_array");
  }();
  return find;
}

CornerDetection DetectWithMrgingham(const cv::Mat& gray, const ChessboardSpec& board) {
  CornerDetection result;
  result.detector = "mrgingham";
  std::vector<mrgingham::PointDouble> points;
  signed char* levels = nullptr;
  // A negative pyramid level lets mrgingham try several image scales.
  const int level = FindChessboardWithMrgingham()(points, &levels, board.width, gray, -1, false,
                                                  mrgingham::debug_sequence_t(), nullptr);
  const size_t expected = static_cast<size_t>(board.width) * board.height;
  if (level < 0 || points.size() != expected) {
    std::free(levels);
    result.reason = "no " + board.SizeText() + " chessboard found (mrgingham)";
    return result;
  }
  for (size_t i = 0; i < points.size(); ++i) {
    if (!std::isfinite(points[i].x) || !std::isfinite(points[i].y)) {
      std::free(levels);
      result.reason = "mrgingham gave a non-finite corner";
      result.corners.clear();
      result.levels.clear();
      return result;
    }
    result.corners.emplace_back(points[i].x, points[i].y);
    result.levels.push_back(levels != nullptr ? levels[i] : level);
  }
  std::free(levels);
  result.found = true;
  return result;
}

}  // namespace

std::string CornerDetectorName(CornerDetector detector) {
  switch (detector) {
    case CornerDetector::kAuto: return "auto";
    case CornerDetector::kOpenCv: return "opencv";
    case CornerDetector::kMrgingham: return "mrgingham";
  }
  return "auto";
}

CornerDetector ParseCornerDetector(const std::string& name) {
  for (CornerDetector d : {CornerDetector::kAuto, CornerDetector::kOpenCv, CornerDetector::kMrgingham}) {
    if (CornerDetectorName(d) == name) return d;
  }
  throw InputError("corner detector '" + name + "': expected auto, opencv or mrgingham");
}

std::vector<std::string> ChessboardSpec::Validate() const {
  std::vector<std::string> errors;
  RequireOption(width >= 2, "board width", width, "at least 2 inner corners", &errors);
  RequireOption(height >= 2, "board height", height, "at least 2 inner corners", &errors);
  RequireOption(spacing > 0.0, "board spacing", spacing, "a positive corner spacing", &errors);
  return errors;
}

std::string ChessboardSpec::SizeText() const {
  return std::to_string(width) + "x" + std::to_string(height);
}

CornerDetection DetectChessboard(const cv::Mat& gray, const ChessboardSpec& board,
                                 CornerDetector detector) {
  const std::vector<std::string> errors = board.Validate();
  if (!errors.empty()) throw InputError("DetectChessboard: " + errors.front());
  if (gray.empty() || gray.type() != CV_8UC1) {
    throw InputError("DetectChessboard: expected a non-empty 8-bit grey image");
  }
  if (detector == CornerDetector::kMrgingham && board.width != board.height) {
    throw InputError("the mrgingham detector finds square N x N boards only; the board is " +
                     board.SizeText() + " (use the opencv detector)");
  }
  const bool square = board.width == board.height;
  if (detector == CornerDetector::kMrgingham ||
      (detector == CornerDetector::kAuto && square)) {
    return DetectWithMrgingham(gray, board);
  }
  return DetectWithOpenCv(gray, board);
}

std::string CornersVnlText(const std::vector<CornersVnlEntry>& entries) {
  std::ostringstream out;
  out << "# filename x y level\n";
  char number[64];
  for (const CornersVnlEntry& entry : entries) {
    if (entry.name.empty() ||
        entry.name.find_first_of(" \t\r\n") != std::string::npos) {
      throw InputError("corners.vnl: image name '" + entry.name +
                       "' is empty or holds whitespace, which the format cannot carry");
    }
    if (entry.detection == nullptr || !entry.detection->found) {
      out << entry.name << " - - -\n";
      continue;
    }
    const CornerDetection& d = *entry.detection;
    for (size_t i = 0; i < d.corners.size(); ++i) {
      std::snprintf(number, sizeof(number), "%.17g %.17g", d.corners[i].x(), d.corners[i].y());
      out << entry.name << ' ' << number << ' ' << (i < d.levels.size() ? d.levels[i] : 0) << '\n';
    }
  }
  return out.str();
}

}  // namespace hdabench::calib
