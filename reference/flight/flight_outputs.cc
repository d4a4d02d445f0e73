#include "reference/flight/flight_outputs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <regex>
#include <set>
#include <sstream>
#include <system_error>
#include <utility>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "tools/images/png.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/util/parallel_for.h"
#include "tools/util/text.h"
#include "tools/util/statistics.h"

namespace hdabench::reference {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

// A double as JSON, null when it is not finite (JSON has no NaN or infinity).
Json Number(double value) { return std::isfinite(value) ? Json(value) : Json(nullptr); }
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// hda::RoiStatus values are 0 .. kNotEvaluated.
constexpr size_t kNumStatuses = static_cast<size_t>(hda::RoiStatus::kNotEvaluated) + 1;

// ---------------------------------------------------------------------------
// Numbers and text



Json BoxJson(const cv::Rect& box) { return Json::array({box.x, box.y, box.width, box.height}); }

Json Vector3Json(const Eigen::Vector3d& v) {
  return Json::array({Number(v.x()), Number(v.y()), Number(v.z())});
}


bool HasBox2(const hda::RoiResult& roi) { return roi.box2_px.area() > 0; }

// The truth of ROI i, or nullptr when the run has none for it.
const RoiTruthValue* TruthOf(const FlightRun& run, size_t i) {
  if (i >= run.truths.size() || !run.truths[i].available) return nullptr;
  return &run.truths[i];
}

// Estimated minus true slope, degrees; NaN without a fit or truth.
double SlopeErrorDeg(const FlightRun& run, size_t i) {
  const hda::RoiResult& roi = run.result.rois[i];
  const RoiTruthValue* truth = TruthOf(run, i);
  if (!roi.has_fit || truth == nullptr) return kNaN;
  return roi.slope_deg - truth->slope_deg;
}

// Tilt error against the truth (TiltErrorDeg), degrees; NaN without a fit or
// truth.
double TiltErrorOf(const FlightRun& run, size_t i) {
  const hda::RoiResult& roi = run.result.rois[i];
  const RoiTruthValue* truth = TruthOf(run, i);
  if (!roi.has_fit || truth == nullptr) return kNaN;
  return TiltErrorDeg(roi.normal_in_local, truth->normal_in_local);
}

bool IsRanked(const hda::RoiResult& roi) { return roi.status == hda::RoiStatus::kEvaluated; }

std::string PlyName(const hda::RoiResult& roi) { return "points/" + RoiFileStem(roi.id) + ".ply"; }

// ---------------------------------------------------------------------------
// result.json

Json CountsJson(const hda::RoiCounts& c) {
  return {{"keypoints1", c.keypoints1},           {"keypoints2", c.keypoints2},
          {"matches", c.matches},                 {"refine_rejected", c.refine_rejected},
          {"ransac_inliers", c.ransac_inliers},   {"epipolar_inliers", c.epipolar_inliers},
          {"triangulated", c.triangulated},       {"depth_inliers", c.depth_inliers}};
}

Json FitJson(const FlightRun& run, size_t i) {
  const hda::RoiResult& roi = run.result.rois[i];
  if (!roi.has_fit) return nullptr;
  Json j;
  j["slope_deg"] = Number(roi.slope_deg);
  j["slope_sigma_deg"] = Number(roi.slope_sigma_deg);
  // The calibration's term (CalibrationTerm) and the two in quadrature: the
  // sigma the within-two-sigma share uses. Null terms where the run has none
  // (calibration_term says why) or this ROI has none (the reason beside it).
  j["slope_sigma_calibration_deg"] = Number(run.calibration.SlopeSigmaDeg(i));
  j["tilt_sigma_calibration_deg"] = Number(run.calibration.TiltSigmaDeg(i));
  if (run.calibration.available && i < run.calibration.rois.size() && !run.calibration.rois[i].available) {
    j["calibration_sigma_why"] = run.calibration.rois[i].why;
  }
  j["slope_sigma_combined_deg"] = Number(run.CombinedSlopeSigmaDeg(i));
  j["sigma_terms"] = {{"pixel_deg", Number(roi.slope_sigma_terms.pixel_deg)},
                      {"baseline_deg", Number(roi.slope_sigma_terms.baseline_deg)},
                      {"attitude_deg", Number(roi.slope_sigma_terms.attitude_deg)},
                      {"lean_deg", Number(roi.slope_sigma_terms.lean_deg)}};
  j["pixel_sigma_px"] = Number(roi.pixel_sigma_px);
  j["roughness_rms_m"] = Number(roi.roughness_rms_m);
  j["roughness_max_m"] = Number(roi.roughness_max_m);
  j["noise_rms_m"] = Number(roi.noise_rms_m);
  j["roughness_excess_m"] = Number(roi.roughness_excess_m);
  j["probability_safe"] = Number(roi.probability_safe);
  j["median_parallax_deg"] = Number(roi.median_parallax_deg);
  j["area_m2"] = Number(roi.area_m2);
  j["normal_in_local"] = Vector3Json(roi.normal_in_local);
  j["centroid_in_local_m"] = Vector3Json(roi.centroid_in_local_m);
  return j;
}

Json TruthJson(const FlightRun& run, size_t i) {
  if (const RoiTruthValue* t = TruthOf(run, i)) {
    return {{"available", true},
            {"slope_deg", Number(t->slope_deg)},
            {"roughness_rms_m", Number(t->roughness_rms_m)},
            {"roughness_max_m", Number(t->roughness_max_m)},
            {"hazard_height_m", Number(t->hazard_height_m)},
            {"max_rock_height_m", Number(t->max_rock_height_m)},
            {"normal", Vector3Json(t->normal_in_local)},
            {"num_points", t->num_points},
            {"landing", LandingJson(t->landing)}};
  }
  const std::string why = i < run.truths.size() ? run.truths[i].why : "the run has no truth";
  return {{"available", false}, {"why", why}};
}

// The flight computer's predicted time (hda/work_model.h): per stage, in
// all, and the counted work it comes from.
Json FlightComputerJson(const hda::HdaResult& result) {
  Json stages = Json::object();
  for (int s = 0; s < hda::kNumStages; ++s) {
    const auto stage = static_cast<hda::Stage>(s);
    stages[std::string(hda::ToString(stage)) + "_s"] = Number(result.FlightSeconds(stage));
  }
  Json work = Json::object();
  for (int u = 0; u < hda::kNumWorkUnits; ++u) {
    const auto unit = static_cast<hda::WorkUnit>(u);
    work[hda::ToString(unit)] = result.work[unit];
  }
  return {{"instructions_per_s", Number(result.flight_instructions_per_s)},
          {"total_s", Number(result.FlightSeconds())},
          {"stages", stages},
          {"work", work}};
}

Json RoiJson(const FlightRun& run, size_t i) {
  const hda::RoiResult& roi = run.result.rois[i];
  Json j;
  j["id"] = roi.id;
  j["status"] = hda::ToString(roi.status);
  j["reason"] = roi.reason;
  j["box1"] = BoxJson(roi.box1_px);
  j["box2"] = HasBox2(roi) ? BoxJson(roi.box2_px) : Json(nullptr);
  j["prediction_margin_px"] = HasBox2(roi) ? Number(roi.prediction_margin_px) : Json(nullptr);
  j["order"] = roi.order;
  j["ils_distance_m"] = Number(roi.ils_distance_m);
  const auto& quadtree_rois = run.result.quadtree.rois;
  const auto block = std::find_if(quadtree_rois.begin(), quadtree_rois.end(),
                                  [&](const hda::Roi& r) { return r.id == roi.id; });
  j["mean_dn"] = block == quadtree_rois.end() ? Json(nullptr) : Number(block->mean_dn);
  j["stddev_dn"] = block == quadtree_rois.end() ? Json(nullptr) : Number(block->stddev_dn);
  j["counts"] = CountsJson(roi.counts);
  j["matching_status"] = roi.matched ? Json(hda::ToString(roi.matching_status)) : Json(nullptr);
  j["prewarped"] = roi.matched ? Json(roi.prewarped) : Json(nullptr);
  j["flight_computer_s"] = Number(run.result.FlightSeconds(roi.work));
  j["fit"] = FitJson(run, i);
  j["score"] = IsRanked(roi) ? Number(roi.score) : Json(nullptr);
  j["rank"] = roi.rank > 0 ? Json(roi.rank) : Json(nullptr);
  j["truth"] = TruthJson(run, i);
  j["slope_error_deg"] = Number(SlopeErrorDeg(run, i));
  j["tilt_error_deg"] = Number(TiltErrorOf(run, i));
  j["ply"] = roi.points_in_local_m.empty() ? Json(nullptr) : Json(PlyName(roi));
  return j;
}

// ---------------------------------------------------------------------------
// The text table



// ---------------------------------------------------------------------------
// Figures

using Colour = cv::Scalar;  // BGR

const Colour kBlack(0, 0, 0);
const Colour kWhite(255, 255, 255);
const Colour kRejectedBlock(110, 60, 30);

// Colour of each hda::RoiStatus, in the enum's order: green evaluated, orange
// unsafe slope, yellow unsafe roughness, red degenerate, greys (light to dark)
// too few points, not in image 2, not evaluated.
Colour StatusColour(hda::RoiStatus status) {
  static const Colour kColours[] = {Colour(0, 210, 0),     Colour(0, 140, 255),
                                    Colour(0, 230, 255),   Colour(40, 40, 255),
                                    Colour(200, 200, 200), Colour(150, 150, 150),
                                    Colour(105, 105, 105)};
  static_assert(sizeof(kColours) / sizeof(kColours[0]) == kNumStatuses);
  return kColours[static_cast<size_t>(status)];
}

// Distinct bright colours for ROIs and matches.
Colour PaletteColour(size_t i) {
  static const Colour kPalette[] = {
      Colour(0, 255, 0),   Colour(255, 128, 0), Colour(0, 200, 255), Colour(255, 0, 255),
      Colour(0, 128, 255), Colour(255, 255, 0), Colour(128, 0, 255), Colour(0, 255, 170),
      Colour(80, 80, 255), Colour(255, 0, 128), Colour(160, 255, 0), Colour(255, 170, 170)};
  return kPalette[i % (sizeof(kPalette) / sizeof(kPalette[0]))];
}

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

// Text with a dark outline so that it reads on any background; `origin` is the
// bottom-left of the text.
void DrawText(cv::Mat* canvas, const std::string& text, cv::Point origin, double scale,
              const Colour& colour) {
  const int thickness = std::max(1, static_cast<int>(std::lround(scale * 1.6)));
  cv::putText(*canvas, text, origin, kFont, scale, kBlack, thickness + 2, cv::LINE_AA);
  cv::putText(*canvas, text, origin, kFont, scale, colour, thickness, cv::LINE_AA);
}

int TextHeight(double scale) {
  int baseline = 0;
  return cv::getTextSize("0", kFont, scale, 1, &baseline).height;
}

// A box (canvas pixels) with its label inside the top-left corner.
void DrawLabelledBox(cv::Mat* canvas, const cv::Rect& box, const Colour& colour, int thickness,
                     const std::string& label, double text_scale) {
  cv::rectangle(*canvas, box, colour, thickness, cv::LINE_8);
  if (label.empty()) return;
  const int pad = thickness + 2;
  DrawText(canvas, label, cv::Point(box.x + pad, box.y + pad + TextHeight(text_scale)), text_scale,
           colour);
}

// Where a crop of an image lands on a canvas: canvas = offset + scale * (image - crop corner).
struct Panel {
  cv::Rect crop;        // image pixels shown
  double scale = 1.0;   // canvas pixels per image pixel
  cv::Point offset;     // canvas position of the crop's top-left corner
  cv::Size CanvasSize() const {
    return cv::Size(static_cast<int>(std::lround(crop.width * scale)),
                    static_cast<int>(std::lround(crop.height * scale)));
  }
  // A pixel centre (docs/conventions.md: pixel (x, y) covers x +- 0.5).
  cv::Point2d Map(const cv::Point2d& p) const {
    return cv::Point2d(offset.x + (p.x - crop.x + 0.5) * scale - 0.5,
                       offset.y + (p.y - crop.y + 0.5) * scale - 0.5);
  }
  // The canvas pixels covering a box of image pixels.
  cv::Rect Map(const cv::Rect& box) const {
    const int x0 = offset.x + static_cast<int>(std::lround((box.x - crop.x) * scale));
    const int y0 = offset.y + static_cast<int>(std::lround((box.y - crop.y) * scale));
    const int x1 = offset.x + static_cast<int>(std::lround((box.br().x - crop.x) * scale));
    const int y1 = offset.y + static_cast<int>(std::lround((box.br().y - crop.y) * scale));
    return cv::Rect(x0, y0, std::max(1, x1 - x0), std::max(1, y1 - y0));
  }
};

cv::Mat ToBgr(const cv::Mat& image) {
  if (image.type() == CV_8UC3) return image;  // converted already (WriteFlightOutputs)
  cv::Mat bgr;
  cv::cvtColor(hda::ToEightBit(image, "figure image"), bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

// Copies the panel's crop of `bgr` onto the canvas, scaled (nearest
// neighbour when enlarging, area averaging when shrinking).
void PastePanel(const cv::Mat& bgr, const Panel& panel, cv::Mat* canvas) {
  cv::Mat scaled;
  cv::resize(bgr(panel.crop), scaled, panel.CanvasSize(), 0, 0,
             panel.scale >= 1.0 ? cv::INTER_NEAREST : cv::INTER_AREA);
  scaled.copyTo((*canvas)(cv::Rect(panel.offset, scaled.size())));
}

// Match i drawn as a point in each panel joined by a line, in colour_of(i);
// the lines blended over the canvas with `line_opacity` in (0, 1].
void DrawMatchLines(cv::Mat* canvas, const Panel& panel1, const Panel& panel2,
                    const std::vector<cv::Point2d>& points1, const std::vector<cv::Point2d>& points2,
                    const std::function<Colour(size_t)>& colour_of, int radius,
                    double line_opacity) {
  const auto fixed = [](const cv::Point2d& p) {
    return cv::Point(static_cast<int>(std::lround(p.x)), static_cast<int>(std::lround(p.y)));
  };
  const size_t n = std::min(points1.size(), points2.size());
  cv::Mat lines = canvas->clone();
  for (size_t i = 0; i < n; ++i) {
    cv::line(lines, fixed(panel1.Map(points1[i])), fixed(panel2.Map(points2[i])), colour_of(i), 1,
             cv::LINE_AA);
  }
  cv::addWeighted(lines, line_opacity, *canvas, 1.0 - line_opacity, 0.0, *canvas);
  for (size_t i = 0; i < n; ++i) {
    for (const cv::Point p : {fixed(panel1.Map(points1[i])), fixed(panel2.Map(points2[i]))}) {
      cv::circle(*canvas, p, radius, colour_of(i), cv::FILLED, cv::LINE_AA);
    }
  }
}

// A strip `width` wide with the entries (colour swatch, label) laid out in
// rows.
cv::Mat LegendStrip(int width, const std::vector<std::pair<Colour, std::string>>& entries,
                    double scale) {
  const int text_h = TextHeight(scale);
  const int line_h = 2 * text_h;
  const int swatch = text_h;
  const int margin = text_h;
  std::vector<cv::Point> positions;
  cv::Point at(margin, margin);
  for (const auto& entry : entries) {
    int baseline = 0;
    const int entry_w = swatch + text_h / 2 + cv::getTextSize(entry.second, kFont, scale, 1, &baseline).width;
    if (at.x > margin && at.x + entry_w > width - margin) at = cv::Point(margin, at.y + line_h);
    positions.push_back(at);
    at.x += entry_w + 2 * text_h;
  }
  cv::Mat strip(at.y + line_h + margin / 2, width, CV_8UC3, Colour(32, 32, 32));
  for (size_t i = 0; i < entries.size(); ++i) {
    const cv::Point p = positions[i];
    cv::rectangle(strip, cv::Rect(p.x, p.y, swatch, swatch), entries[i].first, cv::FILLED);
    DrawText(&strip, entries[i].second, cv::Point(p.x + swatch + text_h / 2, p.y + swatch), scale,
             kWhite);
  }
  return strip;
}

// The height of TitleStrip's strip of `lines` lines at `scale`, when no line
// is too long to fit.
int TitleStripHeight(int lines, double scale) { return lines * 2 * TextHeight(scale) + TextHeight(scale); }

// A dark strip `width` wide with lines of text, shrunk to fit when too long.
cv::Mat TitleStrip(int width, const std::vector<std::string>& lines, double scale) {
  const int margin = TextHeight(scale);
  for (const std::string& line : lines) {
    int baseline = 0;
    const int text_w = cv::getTextSize(line, kFont, scale, 1, &baseline).width;
    if (text_w > width - 2 * margin) scale *= (width - 2.0 * margin) / text_w;
  }
  const int line_h = 2 * TextHeight(scale);
  cv::Mat strip(static_cast<int>(lines.size()) * line_h + margin, width, CV_8UC3,
                Colour(32, 32, 32));
  for (size_t i = 0; i < lines.size(); ++i) {
    DrawText(&strip, lines[i], cv::Point(margin, static_cast<int>(i + 1) * line_h), scale, kWhite);
  }
  return strip;
}

// zlib's fastest level: a quarter less time than level 3 for files about 5 %
// larger (the default scene's figures: 0.53 s against 0.68 s, 8.8 MB against
// 8.4 MB).
constexpr int kFigurePngCompression = 1;

// ---------------------------------------------------------------------------
// Files

void WriteText(const fs::path& dir, const std::string& relative, const std::string& bytes,
               std::vector<std::string>* written) {
  util::WriteFileAtomically(dir / relative, bytes);
  written->push_back(relative);
}

// Removes the per-ROI files ("roi_<digits><extension>") in `folder` that this
// run did not write.
void RemoveStaleRoiFiles(const fs::path& dir, const std::string& folder, const std::string& extension,
                         const std::vector<std::string>& written) {
  const std::set<std::string> keep(written.begin(), written.end());
  const std::regex pattern("roi_[0-9]+\\" + extension);
  std::error_code ec;
  if (!fs::is_directory(dir / folder, ec)) return;
  for (const auto& entry : fs::directory_iterator(dir / folder, ec)) {
    const std::string name = entry.path().filename().string();
    if (!std::regex_match(name, pattern) || keep.count(folder + "/" + name) > 0) continue;
    std::error_code ignored;
    fs::remove(entry.path(), ignored);
  }
}

}  // namespace

std::string RoiFileStem(int id) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "roi_%03d", id);
  return buffer;
}

