#include "reference/compare/compare.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <set>
#include <utility>

#include "datasets/synth/truth.h"
#include "hda/calibration_sigma.h"
#include "reference/compare/method.h"
#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/text.h"

namespace hdabench::reference {

namespace {

std::string JoinNames(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
  return text;
}

// A method that cannot run on the pair (it threw): its column fails, with
// every ROI saying why, and the other methods still run.
std::vector<MethodRoi> FailMethod(const std::string& failure, size_t num_rois, MethodSummary* summary) {
  summary->ok = false;
  summary->failure = failure;
  std::vector<MethodRoi> rois(num_rois);
  for (MethodRoi& roi : rois) roi.reason = failure;
  return rois;
}

// Runs one method of the table inside the guard: whatever it throws, and
// a result that is not one ROI per flight ROI, fails its column only.
void RunGuarded(const MethodEntry& method, const PairContext& ctx, std::vector<MethodRoi>* rois,
                MethodSummary* summary) {
  const size_t num_rois = ctx.flight().result.rois.size();
  std::string failure;
  try {
    method.run(ctx, rois, summary);
    if (rois->size() == num_rois) return;
    failure = "the method gave " + std::to_string(rois->size()) + " ROIs for the flight method's " +
              std::to_string(num_rois);
  } catch (const std::exception& e) {
    failure = e.what();
  } catch (...) {
    failure = "the method threw something that is not an exception";
  }
  *summary = MethodSummary();
  summary->method = method.name;
  *rois = FailMethod(failure, num_rois, summary);
}



// ---------------------------------------------------------------------------
// Summaries

void Summarise(const CompareRun& run, size_t m, size_t colmap_nav_index, double flight_seconds,
               MethodSummary* s) {
  const std::vector<MethodRoi>& rois = run.rois[m];
  std::vector<double> vs_colmap;
  PointAccuracy accuracy;
  int accuracy_points = 0;
  double median_sum = 0.0, within01 = 0.0, within03 = 0.0, within1 = 0.0;
  SlopeErrorPool pool;
  std::vector<DecisionSample> decisions;
  for (size_t i = 0; i < rois.size(); ++i) {
    const MethodRoi& roi = rois[i];
    if (roi.accuracy.available) {
      // Point-weighted means of the per-ROI shares; the median is the
      // point-weighted mean of the ROI medians (documented as such).
      const double n = roi.accuracy.num_points;
      accuracy_points += roi.accuracy.num_points;
      median_sum += n * roi.accuracy.median_m;
      within01 += n * roi.accuracy.within_0_1_m;
      within03 += n * roi.accuracy.within_0_3_m;
      within1 += n * roi.accuracy.within_1_m;
    }
    const RoiTruthValue* truth =
        i < run.flight.truths.size() && run.flight.truths[i].available ? &run.flight.truths[i] : nullptr;
    const SlopeSample sample = SampleOfMethodRoi(roi, truth);
    pool.Add(sample);
    decisions.push_back(DecisionOfMethodRoi(roi, truth, run.flight.options.max_slope_deg,
                                            run.flight.result.rois[i].rank));
    if (!sample.has_slope || sample.num_points < kMinPointsForSlopeStats) continue;
    if (colmap_nav_index < run.rois.size() && colmap_nav_index != m) {
      const SlopeSample ref = SampleOfMethodRoi(run.rois[colmap_nav_index][i], nullptr);
      if (ref.has_slope && ref.num_points >= kMinPointsForSlopeStats) {
        vs_colmap.push_back(std::abs(roi.slope_deg - run.rois[colmap_nav_index][i].slope_deg));
      }
    }
  }
  if (accuracy_points > 0) {
    accuracy.available = true;
    accuracy.num_points = accuracy_points;
    accuracy.median_m = median_sum / accuracy_points;
    accuracy.within_0_1_m = within01 / accuracy_points;
    accuracy.within_0_3_m = within03 / accuracy_points;
    accuracy.within_1_m = within1 / accuracy_points;
  }
  s->accuracy = accuracy;
  s->rois_with_fit = pool.rois_with_slope();
  s->slope_vs_truth_deg = pool.Slope();
  s->tilt_vs_truth_deg = pool.Tilt();
  s->slope_bias_deg = pool.Bias();
  s->tilt_definition_deg = pool.DefinitionTilt();
  s->tilt_estimation_deg = pool.EstimationTilt();
  s->slope_definition_bias_deg = pool.DefinitionBias();
  s->slope_estimation_bias_deg = pool.EstimationBias();
  s->roughness_vs_truth_m = pool.Roughness();
  s->slope_vs_colmap_nav_deg = ComputeErrorStats(vs_colmap);
  s->time_ratio_to_flight = flight_seconds > 0.0 ? s->wall_s / flight_seconds : 0.0;
  s->decision = DecisionPool();
  s->decision.AddRun(decisions);
}

}  // namespace

// ---------------------------------------------------------------------------

bool MethodRoi::HasSlope() const {
  return has_fit && StatusHasSlope(status == MethodRoiStatus::kFlight, StatusName());
}

DecisionSample DecisionOfMethodRoi(const MethodRoi& roi, const RoiTruthValue* truth, double max_slope_deg,
                                   int flight_rank) {
  const bool is_flight = roi.status == MethodRoiStatus::kFlight;
  const Verdict declared = DeclaredVerdict(is_flight, roi.StatusName(),
                                           roi.has_fit ? roi.slope_deg : std::numeric_limits<double>::quiet_NaN(),
                                           max_slope_deg);
  return DecisionOfRoi(declared, truth, is_flight ? flight_rank : 0);
}

SlopeSample SampleOfMethodRoi(const MethodRoi& roi, const RoiTruthValue* truth) {
  SlopeSample s;
  s.has_slope = roi.HasSlope();
  s.num_points = roi.num_points;
  if (roi.has_sigma) s.sigma_deg = hda::CombinedSlopeSigmaDeg(roi.slope_sigma_deg, roi.slope_sigma_calibration_deg);
  if (truth != nullptr && roi.has_fit) {
    s.error_deg = roi.slope_deg - truth->slope_deg;
    s.tilt_error_deg = TiltErrorDeg(roi.normal_in_local, truth->normal_in_local);
    s.roughness_error_m = std::abs(roi.roughness_rms_m - truth->roughness_rms_m);
    if (roi.own_truth.available) {
      s.definition_tilt_deg = TiltErrorDeg(roi.own_truth.normal_in_local, truth->normal_in_local);
      s.estimation_tilt_deg = TiltErrorDeg(roi.normal_in_local, roi.own_truth.normal_in_local);
      s.definition_error_deg = roi.own_truth.slope_deg - truth->slope_deg;
      s.estimation_error_deg = roi.slope_deg - roi.own_truth.slope_deg;
    }
  }
  return s;
}

std::vector<std::string> AllMethodNames() {
  std::vector<std::string> names;
  for (const MethodEntry& method : MethodTable()) {
    if (method.in_all) names.push_back(method.name);
  }
  return names;
}

std::vector<std::string> KnownMethodNames() {
  std::vector<std::string> names;
  for (const MethodEntry& method : MethodTable()) names.push_back(method.name);
  return names;
}

std::vector<std::string> ParseMethodList(const std::string& comma_separated) {
  if (comma_separated == "all") return AllMethodNames();
  const std::vector<std::string> all = KnownMethodNames();
  std::vector<std::string> methods;
  std::set<std::string> seen;
  size_t start = 0;
  while (start <= comma_separated.size()) {
    const size_t end = std::min(comma_separated.find(',', start), comma_separated.size());
    const std::string name = comma_separated.substr(start, end - start);
    if (std::find(all.begin(), all.end(), name) == all.end()) {
      throw InputError("unknown method '" + name + "'; the methods are: " + JoinNames(all) +
                       " (or all)");
    }
    if (!seen.insert(name).second) throw InputError("method '" + name + "' is listed twice");
    methods.push_back(name);
    start = end + 1;
  }
  if (seen.count(kMethodFlight) == 0) methods.insert(methods.begin(), kMethodFlight);
  // Table order: as AllMethodNames.
  std::vector<std::string> ordered;
  for (const std::string& name : all) {
    if (std::find(methods.begin(), methods.end(), name) != methods.end()) ordered.push_back(name);
  }
  return ordered;
}

std::vector<cv::Rect> OverlapTiles(int image_width_px, int image_height_px,
                                   const std::vector<cv::Rect>& roi_boxes_px, int max_tiles) {
  int side = 0;
  for (const cv::Rect& box : roi_boxes_px) side = std::max({side, box.width, box.height});
  if (max_tiles <= 0 || side <= 0 || image_width_px < side || image_height_px < side) return {};
  const int columns = image_width_px / side;
  const int rows = image_height_px / side;
  // Every k-th tile of the grid in each direction: ceil(columns / k) x ceil(rows / k) of them.
  int k = 1;
  while (static_cast<long long>((columns + k - 1) / k) * ((rows + k - 1) / k) > max_tiles) ++k;
  std::vector<cv::Rect> tiles;
  for (int r = 0; r < rows; r += k) {
    for (int c = 0; c < columns; c += k) {
      const cv::Rect tile(c * side, r * side, side, side);
      const bool meets_roi = std::any_of(roi_boxes_px.begin(), roi_boxes_px.end(),
                                         [&](const cv::Rect& box) { return (tile & box).area() > 0; });
      if (!meets_roi) tiles.push_back(tile);
    }
  }
  return tiles;
}

void ColmapSettings::ApplyTo(ColmapOptions* options) const {
  if (max_features) options->sift_max_num_features = *max_features;
  if (first_octave) options->sift_first_octave = *first_octave;
  if (octave_resolution) options->sift_octave_resolution = *octave_resolution;
  if (peak_threshold) options->sift_peak_threshold = *peak_threshold;
  if (nav_band_px) options->nav_guided_max_error_px = *nav_band_px;
}

CeresRefineOptions DefaultRefineOptions() {
  const hda::HdaOptions flight;
  CeresRefineOptions refine;
  refine.nav_position_sigma_m = flight.prediction.nav_position_sigma_m;
  refine.nav_attitude_sigma_deg = flight.prediction.nav_attitude_sigma_deg;
  refine.pixel_sigma_px = flight.match_error_px;
  return refine;
}

std::vector<std::string> ExternalMethodOptions::Validate() const {
  std::vector<std::string> errors;
  if (!(timeout_s > 0.0) || !std::isfinite(timeout_s)) {
    errors.push_back("timeout_s = " + util::ShortestText(timeout_s) + ": expected a finite number of seconds > 0");
  }
  return errors;
}

std::vector<std::string> CompareOptions::Validate() const {
  std::vector<std::string> errors;
  const std::vector<std::string> all = KnownMethodNames();
  for (const std::string& m : methods) {
    if (std::find(all.begin(), all.end(), m) == all.end()) {
      errors.push_back("methods: unknown method '" + m + "'");
    }
  }
  if (methods.empty() || methods.front() != kMethodFlight) {
    errors.push_back("methods: must start with flight (it finds the ROIs)");
  }
  for (const std::string& e : hda.options.Validate()) errors.push_back("hda." + e);
  for (const std::string& e : colmap.Validate()) errors.push_back("colmap." + e);
  for (const std::string& e : opengv.Validate()) errors.push_back("opengv." + e);
  for (const std::string& e : direct_plane.Validate()) errors.push_back("direct_plane." + e);
  for (const std::string& e : dense_stereo.Validate()) errors.push_back("dense_stereo." + e);
  RequireOption(std::isfinite(lrf_range_sigma_m) && lrf_range_sigma_m > 0, "lrf_range_sigma_m", lrf_range_sigma_m,
                "> 0 (metres)", &errors);
  for (const std::string& e : external.Validate()) errors.push_back("external." + e);
  if (std::find(methods.begin(), methods.end(), kMethodExternal) != methods.end() && external.program.empty()) {
    errors.push_back("external.program: the external method needs a program (--external-program)");
  }
  for (const std::string& e : refine.Validate()) errors.push_back("refine." + e);
  if (!(fit_pixel_sigma_px > 0.0 && std::isfinite(fit_pixel_sigma_px))) {
    errors.push_back("fit_pixel_sigma_px = " + std::to_string(fit_pixel_sigma_px) +
                     ": expected > 0");
  }
  if (min_points < 3) {
    errors.push_back("min_points = " + std::to_string(min_points) + ": expected >= 3");
  }
  if (opengv_overlap_tiles < 0) {
    errors.push_back("opengv_overlap_tiles = " + std::to_string(opengv_overlap_tiles) + ": expected >= 0");
  }
  return errors;
}

const char* ToString(MethodRoiStatus status) {
  switch (status) {
    case MethodRoiStatus::kOk: return "ok";
    case MethodRoiStatus::kTooFewPoints: return "too few points";
    case MethodRoiStatus::kDegenerate: return "degenerate";
    case MethodRoiStatus::kFailed: return "failed";
    case MethodRoiStatus::kNoSearchBox: return "no search box";
    case MethodRoiStatus::kPlanar: return "planar";
    case MethodRoiStatus::kLowParallax: return "low parallax";
    case MethodRoiStatus::kPoseFailed: return "pose failed";
    case MethodRoiStatus::kOutsideOverlap: return "outside overlap";
    case MethodRoiStatus::kNoTexture: return "no texture";
    case MethodRoiStatus::kDiverged: return "diverged";
    case MethodRoiStatus::kNotRectifiable: return "not rectifiable";
    case MethodRoiStatus::kFlight: return "flight";
  }
  return "unknown";
}

MethodRoiStatus StatusOfConfiguration(ConfigurationType type) {
  switch (type) {
    case ConfigurationType::kWellConditioned: return MethodRoiStatus::kOk;
    case ConfigurationType::kPlanar: return MethodRoiStatus::kPlanar;
    case ConfigurationType::kLowParallax: return MethodRoiStatus::kLowParallax;
    case ConfigurationType::kTooFewPoints: return MethodRoiStatus::kTooFewPoints;
  }
  return MethodRoiStatus::kTooFewPoints;
}

std::string MethodRoi::StatusName() const {
  return status == MethodRoiStatus::kFlight ? hda::ToString(flight_status) : ToString(status);
}

CompareRun RunCompare(const datasets::Dataset& dataset, int frame1, int frame2,
                      const CompareOptions& options, const std::string& colmap_workspace,
                      const CompareProgress& progress) {
  ThrowIfInvalid("invalid comparison options: ", options.Validate());
  CompareRun run;
  run.methods = options.methods;
  PairContext ctx(dataset, frame1, frame2, options, progress);

  ctx.Say("flight method on frames " + std::to_string(frame1) + "," + std::to_string(frame2));
  run.flight = RunFlight(dataset, frame1, frame2, options.hda, options.given_rois_px);
  ctx.SetFlight(&run.flight);
  run.any_truth = run.flight.AnyTruth();

  std::vector<MethodEntry> methods;
  bool colmap_nav = false, colmap_free = false;
  for (const std::string& name : run.methods) {
    const std::unique_ptr<MethodEntry> method = FindMethod(name);
    if (method == nullptr) throw InputError("unknown method '" + name + "'");  // Validate's: not reached
    colmap_nav = colmap_nav || method->needs.colmap == ColmapNeed::kNav;
    colmap_free = colmap_free || method->needs.colmap == ColmapNeed::kFree;
    methods.push_back(*method);
  }
  // COLMAP (an external program, one thread, and the exact matcher) runs
  // alongside the methods computed here; its methods run last. Nothing is
  // shared but read-only inputs, so no result depends on it; the in-process
  // methods' times are measured under its load.
  if (colmap_nav || colmap_free) {
    ctx.StartColmap(colmap_nav, colmap_free, colmap_workspace);
    run.colmap_workspace = colmap_workspace;
  }
  run.rois.resize(methods.size());
  run.summaries.resize(methods.size());
  for (const bool colmap_pass : {false, true}) {
    bool said = false;
    for (size_t m = 0; m < methods.size(); ++m) {
      if ((methods[m].needs.colmap != ColmapNeed::kNone) != colmap_pass) continue;
      if (colmap_pass && !said) ctx.Say("colmap: waiting for it to finish");
      said = true;
      run.summaries[m].method = methods[m].name;
      RunGuarded(methods[m], ctx, &run.rois[m], &run.summaries[m]);
    }
  }
  AttachOwnTruths(dataset, &run);
  SummariseCompareRun(&run);
  return run;
}

void AttachOwnTruths(const datasets::Dataset& dataset, CompareRun* run) {
  for (size_t i = 0; i < run->flight.result.rois.size(); ++i) {
    const bool site_truth = i < run->flight.truths.size() && run->flight.truths[i].available;
    for (std::vector<MethodRoi>& rois : run->rois) {
      MethodRoi& roi = rois[i];
      MethodRoi::OwnTruth& own = roi.own_truth;
      own = MethodRoi::OwnTruth();
      if (!roi.has_fit) {
        own.why = "no plane";
      } else if (!site_truth) {
        own.why = "the ROI has no truth";
      } else if (roi.support_px.empty()) {
        own.why = "the method names no support";
      } else {
        try {
          const datasets::synth::SupportTruth truth =
              datasets::synth::ComputeSupportTruth(dataset, run->flight.frame1, roi.support_px, roi.support_weights);
          own.available = true;
          own.num_points = truth.num_points;
          own.slope_deg = truth.slope_deg;
          own.normal_in_local = truth.normal_in_local;
        } catch (const InputError& e) {
          own.why = e.what();
        }
      }
    }
  }
}

void SummariseCompareRun(CompareRun* run) {
  const auto colmap_nav_column = std::find(run->methods.begin(), run->methods.end(), kMethodColmapNav);
  const size_t colmap_nav_index = static_cast<size_t>(colmap_nav_column - run->methods.begin());
  const double flight_seconds = run->flight.result.times.total_s;
  for (size_t m = 0; m < run->methods.size(); ++m) {
    Summarise(*run, m, colmap_nav_index, flight_seconds, &run->summaries[m]);
    if (run->methods[m] == kMethodFlight) run->summaries[m].flight_computer_s = run->flight.result.FlightSeconds();
  }
}

}  // namespace hdabench::reference
