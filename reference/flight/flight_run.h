// The flight method (hda/) on a dataset (datasets/): which frames to pair, the
// in-memory inputs the method takes from the dataset's navigation, LRF,
// gravity and ILS, and the truth of the ROIs it found where the dataset has
// truth. Poses and frames follow docs/conventions.md.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "datasets/dataset.h"
#include "datasets/synth/lander_truth.h"
#include "calib/intrinsics_modes.h"
#include "hda/calibration_sigma.h"
#include "hda/hda_options.h"
#include "hda/pipeline.h"
#include "reference/flight/hda_params.h"

namespace hdabench::reference {

// The NOVA-C geometry: about 30 m of lateral motion at a slant range of about
// 566 m. Frames are paired so that baseline / range is closest to this ratio.
inline constexpr double kPaperBaselineToRange = 30.0 / 566.0;

// The default pair, among the frames with an image: the first of them, f,
// and the later one j whose measured (navigation) baseline divided by the LRF
// range at f is closest to kPaperBaselineToRange (the first such j on a tie).
// For a dataset with every image, f = 0. Throws InputError when fewer than 2
// frames have an image.
std::pair<int, int> DefaultFramePair(const datasets::Dataset& dataset);

// The frames to render for a scene that feeds `run` (and `compare`, the gate
// and the fault study): DefaultFramePair, and with `with_next` the frame after
// image 2 when there is one (the frame that takes image 2's place when it is
// dropped). For synth::SynthOptions::frames_to_render.
std::vector<int> PairFramesToRender(const datasets::Dataset& dataset, bool with_next);

// Where the slant range at image 1 came from.
enum class RangeSource {
  kLrf,         // the LRF's sample at image 1's time
  kNavigation,  // no LRF range there: along camera 1's optical axis to the level ground through
                // the ILS, from the navigation (docs/faults.md, "Without the LRF")
};
const char* ToString(RangeSource source);  // "lrf", "navigation"

// The method's inputs for frames (frame1, frame2) from the dataset's measured
// navigation (never its truth): local_from_cam1, cam2_from_cam1, gravity, ILS,
// and the LRF sample at frame 1's time (range interpolated, beam and origin
// moved into cam1). Without an LRF range at frame 1's time (an LRF absent, or
// whose log does not cover it), the range along camera 1's optical axis from
// its centre to the level ground through the ILS, when the axis points at
// least 10 deg below the horizon (RangeSource::kNavigation). The images must be in memory (LoadOptions::keep_images);
// the returned input shares their pixels. Throws InputError for a frame index
// outside the dataset, equal frames, images not loaded, no range at frame 1
// by either way, or no navigation at the frames' times (a dataset changed in
// memory, datasets/faults.h). `range_source`, when given, receives where the
// range came from.
hda::HdaInput MakeHdaInput(const datasets::Dataset& dataset, int frame1, int frame2,
                           RangeSource* range_source = nullptr);

// Truth of one ROI (datasets/synth/truth.h definitions, in image 1).
struct RoiTruthValue {
  bool available = false;  // false: the dataset has no truth points for frame 1, or too few
  std::string why;         // when not available: the reason
  int num_points = 0;
  double slope_deg = 0.0;
  double roughness_rms_m = 0.0;
  double roughness_max_m = 0.0;
  double hazard_height_m = 0.0;
  double max_rock_height_m = 0.0;  // tallest rock whose centre is in the ROI; 0 none
  Eigen::Vector3d normal_in_local = Eigen::Vector3d::UnitZ();  // unit, up: the true plane's normal
  // The lander at the centre of the ROI's true points (datasets/synth/lander_truth.h):
  // the decision's truth. Not defined without a truth DEM, or when the
  // footprint leaves it (landing.why says which).
  datasets::synth::LandingVerdict landing;
};

// The tilt error: the angle between an estimated plane and the true one
// (between their normals, whichever way each points), degrees in [0, 90].
// Unlike the difference of slope magnitudes it sees the direction of the
// tilt, and it has no one-sided bias near a level site. NaN when either
// normal is zero or not finite.
double TiltErrorDeg(const Eigen::Vector3d& normal, const Eigen::Vector3d& true_normal);

// The truth of every ROI of `result` (same order as result.rois), from the
// dataset's truth points of frame1 (LoadOptions::keep_truth), and the
// `lander`'s truth on its truth DEM with the rocks. Every ROI gets an
// entry; without truth points they are all unavailable, with the reason.
std::vector<RoiTruthValue> TruthOfRois(const datasets::Dataset& dataset, int frame1,
                                       const hda::HdaResult& result,
                                       const datasets::synth::LanderGeometry& lander = {});

// The calibration's share of each ROI's slope uncertainty (docs/calibration.md,
// "The calibration in each slope's error budget"): available when the
// dataset's .cameramodel holds mrcal's optimization_inputs and their modes
// could be computed.
struct CalibrationTerm {
  bool available = false;
  std::string why;                          // when not available: the reason, one line
  std::string model_file;                   // the dataset's .cameramodel ("" for a dataset in memory)
  calib::IntrinsicsModes modes;             // when available
  std::vector<hda::CalibrationSigma> rois;  // when available: parallel to HdaResult::rois