// Whether the slopes' sigmas carry the calibration's term, and what it is
// made of: the modes of the model's uncertainty (calib/intrinsics_modes.h).
Json CalibrationTermJson(const CalibrationTerm& term) {
  if (!term.available) return {{"available", false}, {"why", term.why}};
  const calib::IntrinsicsModes& m = term.modes;
  Json modes = Json::array();
  for (const calib::IntrinsicsMode& mode : m.modes) {
    Json delta = Json::array();
    for (double d : mode.intrinsics_delta) delta.push_back(Number(d));
    modes.push_back({{"intrinsics_delta", delta},
                     {"rotation_rad", Vector3Json(mode.rotation_rad)},
                     {"projection_rms_px", Number(mode.projection_rms_px)}});
  }
  const auto with_sigma = std::count_if(term.rois.begin(), term.rois.end(),
                                        [](const hda::CalibrationSigma& s) { return s.available; });
  return {{"available", true},
          {"model", term.model_file},
          {"lens_model", m.lensmodel},
          {"noise_stdev_px", Number(m.noise_stdev_px)},
          {"imager_worst_stdev_median_px", Number(m.imager_worst_stdev_median_px)},
          {"compensated_worst_stdev_median_px", Number(m.compensated_worst_stdev_median_px)},
          {"variance_kept", Number(m.variance_kept)},
          {"mode_step_sigma", Number(hda::kCalibrationModeStep)},
          {"rois_with_sigma", with_sigma},
          {"modes", modes}};
}

