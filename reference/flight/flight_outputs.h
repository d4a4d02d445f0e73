// The outputs of one run of the flight method on a dataset (`hdabench run`):
// result.json (deterministic, versioned), timings.json (wall times), rois.csv,
// one PLY cloud per ROI with points, the figures, and the text report with
// the paper-style table of estimated against true slopes. The formats are
// specified in docs/flight-results.md (format_version 1); frames and units
// follow docs/conventions.md.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>

#include "hda/hda_options.h"
#include "hda/pipeline.h"
#include "reference/flight/decision_statistics.h"
#include "reference/flight/flight_run.h"
#include "reference/flight/slope_statistics.h"

namespace hdabench::reference {

inline constexpr char kFlightResultFormatName[] = "hdabench-flight-result";
inline constexpr char kFlightTimingsFormatName[] = "hdabench-flight-timings";
inline constexpr int kFlightResultFormatVersion = 1;

// result.json: the deterministic record of the run (no wall times), doubles
// printed so they read back identical, null for what does not apply and for
// non-finite values. Two runs on the same inputs give the same bytes (unless
// the time budget ran out at different ROIs).
std::string FlightResultJson(const FlightRun& run);

// result.json's "calibration_term" (compare.json has it too): whether the
// slopes' sigmas carry the calibration's term; when they do, the model, the
// corner noise, the projection stdevs and the modes.
nlohmann::ordered_json CalibrationTermJson(const CalibrationTerm& term);

// One line of the run's text: the calibration term, or why there is none.
std::string CalibrationTermLine(const CalibrationTerm& term);

// timings.json: StageTimes, budget and each ROI's seconds (not deterministic).
std::string FlightTimingsJson(const FlightRun& run);

// rois.csv: a header and one row per ROI in id order; empty cells where a
// value does not apply.
std::string FlightRoisCsv(const FlightRun& run);

// ASCII PLY of an ROI's points: x y z in the local frame (metres) and the
// image-1 pixel u1 v1 of each, as doubles.
std::string RoiPly(const hda::RoiResult& roi);

// "roi_007" style stem of an ROI's per-ROI files: the id zero-padded to 3 digits.
std::string RoiFileStem(int id);

// Slope error statistics over the ROIs with a slope (hda::HasSlope), truth
// and at least kMinPointsForSlopeStats points (depth inliers): |estimated -
// true| slope, the tilt error (TiltErrorDeg) and the bias.
struct SlopeErrorStats {
  int count = 0;                        // ROIs used
  double median_abs_deg = 0.0;          // median |error|, degrees (0 when count is 0)
  double p90_abs_deg = 0.0;             // 90th percentile |error| (linear between order statistics)
  double within_two_sigma_fraction = 0.0;  // share with |error| <= 2 * predicted slope sigma
  double median_tilt_deg = 0.0;         // median tilt error, degrees (NaN when no ROI has one)
  double p90_tilt_deg = 0.0;            // 90th percentile tilt error
  double bias_deg = 0.0;                // mean of estimated - true slope, degrees (signed)
};
SlopeErrorStats ComputeSlopeErrorStats(const FlightRun& run);

// The run's landing decisions against the lander's truth
// (reference/flight/decision_statistics.h).
DecisionPool ComputeFlightDecisions(const FlightRun& run);

// The same sites decided by the probability rule (every fitted site with a
// probability of safety: safe at or over the options' min_probability_safe,
// ranked by the probability, then the paper's score), whichever rule the run
// used, and how often the sites given each probability are truly safe.
struct ProbabilityDecisions {
  DecisionPool pool;
  SafetyCalibration calibration;
};
ProbabilityDecisions ComputeProbabilityDecisions(const FlightRun& run);

// The report printed by `hdabench run`: the summary line (HdaResult::Summary,
// frames, baseline), then a table with one row per ROI in id order
//   ROI | status | truth slope (deg) | est. slope (deg) | sigma (deg) | # points |
//   truth rough. RMS (m) | est. relief (m)
// (without the truth columns when no ROI has truth; "-" where a value does not
// apply), and with truth a line with the SlopeErrorStats, one with the
// landing decisions (DecisionLine) and one with the probability rule's
// decisions and calibration.
std::string FlightReport(const FlightRun& run);

// The largest size at which the report (reference/report) shows a figure: its
// page's width, and the height of its grids (the ROI pairs, the maps). The
// figures are drawn at most this large, so the report embeds them as they are.
constexpr int kFigureShownWidthPx = 1360;
constexpr int kFigureGridHeightPx = 320;
// The decision figure's width: half the page, beside the truth's safety map.
constexpr int kFigureHalfWidthPx = kFigureShownWidthPx / 2 - 16;

// Figures (8-bit BGR images). image1 / image2 are the run's images (CV_8UC1
// or CV_16UC1), or those images already converted to 8-bit BGR (CV_8UC3).
// Image 1 (enlarged so that a minimum block is readable, at most
// kFigureShownWidthPx wide) with every ROI box coloured by status and labelled
// with its id, the rejected quadtree blocks thin and dark, and a legend strip
// below.
cv::Mat QuadtreeFigure(const cv::Mat& image1, const hda::HdaResult& result);
// Image 1 as QuadtreeFigure shows it but at most kFigureHalfWidthPx wide, every ROI box coloured by its landing
// decision against the lander's truth (DecisionClassName) and labelled with
// its slope error (estimated - true, degrees) where it has one, and a
// legend strip with the counts below. For a run with truth.
cv::Mat DecisionFigure(const cv::Mat& image1, const FlightRun& run);
// The confusion class of a site: "safe, truly safe", "FALSE SAFE",
// "missed safe", "unsafe, truly unsafe", "no verdict", "no lander truth".
const char* DecisionClassName(const DecisionSample& sample);
// One ROI, kFigureGridHeightPx high: a title, then the image-1 box with some
// context beside the image-2 search box, each scaled to the same height
// (nearest neighbour when enlarging), the surviving matches as points joined
// by lines.
cv::Mat RoiPairFigure(const cv::Mat& image1, const cv::Mat& image2, const hda::RoiResult& roi);
// Both full images side by side (shrunk to at most kFigureShownWidthPx wide;
// small ones enlarged by a whole factor toward 1024) with every surviving
// match as a translucent line and the ROI boxes that have matches, coloured
// per ROI.
cv::Mat MatchesFigure(const cv::Mat& image1, const cv::Mat& image2, const hda::HdaResult& result);

// Creates the output folder `dir` (and its parents) if missing. Throws
// InputError naming it when it cannot be created or is not a folder.
void PrepareOutputFolder(const std::string& dir);

// Writes every output into `dir` (created if missing): result.json,
// timings.json, rois.csv, points/roi_NNN.ply, and unless !figures
// figures/quadtree.png, figures/matches.png, figures/roi_pairs/roi_NNN.png.
// Each file is written to a temporary name and renamed into place; files of
// the same names are replaced, and per-ROI files of an earlier run that this
// run does not write are removed. result.json, the mark of a whole run, is
// removed first and written last: a folder whose writing stopped halfway (a
// full disk, a kill) holds none. Returns the paths written, relative to dir,
// result.json first. Throws InputError naming the path when a folder or file
// cannot be written. `threads` draw the figures (0: every core this process
// may use, util::AvailableCores); the files do not depend on it.
std::vector<std::string> WriteFlightOutputs(const FlightRun& run, const cv::Mat& image1,
                                            const cv::Mat& image2, const std::string& dir,
                                            bool figures, int threads = 0);

}  // namespace hdabench::reference