  // The calibration's slope sigma of ROI i, degrees; NaN where there is none.
  double SlopeSigmaDeg(size_t i) const;
  double TiltSigmaDeg(size_t i) const;
};

// The calibration term of a run of the method on `input` with the dataset's
// camera: the modes of the dataset's model file (calib::ComputeIntrinsicsModes,
// which runs python), then each fitted ROI's sigma (hda::SiteCalibrationSigma)
// from its surviving matches. Never throws for the model or the script: a
// model without optimization_inputs, a dataset built in memory, or a failure
// of the script leaves the term unavailable, saying why.
CalibrationTerm ComputeCalibrationTerm(const datasets::Dataset& dataset, const hda::HdaInput& input,
                                       const hda::HdaOptions& options, const hda::HdaResult& result);

// Everything one run produced and what it was run on.
struct FlightRun {
  std::string dataset_name;
  int frame1 = 0;
  int frame2 = 1;
  std::string lens_model;         // the camera's mrcal lens model name
  int image_width_px = 0;         // the imager
  int image_height_px = 0;
  double baseline_m = 0.0;        // navigation baseline between the two frames, metres
  double lrf_range_m = 0.0;       // slant range at frame 1, metres: the LRF's, or see range_source
  RangeSource range_source = RangeSource::kLrf;
  hda::HdaOptions options;        // the options RunHda was given
  datasets::synth::LanderGeometry lander;  // the lander of the truth's decision (HdaSettings::lander)
  // The values of `options` set from the pair's geometry (ResolveHdaOptions);
  // empty when the options were given whole.
  std::vector<DerivedParam> derived_options;
  bool given_rois = false;        // the ROIs were given, not found by the quadtree
  hda::HdaResult result;
  // Truth per ROI, parallel to result.rois (TruthOfRois). Empty, or all
  // unavailable, when the dataset has no truth.
  std::vector<RoiTruthValue> truths;
  CalibrationTerm calibration;    // the calibration's share of each slope's sigma

  bool AnyTruth() const;
  // The slope sigma of ROI i with the calibration's term in quadrature
  // (hda::CombinedSlopeSigmaDeg): the method's own where there is no term.
  double CombinedSlopeSigmaDeg(size_t i) const;
};

// Runs the flight method on frames (frame1, frame2) of a dataset loaded with
// its images (and its truth, for the truth of the ROIs): MakeHdaInput, RunHda,
// TruthOfRois with `lander`, and what the run was made on. Throws InputError
// as MakeHdaInput and RunHda do, and for an invalid lander.
// `given_rois_px`, when not empty, are the ROIs instead of the quadtree's
// (hda::HdaInput::given_rois_px).
// `progress` is told after each ROI the method evaluates (hda::RunHda).
FlightRun RunFlight(const datasets::Dataset& dataset, int frame1, int frame2,
                    const hda::HdaOptions& options, const std::vector<cv::Rect>& given_rois_px = {},
                    const hda::RoiProgress& progress = {},
                    const datasets::synth::LanderGeometry& lander = {});

// The same with the options resolved for this pair (ResolveHdaOptions: the
// keys not given follow the LRF range at frame 1 and the navigation
// baseline), recorded in FlightRun::derived_options, and the settings'
// lander. Throws InputError also when the resolved options are unusable.
FlightRun RunFlight(const datasets::Dataset& dataset, int frame1, int frame2,
                    const HdaSettings& settings, const std::vector<cv::Rect>& given_rois_px = {},
                    const hda::RoiProgress& progress = {});

}  // namespace hdabench::reference