std::string FlightResultJson(const FlightRun& run) {
  const hda::HdaResult& result = run.result;
  Json j;
  j["format"] = kFlightResultFormatName;
  j["format_version"] = kFlightResultFormatVersion;
  j["dataset"] = run.dataset_name;
  j["frames"] = Json::array({run.frame1, run.frame2});
  j["options"] = HdaOptionsJson(run.options);
  if (!run.derived_options.empty()) {
    Json derived = Json::array();
    for (const DerivedParam& d : run.derived_options) {
      derived.push_back({{"key", d.key}, {"value", Number(d.value)}, {"rule", d.rule}});
    }
    j["options_from_geometry"] = derived;
  }
  j["camera"] = {{"lens_model", run.lens_model},
                 {"width_px", run.image_width_px},
                 {"height_px", run.image_height_px}};
  j["inputs"] = {{"baseline_m", Number(run.baseline_m)}, {"lrf_range_m", Number(run.lrf_range_m)}};
  // Only when the range is not the LRF's, so that every other result keeps its bytes.
  if (run.range_source != RangeSource::kLrf) j["inputs"]["range_source"] = ToString(run.range_source);
  const hda::QuadtreeResult& q = result.quadtree;
  Json rejected = Json::array();
  for (const cv::Rect& box : q.rejected_boxes) rejected.push_back(BoxJson(box));
  j["quadtree"] = {{"min_block_px", q.min_block_px},
                   {"blocks_visited", q.blocks_visited},
                   {"num_rois", q.rois.size()},
                   {"rejected_dark", q.rejected_dark},
                   {"rejected_variable", q.rejected_variable},
                   {"rejected_small", q.rejected_small},
                   {"rejected_boxes", rejected}};
  if (run.given_rois) j["quadtree"]["given_rois"] = true;  // the ROIs were given, the quadtree not run
  j["budget_s"] = Number(result.budget_s);
  j["budget_exhausted"] = result.budget_exhausted;
  j["flight_computer"] = FlightComputerJson(result);
  j["calibration_term"] = CalibrationTermJson(run.calibration);
  Json status_counts = Json::object();
  for (size_t s = 0; s < kNumStatuses; ++s) {
    const auto status = static_cast<hda::RoiStatus>(s);
    status_counts[hda::ToString(status)] =
        std::count_if(result.rois.begin(), result.rois.end(),
                      [&](const hda::RoiResult& roi) { return roi.status == status; });
  }
  j["status_counts"] = status_counts;
  j["ranking"] = result.ranking;
  j["lander"] = LanderJson(run.lander);
  if (run.AnyTruth()) {
    j["decision"] = DecisionJson(ComputeFlightDecisions(run));
    const ProbabilityDecisions probability = ComputeProbabilityDecisions(run);
    Json rule = DecisionJson(probability.pool);
    rule["min_probability_safe"] = Number(run.options.min_probability_safe);
    rule["calibration"] = SafetyCalibrationJson(probability.calibration);
    j["decision"]["probability_rule"] = rule;
  }
  Json rois = Json::array();
  for (size_t i = 0; i < result.rois.size(); ++i) rois.push_back(RoiJson(run, i));
  j["rois"] = rois;
  return j.dump(2) + "\n";
}

