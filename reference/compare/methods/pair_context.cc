// PairContext: the pair's geometry, and what the methods ask for computed
// once when first asked: the matches without navigation (and the pair's
// configuration from them), and COLMAP's run alongside the other methods.
#include <algorithm>
#include <exception>
#include <mutex>
#include <optional>

#include "hda/geometry.h"
#include "hda/matching.h"
#include "reference/compare/methods/method_support.h"
#include "tools/util/error.h"

namespace hdabench::reference {

namespace {

using methods::Bearings;
using methods::PoolPairMatches;

constexpr int kDenseOrbFeaturesPerRoi = 2000;
constexpr int kDenseOrbFastThreshold = 5;

// Each box pair's matches (image-1 box, image-2 search box; a pair without a
// search box gets none): the flight matcher, RANSAC inliers, without the
// nav-aided refinement, which maps each window through the motion the nav
// pose predicts, so that the relative-pose solvers see matches that owe
// nothing to navigation beyond the search boxes (Lucas-Kanade only).
std::vector<RoiBearings> MatchBoxes(const std::vector<std::pair<cv::Rect, cv::Rect>>& boxes,
                                    const CompareOptions& options, const PairContext& ctx) {
  std::vector<RoiBearings> all(boxes.size());
  hda::MatchingOptions matching = options.hda.options.matching;
  matching.warp_refine = false;
  if (options.opengv_dense_features) {
    matching.orb_features_per_roi = kDenseOrbFeaturesPerRoi;
    matching.orb_fast_threshold = kDenseOrbFastThreshold;
  }
  // 16-bit images are converted once, not once per box.
  const cv::Mat image1 = hda::ToEightBit(ctx.input().image1, "image 1");
  const cv::Mat image2 = hda::ToEightBit(ctx.input().image2, "image 2");
  for (size_t i = 0; i < all.size(); ++i) {
    const auto& [box1, box2] = boxes[i];
    if (box2.area() <= 0) continue;
    all[i].has_box = true;
    const hda::RoiMatches matches =
        hda::MatchRoiPair(image1, image2, box1, box2, ctx.dataset().camera, matching);
    std::vector<unsigned char> valid1, valid2;
    const std::vector<Eigen::Vector3d> b1 = Bearings(ctx.dataset().camera, matches.points1_px, &valid1);
    const std::vector<Eigen::Vector3d> b2 = Bearings(ctx.dataset().camera, matches.points2_px, &valid2);
    for (size_t k = 0; k < b1.size(); ++k) {
      if (valid1[k] == 0 || valid2[k] == 0) continue;
      all[i].pixels1.push_back(matches.points1_px[k]);
      all[i].bearings1.push_back(b1[k]);
      all[i].bearings2.push_back(b2[k]);
    }
  }
  return all;
}

// The ROIs' matches on the flight's boxes.
std::vector<RoiBearings> MatchAllRois(const FlightRun& flight, const CompareOptions& options,
                                      const PairContext& ctx) {
  std::vector<std::pair<cv::Rect, cv::Rect>> boxes;
  for (const hda::RoiResult& r : flight.result.rois) boxes.emplace_back(r.box1_px, r.box2_px);
  return MatchBoxes(boxes, options, ctx);
}

// The matches of the tiles over the rest of the overlap (OverlapTiles), each
// tile's search box in image 2 predicted as the flight method predicts an
// ROI's (hda::PredictSearchBoxes, its options as resolved for the pair).
// *num_tiles: the tiles laid.
std::vector<RoiBearings> MatchOverlapTiles(const FlightRun& flight, const CompareOptions& options,
                                           const PairContext& ctx, int* num_tiles) {
  std::vector<cv::Rect> roi_boxes;
  for (const hda::RoiResult& r : flight.result.rois) roi_boxes.push_back(r.box1_px);
  const std::vector<cv::Rect> tiles =
      OverlapTiles(ctx.input().image1.cols, ctx.input().image1.rows, roi_boxes, options.opengv_overlap_tiles);
  *num_tiles = static_cast<int>(tiles.size());
  if (tiles.empty()) return {};
  const std::vector<cv::Rect> boxes2 =
      hda::PredictSearchBoxes(ctx.input(), ctx.dataset().camera, flight.options, tiles);
  std::vector<std::pair<cv::Rect, cv::Rect>> boxes;
  for (size_t i = 0; i < tiles.size(); ++i) boxes.emplace_back(tiles[i], boxes2[i]);
  return MatchBoxes(boxes, options, ctx);
}

// The smallest side of the flight method's ROI boxes in image 1, pixels; 0
// without ROIs.
double SmallestRoiSidePx(const FlightRun& flight) {
  int side = 0;
  for (const auto& roi : flight.result.rois) {
    const int s = std::min(roi.box1_px.width, roi.box1_px.height);
    if (s > 0 && (side == 0 || s < side)) side = s;
  }
  return side;
}

// colmap-nav and colmap-free (whichever are wanted) in one COLMAP run: the
// pair first, then, with use_all_frames, every other frame of the window that
// has an image.
ColmapResults RunColmapMethods(const datasets::Dataset& dataset, int frame1, int frame2,
                               const CompareOptions& options, bool nav, bool free,
                               double smallest_roi_px, const std::string& workspace) {
  if (dataset.dir.empty()) {
    throw InputError("colmap needs the dataset's image files: the dataset has no folder");
  }
  std::vector<int> frames = {frame1, frame2};
  if (options.colmap.use_all_frames) {
    for (const int f : datasets::FramesWithImages(dataset.frames)) {
      if (f != frame1 && f != frame2) frames.push_back(f);
    }
  }
  ColmapInput input;
  for (const int f : frames) {
    input.image_paths.push_back(dataset.dir + "/" + dataset.frames[static_cast<size_t>(f)].image_path);
    input.local_from_cam.push_back(dataset.CamFromLocal(f).Inverse());
  }
  input.camera = dataset.camera;
  input.workspace = workspace;
  input.smallest_roi_px = smallest_roi_px;
  ColmapOptions colmap = options.colmap;
  colmap.run_nav = nav;
  colmap.run_free = free;
  return RunColmap(input, colmap);
}

}  // namespace

// What is computed when first asked for, with what its computation threw.
struct PairContext::Lazy {
  std::once_flag matches_once;
  PairMatches matches;
  ConfigurationReport configuration;
  std::exception_ptr matches_error;
  std::shared_future<ColmapResults> colmap;
};

PairContext::PairContext(const datasets::Dataset& dataset, int frame1, int frame2, const CompareOptions& options,
                         const CompareProgress& progress)
    : dataset_(&dataset), frame1_(frame1), frame2_(frame2), options_(&options), progress_(progress),
      lazy_(std::make_unique<Lazy>()) {
  input_ = MakeHdaInput(dataset, frame1, frame2);
  local_from_cam2_ = input_.local_from_cam1 * input_.cam2_from_cam1.Inverse();
  try {
    true_cam2_from_cam1_ = dataset.TrueCam2FromCam1(frame1, frame2);
    has_true_pose_ = !dataset.truth.navigation.empty();
  } catch (const std::exception&) {
    has_true_pose_ = false;
  }
  focal_px_ = hda::PixelsPerRadian(
      dataset.camera,
      Eigen::Vector2d(0.5 * (dataset.camera.WidthPx() - 1), 0.5 * (dataset.camera.HeightPx() - 1)));
  if (!(focal_px_ > 0.0)) throw InputError("the camera cannot project around its image centre");
}

// A future of std::async waits for its task when destroyed: COLMAP never
// runs on freed inputs, whatever was thrown.
PairContext::~PairContext() = default;

void PairContext::Say(const std::string& message) const {
  if (progress_) progress_(message);
}

const PairMatches& PairContext::Matches() const {
  std::call_once(lazy_->matches_once, [this] {
    Say("matching the ROIs and the overlap without navigation (OpenGV, the pair's configuration)");
    try {
      lazy_->matches.rois = MatchAllRois(flight(), options(), *this);
      lazy_->matches.overlap = MatchOverlapTiles(flight(), options(), *this, &lazy_->matches.overlap_tiles);
      if (!lazy_->matches.empty()) {
        std::vector<Eigen::Vector3d> b1, b2;
        PoolPairMatches(lazy_->matches, &b1, &b2);
        lazy_->configuration =
            ClassifyConfiguration(b1, b2, input_.cam2_from_cam1, focal_px_, options().opengv);
      }
    } catch (...) {
      lazy_->matches_error = std::current_exception();
    }
  });
  if (lazy_->matches_error) std::rethrow_exception(lazy_->matches_error);
  return lazy_->matches;
}

const ConfigurationReport& PairContext::PairConfiguration() const {
  Matches();
  return lazy_->configuration;
}

void PairContext::StartColmap(bool nav, bool free, const std::string& workspace) {
  Say("colmap: SIFT, matching, reconstruction in " + workspace + " (alongside the other methods)");
  const double smallest_roi_px = SmallestRoiSidePx(flight());
  lazy_->colmap = std::async(std::launch::async, [this, nav, free, smallest_roi_px, workspace] {
                    return RunColmapMethods(dataset(), frame1_, frame2_, options(), nav, free, smallest_roi_px,
                                            workspace);
                  }).share();
}

const ColmapResults& PairContext::Colmap() const {
  if (!lazy_->colmap.valid()) throw InputError("COLMAP was not started for this comparison");
  return lazy_->colmap.get();
}

}  // namespace hdabench::reference
