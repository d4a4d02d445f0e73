// The per-ROI comparison (`hdabench compare`): for one frame pair of a
// dataset, the flight method (hda/) finds the ROIs of image 1 and estimates
// their slopes; the reference methods reconstruct the same pair
// independently and the comparison fits each ROI's plane to each method's
// points, next to the truth where the dataset has it.
//
// The methods (names as on the command line) are the table of method.h:
// each is one file of reference/compare/methods/, and `hdabench compare
// --help` lists them.
//
// A reference method's points belong to an ROI through their observation in
// image 1 (inside the ROI's image-1 box). Every method's ROI plane is fitted
// the same way: the errors-in-variables fit of hda::FitPlaneWithCovariance
// with each point's two-view covariance from the method's own camera centres
// (TLS would tilt every two-view cloud toward the line of sight), slope against
// the dataset's gravity. Frames and units follow docs/conventions.md; the
// output formats are in docs/compare-results.md.
#pragma once

#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "datasets/dataset.h"
#include "hda/hda_options.h"
#include "hda/pipeline.h"
#include "reference/ceres/ceres_refine.h"
#include "reference/colmap/colmap_runner.h"
#include "reference/flight/flight_outputs.h"
#include "reference/flight/flight_run.h"
#include "reference/direct/dense_stereo.h"
#include "reference/direct/plane_direct.h"
#include "reference/opengv/opengv_solvers.h"
#include "reference/reconstruction/reconstruction.h"