std::string FlightTimingsJson(const FlightRun& run) {
  const hda::StageTimes& t = run.result.times;
  Json j;
  j["format"] = kFlightTimingsFormatName;
  j["format_version"] = kFlightResultFormatVersion;
  j["budget_s"] = Number(run.result.budget_s);
  j["budget_exhausted"] = run.result.budget_exhausted;
  j["flight_computer_s"] = Number(run.result.FlightSeconds());
  j["stages"] = {{"convert_s", Number(t.convert_s)},       {"quadtree_s", Number(t.quadtree_s)},
                 {"prediction_s", Number(t.prediction_s)}, {"matching_s", Number(t.matching_s)},
                 {"rejection_s", Number(t.rejection_s)},   {"plane_s", Number(t.plane_s)},
                 {"ranking_s", Number(t.ranking_s)},       {"total_s", Number(t.total_s)}};
  Json rois = Json::array();
  for (const hda::RoiResult& roi : run.result.rois) {
    rois.push_back({{"id", roi.id}, {"seconds", Number(roi.wall_s)}});
  }
  j["rois"] = rois;
  return j.dump(2) + "\n";
}

std::string FlightRoisCsv(const FlightRun& run) {
  std::ostringstream out;
  out << "id,status,x1,y1,w1,h1,x2,y2,w2,h2,order,keypoints1,keypoints2,matches,ransac_inliers,"
         "epipolar_inliers,triangulated,depth_inliers,slope_deg,slope_sigma_deg,roughness_rms_m,"
         "roughness_excess_m,area_m2,score,rank,truth_slope_deg,slope_error_deg,tilt_error_deg,"
         "slope_sigma_calibration_deg,slope_sigma_combined_deg\n";
  for (size_t i = 0; i < run.result.rois.size(); ++i) {
    const hda::RoiResult& roi = run.result.rois[i];
    const cv::Rect& b1 = roi.box1_px;
    const cv::Rect& b2 = roi.box2_px;
    out << roi.id << "," << hda::ToString(roi.status) << "," << b1.x << "," << b1.y << ","
        << b1.width << "," << b1.height << ",";
    if (HasBox2(roi)) {
      out << b2.x << "," << b2.y << "," << b2.width << "," << b2.height << ",";
    } else {
      out << ",,,,";
    }
    const hda::RoiCounts& c = roi.counts;
    out << roi.order << "," << c.keypoints1 << "," << c.keypoints2 << "," << c.matches << ","
        << c.ransac_inliers << "," << c.epipolar_inliers << "," << c.triangulated << ","
        << c.depth_inliers << ",";
    const auto fit_value = [&](double value) { return roi.has_fit ? util::CsvNumber(value) : ""; };
    out << fit_value(roi.slope_deg) << "," << fit_value(roi.slope_sigma_deg) << ","
        << fit_value(roi.roughness_rms_m) << "," << fit_value(roi.roughness_excess_m) << ","
        << fit_value(roi.area_m2) << ",";
    out << (IsRanked(roi) ? util::CsvNumber(roi.score) : "") << ","
        << (roi.rank > 0 ? std::to_string(roi.rank) : "") << ",";
    const RoiTruthValue* truth = TruthOf(run, i);
    out << (truth != nullptr ? util::CsvNumber(truth->slope_deg) : "") << ","
        << util::CsvNumber(SlopeErrorDeg(run, i)) << "," << util::CsvNumber(TiltErrorOf(run, i)) << ","
        << fit_value(run.calibration.SlopeSigmaDeg(i)) << "," << fit_value(run.CombinedSlopeSigmaDeg(i)) << "\n";
  }
  return out.str();
}

std::string RoiPly(const hda::RoiResult& roi) {
  const size_t n = roi.points_in_local_m.size();
  std::ostringstream out;
  out << "ply\nformat ascii 1.0\n"
      << "comment hdabench flight ROI " << roi.id
      << ": x y z in the local frame (ENU, metres), u1 v1 the image-1 pixel\n"
      << "element vertex " << n << "\n"
      << "property double x\nproperty double y\nproperty double z\n"
      << "property double u1\nproperty double v1\nend_header\n";
  // PLY has no null: a value that is not finite is written as nan.
  const auto text = [](double v) { return std::isfinite(v) ? Json(v).dump() : std::string("nan"); };
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& p = roi.points_in_local_m[i];
    const cv::Point2d uv = i < roi.points1_px.size() ? roi.points1_px[i] : cv::Point2d(kNaN, kNaN);
    out << text(p.x()) << " " << text(p.y()) << " " << text(p.z()) << " " << text(uv.x) << " "
        << text(uv.y) << "\n";
  }
  return out.str();
}

SlopeErrorStats ComputeSlopeErrorStats(const FlightRun& run) {
  SlopeErrorPool pool;
  for (size_t i = 0; i < run.result.rois.size(); ++i) {
    const hda::RoiResult& roi = run.result.rois[i];
    SlopeSample sample;
    sample.has_slope = roi.has_fit && hda::HasSlope(roi.status);
    sample.num_points = roi.counts.depth_inliers;
    sample.error_deg = SlopeErrorDeg(run, i);
    sample.tilt_error_deg = TiltErrorOf(run, i);
    sample.sigma_deg = run.CombinedSlopeSigmaDeg(i);
    pool.Add(sample);
  }
  SlopeErrorStats stats;
  stats.count = pool.count();
  if (stats.count == 0) return stats;
  const ErrorStats slope = pool.Slope();
  const ErrorStats tilt = pool.Tilt();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  stats.median_abs_deg = slope.median;
  stats.p90_abs_deg = slope.p90;
  stats.within_two_sigma_fraction = pool.WithinTwoSigmaShare();
  stats.median_tilt_deg = tilt.count == 0 ? nan : tilt.median;
  stats.p90_tilt_deg = tilt.count == 0 ? nan : tilt.p90;
  stats.bias_deg = pool.Bias();
  return stats;
}

DecisionPool ComputeFlightDecisions(const FlightRun& run) {
  std::vector<DecisionSample> samples;
  for (size_t i = 0; i < run.result.rois.size(); ++i) {
    const hda::RoiResult& roi = run.result.rois[i];
    const Verdict declared = DeclaredVerdict(true, hda::ToString(roi.status), roi.slope_deg, run.options.max_slope_deg);
    samples.push_back(DecisionOfRoi(declared, TruthOf(run, i), roi.rank));
  }
  DecisionPool pool;
  pool.AddRun(samples);
  return pool;
}

ProbabilityDecisions ComputeProbabilityDecisions(const FlightRun& run) {
  const hda::HdaOptions& options = run.options;
  const std::vector<hda::RoiResult>& rois = run.result.rois;
  std::vector<size_t> safe;
  for (size_t i = 0; i < rois.size(); ++i) {
    if (ProbabilityVerdict(rois[i].probability_safe, options.min_probability_safe) == Verdict::kSafe) safe.push_back(i);
  }
  const auto score = [&](size_t i) {
    return hda::RankingScore(rois[i].area_m2, rois[i].slope_deg, rois[i].roughness_excess_m, options);
  };
  std::stable_sort(safe.begin(), safe.end(), [&](size_t a, size_t b) {
    if (rois[a].probability_safe != rois[b].probability_safe) return rois[a].probability_safe > rois[b].probability_safe;
    return score(a) > score(b);
  });
  std::vector<int> rank(rois.size(), 0);
  for (size_t r = 0; r < safe.size(); ++r) rank[safe[r]] = static_cast<int>(r) + 1;
  ProbabilityDecisions out{DecisionPool(), SafetyCalibration(options.min_probability_safe)};
  std::vector<DecisionSample> samples;
  for (size_t i = 0; i < rois.size(); ++i) {
    const Verdict declared = ProbabilityVerdict(rois[i].probability_safe, options.min_probability_safe);
    samples.push_back(DecisionOfRoi(declared, TruthOf(run, i), rank[i]));
    out.calibration.Add(rois[i].probability_safe, samples.back());
  }
  out.pool.AddRun(samples);
  return out;
}

// One line: whether the slopes' sigmas carry the calibration's term, and its size.
std::string CalibrationTermLine(const CalibrationTerm& term) {
  if (!term.available) return "calibration term: none (" + term.why + ")";
  std::vector<double> sigmas;
  for (const hda::CalibrationSigma& s : term.rois) {
    if (s.available) sigmas.push_back(s.slope_deg);
  }
  std::ostringstream line;
  line << "calibration term (" << term.model_file << ", " << term.modes.modes.size()
       << " modes, corner noise " << util::FixedCell(term.modes.noise_stdev_px, 3) << " px): ";
  std::sort(sigmas.begin(), sigmas.end());
  if (sigmas.empty()) {
    line << "no ROI with a fit got one";
  } else {
    line << "slope sigma median " << util::FixedCell(util::Quantile(sigmas, 0.5), 3) << " deg, p90 "
         << util::FixedCell(util::Quantile(sigmas, 0.9), 3) << " deg, max " << util::FixedCell(sigmas.back(), 3)
         << " deg over " << sigmas.size()
         << " ROIs; added in quadrature to the method's";
  }
  return line.str();
}