namespace hdabench::reference {

// kMethodFlight: reference/flight/slope_statistics.h.
inline constexpr char kMethodFlightRefined[] = "flight-refined";
inline constexpr char kMethodColmapNav[] = "colmap-nav";
inline constexpr char kMethodColmapFree[] = "colmap-free";
inline constexpr char kOpenGvMethodPrefix[] = "opengv-";
inline constexpr char kMethodDenseNav[] = "dense-nav";
inline constexpr char kMethodPlaneNav[] = "plane-nav";
inline constexpr char kMethodExternal[] = "external";

// The image-1 tiles whose features join the ROIs' in the OpenGV methods'
// pose: squares of the largest ROI side on a grid over the image, every k-th
// row and column with k the smallest that leaves at most max_tiles of them
// (so they spread over the whole image whatever its size), less those that
// meet an ROI (no feature counted twice). Row by row, top first. None when
// there are no ROIs or max_tiles <= 0.
std::vector<cv::Rect> OverlapTiles(int image_width_px, int image_height_px,
                                   const std::vector<cv::Rect>& roi_boxes_px, int max_tiles);

// Every method `all` stands for, in the order of the tables: the table's
// methods but those that run only when named (external, which needs a
// program).
std::vector<std::string> AllMethodNames();
// Every method name of the table, those that run only when named included.
std::vector<std::string> KnownMethodNames();
// "flight,colmap-nav" -> {"flight", "colmap-nav"}; "all" -> AllMethodNames().
// The flight method is always run (it finds the ROIs); it is added first when
// not listed. Throws InputError naming an unknown or repeated method and
// listing the valid names.
std::vector<std::string> ParseMethodList(const std::string& comma_separated);

// The COLMAP settings a user gives by name: compare's --colmap-* flags and a
// gate suite's "colmap" object (docs/gate.md); unset: ColmapOptions' own.
struct ColmapSettings {
  std::optional<int> max_features;       // --colmap-max-features: ColmapOptions::sift_max_num_features
  std::optional<int> first_octave;       // --colmap-first-octave: sift_first_octave
  std::optional<int> octave_resolution;  // --colmap-octave-resolution: sift_octave_resolution
  std::optional<double> peak_threshold;  // --colmap-peak-threshold: sift_peak_threshold
  std::optional<double> nav_band_px;     // --colmap-nav-band-px: nav_guided_max_error_px
  // The settings given, over *options: the one place their names meet
  // ColmapOptions' fields.
  void ApplyTo(ColmapOptions* options) const;
};

// The refinement's defaults for the comparison: the nav prior with the flight
// method's own nav sigmas (hda::PredictionOptions) and the pixel noise its
// matches are measured to have (HdaOptions::match_error_px). RunCompare
// replaces these three with the flight method's options as resolved for the
// pair (FlightRun::options).
CeresRefineOptions DefaultRefineOptions();

// The external method (methods/external.cc, docs/external-method.md): the
// program it runs as `program args... INPUT_JSON OUTPUT_JSON`, in work_dir.
struct ExternalMethodOptions {
  std::string program;            // a path, or a name looked up in PATH; empty: none given
  std::vector<std::string> args;  // before the two file arguments
  // Wall-time limit of the program, seconds; on expiry it and every process it
  // started are ended, and the column fails. A learned or dense method on one
  // pair takes seconds to minutes; ten minutes is far past a working one.
  double timeout_s = 600.0;
  // Its input, output and log (input.json, output.json, program.log); empty:
  // a temporary folder, removed after the run.
  std::string work_dir;
  std::vector<std::string> Validate() const;
};

struct CompareOptions {
  std::vector<std::string> methods = AllMethodNames();
  // The flight method (and the matcher the OpenGV methods use); the keys not
  // given follow the pair's geometry (ResolveHdaOptions). Set a key with
  // hda.Set so that it is kept as given.
  HdaSettings hda;
  ColmapOptions colmap;           // workspace: <out>/colmap
  OpenGvOptions opengv;
  CeresRefineOptions refine = DefaultRefineOptions();
  // flight-refined: the range finder's 1-sigma range noise, metres, the
  // weight of its range in the adjustment (the synthetic scenes' LRF has
  // 0.10 m; a flight laser altimeter is of that order).
  double lrf_range_sigma_m = 0.10;
  DirectPlaneOptions direct_plane;  // plane-nav
  DenseStereoOptions dense_stereo;  // dense-nav
  ExternalMethodOptions external;   // external
  // The ROIs (image-1 boxes) instead of the quadtree's, when not empty
  // (hda::HdaInput::given_rois_px): every method judges these.
  std::vector<cv::Rect> given_rois_px;
  // The matches the OpenGV methods use: the flight matcher's ORB matches with
  // the flight's options (false), or denser ones over the same boxes (true:
  // 2000 ORB keypoints per box at a FAST threshold of 5, the rest as the
  // flight's).
  bool opengv_dense_features = false;
  // Features over the whole overlap for the OpenGV methods' pose (and the
  // pair's configuration): at most this many tiles of the ROIs' size that meet
  // no ROI (OverlapTiles), each predicted into image 2 by the flight method
  // and matched like an ROI; their matches join the pose, never an ROI's
  // plane. 0: the ROIs' matches only. 128 tiles of 32 px (the default scene)
  // hold about as many matches as its ROIs (3700 against 4000), spread over the
  // whole image, for about 1.5 s more of the five solvers; the cap bounds that
  // cost whatever the image and ROI sizes.
  int opengv_overlap_tiles = 128;
  // Angular noise assumed for every method's points when weighting the plane
  // fit (only the shape of the covariances matters to the fit's normal).
  double fit_pixel_sigma_px = 0.5;
  // A method's ROI needs this many points for a plane (as the flight's min_points).
  int min_points = 10;
  // Every violated constraint, one message each.
  std::vector<std::string> Validate() const;
};

// Distances of a method's points to the true terrain surface (the truth DEM,
// rocks not included): |z - h(x, y)| / sqrt(1 + |grad h|^2), the distance to
// the local tangent plane of the surface. Shares within 0.1, 0.3 and 1 m, as
// ETH3D reports accuracy.
struct PointAccuracy {
  bool available = false;  // false: no truth DEM, or no point over it
  int num_points = 0;
  double median_m = 0.0;
  double within_0_1_m = 0.0;  // fractions in [0, 1]
  double within_0_3_m = 0.0;
  double within_1_m = 0.0;
};

// What became of one method on one ROI (compare.json "status", ToString).
enum class MethodRoiStatus {
  kOk,            // "ok": the ROI's points were fitted
  kTooFewPoints,  // "too few points": fewer points (or usable matches) than the fit needs
  kDegenerate,    // "degenerate": the points are collinear
  kFailed,        // "failed": the method failed for the run
  kNoSearchBox,   // "no search box": the ROI was not predicted in image 2
  kPlanar,        // "planar": OpenGV and colmap-free: the pair's configuration cannot
                  // give a confident free relative pose, so no slope
  kLowParallax,   // "low parallax": likewise; plane-nav: the pose gives the ROI no parallax;
                  // flight-refined: the flight method refused the ROI before matching for that;
                  // dense-nav: too little for the disparity step to give a slope
  kPoseFailed,    // "pose failed": OpenGV found no pose
  kOutsideOverlap,  // "outside overlap": plane-nav, dense-nav: too few of the ROI's pixels are seen in image 2
                    // (dense-nav: or in the rectified field)
  kNoTexture,       // "no texture": plane-nav: the ROI's pixels do not constrain its plane;
                    // dense-nav: too few of them have a disparity
  kNotRectifiable,  // "not rectifiable": dense-nav: the pair has no baseline, one too short for the
                    // matcher's disparity step, or its epipole leaves no part of image 1 to rectify
  kDiverged,        // "diverged": plane-nav: the photometric fit did not give a plane
  kFlight,        // the flight method: its own status, MethodRoi::flight_status. The last:
                  // the report's record check takes every status before it as a name
};
const char* ToString(MethodRoiStatus status);  // the names above

// The status of an ROI whose configuration is not well-conditioned: kPlanar,
// kLowParallax or kTooFewPoints (kOk for a well-conditioned one).
MethodRoiStatus StatusOfConfiguration(ConfigurationType type);

// One method on one ROI.
struct MethodRoi {
  MethodRoiStatus status = MethodRoiStatus::kFailed;
  hda::RoiStatus flight_status = hda::RoiStatus::kNotEvaluated;  // status == kFlight only
  // The status's name: the flight method's own for it ("evaluated", ...),
  // ToString(status) for the others.
  std::string StatusName() const;
  std::string reason;             // one line with numbers
  int num_points = 0;
  bool has_fit = false;           // a plane was fitted: slope, normal and roughness are meaningful
  // Whether the method stands by its slope: has_fit and a status with a
  // slope (StatusHasSlope; a degenerate ROI's plane is a diagnostic).
  bool HasSlope() const;
  double slope_deg = 0.0;
  Eigen::Vector3d normal_in_local = Eigen::Vector3d::UnitZ();  // the fitted plane's unit normal, up
  double roughness_rms_m = 0.0;
  double roughness_max_m = 0.0;
  bool has_sigma = false;         // the method predicts its slope uncertainty (flight only)
  double slope_sigma_deg = 0.0;
  // The camera calibration's share of the slope sigma (flight only, where
  // the run has a calibration term; NaN otherwise): within-two-sigma uses
  // the two in quadrature.
  double slope_sigma_calibration_deg = std::numeric_limits<double>::quiet_NaN();
  std::string configuration;      // OpenGV, colmap-free: the pair's (well-conditioned, planar, low parallax, too few points)
  PointAccuracy accuracy;
  std::vector<Eigen::Vector3d> points_in_local_m;  // the method's points in the ROI
  // The image-1 positions the method's plane stands on (pixel centres at
  // whole numbers) and their weights in its fit (empty: alike): its points'
  // pixels, or a photometric fit's pixels with their information. Empty when
  // the method does not say (external).
  std::vector<Eigen::Vector2d> support_px;
  std::vector<double> support_weights;
  // The truth of that support (RunCompare, where the dataset has truth
  // points): the plane of the ground the method looks at, weighted as it
  // weighs it (datasets/synth/truth.h, ComputeSupportTruth).
  struct OwnTruth {
    bool available = false;
    std::string why;  // when not available
    int num_points = 0;
    double slope_deg = 0.0;
    Eigen::Vector3d normal_in_local = Eigen::Vector3d::UnitZ();
  };
  OwnTruth own_truth;
  double wall_s = 0.0;           // wall time spent on this ROI (per-ROI methods only)
};

// The ROI as the statistics see it (reference/flight/slope_statistics.h),
// against its truth (nullptr: none).
SlopeSample SampleOfMethodRoi(const MethodRoi& roi, const RoiTruthValue* truth);

// The ROI's landing decision as the decision statistics see it
// (reference/flight/decision_statistics.h): what the method declared under
// the flight method's slope limit, against its truth (nullptr: none), with
// the flight method's rank for the flight column.
DecisionSample DecisionOfMethodRoi(const MethodRoi& roi, const RoiTruthValue* truth, double max_slope_deg,
                                   int flight_rank);

struct MethodSummary {
  std::string method;
  bool ok = true;               // false: the method failed for the run
  std::string failure;          // why, when not ok
  std::string note;             // one line about the run of the method (solver status, logs)
  int rois_with_fit = 0;            // ROIs with a slope (MethodRoi::HasSlope)
  ErrorStats slope_vs_truth_deg;    // |slope - truth| over ROIs with a slope, truth and >= kMinPointsForSlopeStats points
  ErrorStats tilt_vs_truth_deg;     // TiltErrorDeg against the true plane, same ROIs
  double slope_bias_deg = 0.0;      // mean of slope - truth (signed), same ROIs; 0 when there are none
  // The tilt error taken apart, over those of the same ROIs with an own truth
  // (MethodRoi::own_truth): the definition part (own truth against the
  // site's), the estimation part (the method against its own truth), and
  // each one's signed slope bias (0 when there are none).
  ErrorStats tilt_definition_deg;
  ErrorStats tilt_estimation_deg;
  double slope_definition_bias_deg = 0.0;
  double slope_estimation_bias_deg = 0.0;
  ErrorStats slope_vs_colmap_nav_deg;  // |slope - colmap-nav's| where both have a fit with enough points
  ErrorStats roughness_vs_truth_m; // |roughness rms - truth rms|, metres, same ROIs as slope_vs_truth
  PointAccuracy accuracy;       // over all the method's points inside ROIs
  // Whole-pair relative pose against the truth (the method's own estimate;
  // for OpenGV solvers, the solve on the pair's matches pooled).
  bool has_pose_error = false;
  double rotation_error_deg = 0.0;
  double translation_direction_error_deg = 0.0;
  double wall_s = 0.0;         // wall time of the method for the run
  double time_ratio_to_flight = 0.0;
  // The flight method only: its time on the flight computer, predicted from
  // its counted work (hda::HdaResult::FlightSeconds); -1 for the others.
  double flight_computer_s = -1.0;
  DecisionPool decision;       // its landing decisions against the lander's truth
};

struct CompareRun {
  FlightRun flight;                         // dataset, frames, options, HdaResult, truths
  std::vector<std::string> methods;         // in table order, flight first
  std::vector<std::vector<MethodRoi>> rois; // [method][roi], parallel to flight.result.rois
  std::vector<MethodSummary> summaries;     // parallel to methods
  bool any_truth = false;
  std::string colmap_workspace;             // where COLMAP's files and logs are, when it ran
};

using CompareProgress = std::function<void(const std::string& message)>;

// Runs every method of options.methods on frames (frame1, frame2) of a dataset
// loaded with images (and truth, for the truth columns); COLMAP reads the
// frames' image files from the dataset's folder. Each method runs inside a
// guard (method.h): one that throws marks its column failed with the reason,
// and the others are still computed. Throws InputError for invalid options or
// frames, and what the flight method throws (it finds the ROIs).
CompareRun RunCompare(const datasets::Dataset& dataset, int frame1, int frame2,
                      const CompareOptions& options, const std::string& colmap_workspace,
                      const CompareProgress& progress = nullptr);

// RunCompare's step after the methods: each method ROI's own truth
// (MethodRoi::own_truth) from the dataset's truth points of frame 1, where
// the ROI has a plane, a site truth and a support; the reason elsewhere.
void AttachOwnTruths(const datasets::Dataset& dataset, CompareRun* run);

// RunCompare's last step: each method's statistics (MethodSummary's counts,
// errors against the truth and colmap-nav, point accuracy, time ratio) from
// run->rois, by the one rule of reference/flight/slope_statistics.h.
// run->summaries holds one per method, with what each method filled.
void SummariseCompareRun(CompareRun* run);

// A whole-run reconstruction split by ROI (points whose image-1 observation
// is inside the ROI's image-1 box), each ROI fitted with FitRoiPoints and
// scored against the truth DEM where there is one. Camera 2's centre comes
// from the reconstruction's pose when it has one, else from the navigation.
// A failed reconstruction gives every ROI the status "failed" with its reason;
// an ROI without points gets "too few points".
std::vector<MethodRoi> RoisOfReconstruction(const PairReconstruction& recon,
                                            const hda::HdaResult& flight,
                                            const datasets::Dataset& dataset,
                                            const Rigid3d& local_from_cam1,
                                            const Rigid3d& nav_local_from_cam2, int min_points);

// The fit every reference method's ROI gets (see the file comment). camera
// centres in the local frame; points in the local frame.
struct RoiFit {
  MethodRoiStatus status = MethodRoiStatus::kTooFewPoints;  // kOk, kTooFewPoints or kDegenerate
  int num_points = 0;
  double slope_deg = 0.0;
  double roughness_rms_m = 0.0;
  double roughness_max_m = 0.0;
  Eigen::Vector3d normal_in_local = Eigen::Vector3d::UnitZ();  // kOk: the fitted plane's unit normal, up
};
RoiFit FitRoiPoints(const std::vector<Eigen::Vector3d>& points_in_local,
                    const Eigen::Vector3d& camera1_centre_in_local,
                    const Eigen::Vector3d& camera2_centre_in_local,
                    const Eigen::Vector3d& gravity_in_local, int min_points);

// The external method's output.json (docs/external-method.md) as text: one
// MethodRoi per id of `roi_ids` (the flight method's ROIs, in their order),
// an ROI it does not give "failed" with that reason; slopes against
// `gravity_in_local`, point accuracy against `dem` when given; *note the
// output's note and how many ROIs it left out. Throws InputError naming
// `where_file` and the record for anything unusable (not JSON, another format,
// an unknown or repeated id, an unknown status, "ok" without a finite,
// non-zero normal).
void ParseExternalOutput(const std::string& text, const std::string& where_file, const std::vector<int>& roi_ids,
                         const Eigen::Vector3d& gravity_in_local, const datasets::TruthDem* dem,
                         std::vector<MethodRoi>* rois, std::string* note);

// Point accuracy against the truth DEM (see PointAccuracy).
PointAccuracy ComputePointAccuracy(const std::vector<Eigen::Vector3d>& points_in_local,
                                   const datasets::TruthDem& dem);

}  // namespace hdabench::reference