std::string FlightReport(const FlightRun& run) {
  std::ostringstream out;
  out << run.result.Summary() << "; frames " << run.frame1 << "," << run.frame2 << ", baseline "
      << util::FixedCell(run.baseline_m, 2) << " m, "
      << (run.range_source == RangeSource::kLrf ? "LRF range " : "range from the navigation (no LRF range) ")
      << util::FixedCell(run.lrf_range_m, 1) << " m\n";
  if (run.result.flight_instructions_per_s > 0.0) {  // a result of RunHda, which counted its work
    out << "flight computer, predicted from the counted work at "
        << util::ShortestText(run.result.flight_instructions_per_s) << " instructions/s:";
    for (int s = 0; s < hda::kNumStages; ++s) {
      const auto stage = static_cast<hda::Stage>(s);
      out << (s == 0 ? " " : ", ") << hda::ToString(stage) << " "
          << util::FixedCell(run.result.FlightSeconds(stage), 3) << " s";
    }
    out << "\n";
  }
  // A run made in memory, whose term was never looked for, says nothing.
  if (run.calibration.available || !run.calibration.why.empty()) out << CalibrationTermLine(run.calibration) << "\n";
  if (run.result.rois.empty()) return out.str();
  const bool truth = run.AnyTruth();
  const bool calibration = run.calibration.available;
  std::vector<std::vector<std::string>> rows;
  if (truth) {
    rows.push_back({"ROI", "status", "truth slope (deg)", "est. slope (deg)", "sigma (deg)",
                    "# points", "truth rough. RMS (m)", "est. relief (m)"});
  } else {
    rows.push_back({"ROI", "status", "est. slope (deg)", "sigma (deg)", "# points", "est. relief (m)"});
  }
  if (calibration) rows.front().insert(rows.front().begin() + (truth ? 5 : 4), "calib. sigma (deg)");
  for (size_t i = 0; i < run.result.rois.size(); ++i) {
    const hda::RoiResult& roi = run.result.rois[i];
    const auto fit = [&](double value, int digits) { return roi.has_fit ? util::FixedCell(value, digits) : "-"; };
    const RoiTruthValue* t = TruthOf(run, i);
    std::vector<std::string> row = {std::to_string(roi.id), hda::ToString(roi.status)};
    if (truth) row.push_back(t != nullptr ? util::FixedCell(t->slope_deg, 2) : "-");
    row.push_back(fit(roi.slope_deg, 2));
    row.push_back(fit(roi.slope_sigma_deg, 2));
    if (calibration) {
      const double sigma = run.calibration.SlopeSigmaDeg(i);
      row.push_back(std::isfinite(sigma) ? util::FixedCell(sigma, 3) : "-");
    }
    row.push_back(std::to_string(roi.counts.depth_inliers));
    if (truth) row.push_back(t != nullptr ? util::FixedCell(t->roughness_rms_m, 3) : "-");
    row.push_back(fit(roi.roughness_excess_m, 3));
    rows.push_back(row);
  }
  std::vector<bool> left(rows.front().size(), false);
  left[1] = true;
  out << util::FormatTextTable(rows, left);
  if (!truth) return out.str();
  const SlopeErrorStats stats = ComputeSlopeErrorStats(run);
  if (stats.count == 0) {
    out << "slope error: no ROI has a slope, truth and >= " << kMinPointsForSlopeStats << " points\n";
  } else {
    out << "slope error over " << stats.count << " ROI(s) with a slope, truth and >= "
        << kMinPointsForSlopeStats << " points: median |error| " << util::FixedCell(stats.median_abs_deg, 2)
        << " deg, 90th percentile " << util::FixedCell(stats.p90_abs_deg, 2) << " deg, "
        << util::FixedCell(100.0 * stats.within_two_sigma_fraction, 0) << " % within 2 predicted sigmas\n"
        << "tilt error (angle to the true plane) median " << util::FixedCell(stats.median_tilt_deg, 2)
        << " deg, 90th percentile " << util::FixedCell(stats.p90_tilt_deg, 2) << " deg; slope bias (mean of "
        << "estimated - true) " << util::SignedCell(stats.bias_deg, 2) << " deg\n";
  }
  const DecisionPool decisions = ComputeFlightDecisions(run);
  out << "landing decision: "
      << (decisions.sites() > 0 ? DecisionLine(decisions) : "no site has a lander truth (no truth DEM)") << "\n";
  if (decisions.sites() > 0) {
    const ProbabilityDecisions probability = ComputeProbabilityDecisions(run);
    out << "probability rule (safe at P >= " << util::FixedText(run.options.min_probability_safe, 2)
        << "): " << DecisionLine(probability.pool) << "; " << SafetyCalibrationLine(probability.calibration) << "\n";
  }
  return out.str();
}

namespace {

// Image 1 enlarged as the whole-image figures show it (by a whole factor up
// to 4 so that a minimum block is about 48 px, at most `max_width_px`
// wide), and the label size that fits `widest_label` in `fill` of the
// smallest ROI box.
struct Image1Canvas {
  Panel panel;
  cv::Mat canvas;
  double scale = 1.0;
  double text_scale = 0.5;
};
Image1Canvas MakeImage1Canvas(const cv::Mat& bgr, const hda::HdaResult& result, const char* widest_label,
                              double fill, int max_width_px) {
  Image1Canvas out;
  const int min_block = std::max(1, result.quadtree.min_block_px);
  const int factor = std::clamp((48 + min_block - 1) / min_block, 1, 4);
  out.scale = bgr.cols * factor > max_width_px ? static_cast<double>(max_width_px) / bgr.cols
                                               : static_cast<double>(factor);
  out.panel = Panel{cv::Rect(0, 0, bgr.cols, bgr.rows), out.scale, cv::Point(0, 0)};
  out.canvas = cv::Mat(out.panel.CanvasSize(), CV_8UC3);
  PastePanel(bgr, out.panel, &out.canvas);
  int smallest = static_cast<int>(std::lround(min_block * out.scale));
  for (const hda::RoiResult& roi : result.rois) {
    smallest = std::min({smallest, out.panel.Map(roi.box1_px).width, out.panel.Map(roi.box1_px).height});
  }
  int baseline = 0;
  const double unit_width = cv::getTextSize(widest_label, kFont, 1.0, 1, &baseline).width;
  out.text_scale = std::clamp(fill * smallest / unit_width, 0.3, 0.8);
  return out;
}

}  // namespace

cv::Mat QuadtreeFigure(const cv::Mat& image1, const hda::HdaResult& result) {
  const cv::Mat bgr = ToBgr(image1);
  Image1Canvas image = MakeImage1Canvas(bgr, result, "999", 0.8, kFigureShownWidthPx);
  cv::Mat& canvas = image.canvas;
  const Panel& panel = image.panel;
  const double text_scale = image.text_scale;
  for (const cv::Rect& box : result.quadtree.rejected_boxes) {
    DrawLabelledBox(&canvas, panel.Map(box), kRejectedBlock, 1, "", 0.0);
  }
  const int thickness = image.scale >= 2.0 ? 2 : 1;
  std::vector<int> counts(kNumStatuses, 0);
  for (const hda::RoiResult& roi : result.rois) {
    ++counts[static_cast<size_t>(roi.status)];
    DrawLabelledBox(&canvas, panel.Map(roi.box1_px), StatusColour(roi.status), thickness,
                    std::to_string(roi.id), text_scale);
  }

  std::vector<std::pair<Colour, std::string>> entries;
  for (size_t s = 0; s < kNumStatuses; ++s) {
    const auto status = static_cast<hda::RoiStatus>(s);
    entries.emplace_back(StatusColour(status),
                         std::string(hda::ToString(status)) + " (" + std::to_string(counts[s]) + ")");
  }
  entries.emplace_back(kRejectedBlock, "rejected block (" +
                                           std::to_string(result.quadtree.rejected_boxes.size()) + ")");
  const double legend_scale = std::clamp(canvas.cols / 1600.0, 0.4, 0.8);
  cv::Mat figure;
  cv::vconcat(canvas, LegendStrip(canvas.cols, entries, legend_scale), figure);
  return figure;
}

namespace {

// The decision classes in the legend's order, and their colours: green right
// and safe, red false safe, orange missed safe, blue right and unsafe, light
// grey no verdict, dark grey no truth.
constexpr int kDecisionClasses = 6;
int DecisionClass(const DecisionSample& s) {
  if (!s.has_truth) return 5;
  if (s.declared == Verdict::kNone) return 4;
  if (s.declared == Verdict::kSafe) return s.truly_safe ? 0 : 1;
  return s.truly_safe ? 2 : 3;
}
const Colour kDecisionColours[kDecisionClasses] = {Colour(0, 210, 0),   Colour(40, 40, 255),  Colour(0, 150, 255),
                                                   Colour(255, 140, 0), Colour(200, 200, 200), Colour(90, 90, 90)};
const char* const kDecisionNames[kDecisionClasses] = {"safe, truly safe", "FALSE SAFE", "missed safe",
                                                      "unsafe, truly unsafe", "no verdict", "no lander truth"};

}  // namespace

const char* DecisionClassName(const DecisionSample& sample) { return kDecisionNames[DecisionClass(sample)]; }

cv::Mat DecisionFigure(const cv::Mat& image1, const FlightRun& run) {
  const hda::HdaResult& result = run.result;
  Image1Canvas image = MakeImage1Canvas(ToBgr(image1), result, "+9.9", 0.85, kFigureHalfWidthPx);
  cv::Mat& canvas = image.canvas;
  const Panel& panel = image.panel;
  const double text_scale = image.text_scale;
  const int thickness = image.scale >= 2.0 ? 3 : 2;
  std::vector<int> counts(kDecisionClasses, 0);
  for (size_t i = 0; i < result.rois.size(); ++i) {
    const hda::RoiResult& roi = result.rois[i];
    const DecisionSample sample = DecisionOfRoi(
        DeclaredVerdict(true, hda::ToString(roi.status), roi.slope_deg, run.options.max_slope_deg), TruthOf(run, i), roi.rank);
    const int c = DecisionClass(sample);
    ++counts[static_cast<size_t>(c)];
    const double error = SlopeErrorDeg(run, i);
    const bool shown = roi.has_fit && hda::HasSlope(roi.status) && std::isfinite(error);
    DrawLabelledBox(&canvas, panel.Map(roi.box1_px), kDecisionColours[c], thickness,
                    shown ? util::SignedCell(error, 1) : "", text_scale);
  }
  std::vector<std::pair<Colour, std::string>> entries;
  for (int c = 0; c < kDecisionClasses; ++c) {
    entries.emplace_back(kDecisionColours[c], std::string(kDecisionNames[c]) + " (" +
                                                  std::to_string(counts[static_cast<size_t>(c)]) + ")");
  }
  const double legend_scale = std::clamp(canvas.cols / 1600.0, 0.4, 0.8);
  cv::Mat figure;
  cv::vconcat(canvas, LegendStrip(canvas.cols, entries, legend_scale), figure);
  return figure;
}

cv::Mat RoiPairFigure(const cv::Mat& image1, const cv::Mat& image2, const hda::RoiResult& roi) {
  constexpr int kTitleLines = 2;
  constexpr double kTitleScale = 0.5;
  const double panel_height_px = kFigureGridHeightPx - TitleStripHeight(kTitleLines, kTitleScale);
  constexpr int kGapPx = 12;
  const cv::Mat bgr1 = ToBgr(image1);
  const cv::Mat bgr2 = ToBgr(image2);
  const auto context_crop = [](const cv::Rect& box, int context, const cv::Mat& image) {
    const cv::Rect grown(box.x - context, box.y - context, box.width + 2 * context,
                         box.height + 2 * context);
    const cv::Rect crop = grown & cv::Rect(0, 0, image.cols, image.rows);
    return crop.area() > 0 ? crop : cv::Rect(0, 0, image.cols, image.rows);
  };
  const int context1 = std::max(8, std::max(roi.box1_px.width, roi.box1_px.height) / 2);
  const cv::Rect crop1 = context_crop(roi.box1_px, context1, bgr1);
  const cv::Rect crop2 = context_crop(HasBox2(roi) ? roi.box2_px : roi.box1_px, 8, bgr2);

  Panel panel1{crop1, panel_height_px / crop1.height, cv::Point(0, 0)};
  Panel panel2{crop2, panel_height_px / crop2.height, cv::Point(0, 0)};
  panel2.offset.x = panel1.CanvasSize().width + kGapPx;
  const int width = panel2.offset.x + panel2.CanvasSize().width;
  const int height = std::max(panel1.CanvasSize().height, panel2.CanvasSize().height);
  cv::Mat canvas(height, width, CV_8UC3, Colour(32, 32, 32));
  PastePanel(bgr1, panel1, &canvas);
  PastePanel(bgr2, panel2, &canvas);

  const Colour colour = StatusColour(roi.status);
  DrawLabelledBox(&canvas, panel1.Map(roi.box1_px), colour, 2, "", 0.0);
  if (HasBox2(roi)) DrawLabelledBox(&canvas, panel2.Map(roi.box2_px), colour, 2, "", 0.0);
  DrawMatchLines(&canvas, panel1, panel2, roi.points1_px, roi.points2_px, PaletteColour, 3, 1.0);

  std::string title = "ROI " + std::to_string(roi.id) + ": " + hda::ToString(roi.status) + ", " +
                      std::to_string(roi.points1_px.size()) + " matches";
  if (roi.has_fit) {
    title += ", slope " + util::FixedCell(roi.slope_deg, 2) + " +- " + util::FixedCell(roi.slope_sigma_deg, 2) + " deg";
  }
  cv::Mat figure;
  cv::vconcat(TitleStrip(width, {title, "left: image 1 ROI; right: image 2 search box"}, kTitleScale),
              canvas, figure);
  return figure;
}

cv::Mat MatchesFigure(const cv::Mat& image1, const cv::Mat& image2, const hda::HdaResult& result) {
  // Shrunk to at most kFigureShownWidthPx wide; small images enlarged to about
  // 1024 px wide.
  constexpr int kMaxWidthPx = kFigureShownWidthPx;
  constexpr int kMinWidthPx = 1024;
  constexpr int kGapPx = 8;
  const cv::Mat bgr1 = ToBgr(image1);
  const cv::Mat bgr2 = ToBgr(image2);
  const double both = bgr1.cols + bgr2.cols;
  const double scale = both > kMaxWidthPx - kGapPx
                           ? (kMaxWidthPx - kGapPx) / both
                           : std::max(1.0, std::floor((kMinWidthPx - kGapPx) / both));
  Panel panel1{cv::Rect(0, 0, bgr1.cols, bgr1.rows), scale, cv::Point(0, 0)};
  Panel panel2{cv::Rect(0, 0, bgr2.cols, bgr2.rows), scale, cv::Point(0, 0)};
  panel2.offset.x = panel1.CanvasSize().width + kGapPx;
  cv::Mat canvas(std::max(panel1.CanvasSize().height, panel2.CanvasSize().height),
                 panel2.offset.x + panel2.CanvasSize().width, CV_8UC3, Colour(32, 32, 32));
  PastePanel(bgr1, panel1, &canvas);
  PastePanel(bgr2, panel2, &canvas);
  for (const hda::RoiResult& roi : result.rois) {
    const Colour colour = PaletteColour(static_cast<size_t>(roi.id));
    if (!roi.points1_px.empty()) {
      DrawLabelledBox(&canvas, panel1.Map(roi.box1_px), colour, 1, "", 0.0);
    }
    DrawMatchLines(&canvas, panel1, panel2, roi.points1_px, roi.points2_px,
                   [&](size_t) { return colour; }, 2, 0.35);
  }
  return canvas;
}

void PrepareOutputFolder(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir, ec)) {
    throw InputError(dir + ": cannot create the output folder (" +
                     (ec ? ec.message() : std::string("exists and is not a folder")) + ")");
  }
}

std::vector<std::string> WriteFlightOutputs(const FlightRun& run, const cv::Mat& image1,
                                            const cv::Mat& image2, const std::string& dir,
                                            bool figures, int threads) {
  PrepareOutputFolder(dir);
  const fs::path root(dir);
  // result.json marks a whole run (OtherCommandsResults, report, gate): it is
  // removed first and written last, so a folder whose writing stopped halfway
  // (a full disk, a kill) holds none and nothing takes it for a run's results.
  std::error_code ec;
  fs::remove(root / "result.json", ec);
  if (ec) throw InputError((root / "result.json").string() + ": cannot remove the earlier result (" + ec.message() + ")");
  std::vector<std::string> written;
  WriteText(root, "timings.json", FlightTimingsJson(run), &written);
  WriteText(root, "rois.csv", FlightRoisCsv(run), &written);
  for (const hda::RoiResult& roi : run.result.rois) {
    if (!roi.points_in_local_m.empty()) WriteText(root, PlyName(roi), RoiPly(roi), &written);
  }
  RemoveStaleRoiFiles(root, "points", ".ply", written);
  if (figures) {
    // Each image converted once for every figure, not once per figure.
    const cv::Mat bgr1 = ToBgr(image1), bgr2 = ToBgr(image2);
    std::vector<const hda::RoiResult*> pairs;
    for (const hda::RoiResult& roi : run.result.rois) {
      if (roi.counts.matches > 0 && HasBox2(roi)) pairs.push_back(&roi);
    }
    // Drawn and encoded on every core (each figure depends on its index
    // only), then written in order, so the files and what a failed write
    // leaves behind are those of one thread.
    // The decision figure, with truth, after the two whole-image figures.
    const int decision = run.AnyTruth() ? 1 : 0;
    const int count = 2 + decision + static_cast<int>(pairs.size());
    std::vector<std::string> names(static_cast<size_t>(count)), pngs(static_cast<size_t>(count));
    util::ParallelFor("flight figures", count, util::WorkerThreads(threads), [&](int i) {
      const size_t k = static_cast<size_t>(i);
      cv::Mat figure;
      if (i == 0) {
        names[k] = "figures/quadtree.png";
        figure = QuadtreeFigure(bgr1, run.result);
      } else if (i == 1) {
        names[k] = "figures/matches.png";
        figure = MatchesFigure(bgr1, bgr2, run.result);
      } else if (i == 2 && decision == 1) {
        names[k] = "figures/decision.png";
        figure = DecisionFigure(bgr1, run);
      } else {
        const hda::RoiResult& roi = *pairs[k - 2 - static_cast<size_t>(decision)];
        names[k] = "figures/roi_pairs/" + RoiFileStem(roi.id) + ".png";
        figure = RoiPairFigure(bgr1, bgr2, roi);
      }
      pngs[k] = images::EncodePng(figure, kFigurePngCompression);
    });
    for (size_t k = 0; k < names.size(); ++k) {
      WriteText(root, names[k], pngs[k], &written);
      std::string().swap(pngs[k]);
    }
    RemoveStaleRoiFiles(root, "figures/roi_pairs", ".png", written);
  }
  WriteText(root, "result.json", FlightResultJson(run), &written);
  // Listed first, as it always was.
  std::rotate(written.begin(), written.end() - 1, written.end());
  return written;
}

}  // namespace hdabench::reference
