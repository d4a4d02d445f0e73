// Entry points of the hdabench subcommands. Each command file registers its
// subcommands on the command line (command_line.h) and calls these after the
// parse; each returns an exit code from exit_codes.h and writes its report to
// `out` and problems to `err`. The work itself lives in the modules: these
// functions only load, call and print.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core/types.hpp>

namespace hdabench::tools {

struct DatasetCheckOptions {
  std::string dataset_dir;                     // the dataset folder (holds manifest.json)
  std::optional<std::pair<int, int>> frames;   // frame indices for the baseline line; default: first and last
};
int RunDatasetCheck(const DatasetCheckOptions& options, std::ostream& out, std::ostream& err);

struct DatasetCreateOptions {
  std::string out_dir;     // folder to create; must not exist or be empty
  std::uint64_t seed = 1;  // same seed, same bytes
};
int RunDatasetCreate(const DatasetCreateOptions& options, std::ostream& out, std::ostream& err);

struct SynthCommandOptions {
  std::string out_dir;                  // folder to create; must not exist, or be empty
  std::string preset = "novac-lateral"; // novac-lateral, novac-forward, novac-boresight, truck, aircraft, helicopter
  std::string terrain;                  // mare, cratered, rocky, flank, boulders; empty: the preset's
  std::uint64_t seed = 1;               // same seed, same bytes
  int threads = 0;                      // 0: every core this process may use; the output does not depend on it
  int image_size_px = 0;                // 0: the preset's (1024)
  std::string camera_model_file;        // a .cameramodel instead of the default camera
  std::vector<std::string> overrides;   // "key=value", docs/synthetic-scenes.md
  // Sensor faults "NAME[=M]" (docs/faults.md), one magnitude each, applied in
  // order to the pair `hdabench run` takes; the truth stays the scene's.
  std::vector<std::string> faults;
  // The frames rendered: "all", "pair" (the pair `hdabench run` takes),
  // "pair+next" (and the frame after it, which the dropped-frame fault needs),
  // or frame indices and ranges ("0,6", "0-6"). The rest of the dataset is
  // the same whichever.
  std::string frames = "all";
  bool quiet = false;                   // no progress lines
};
int RunSynth(const SynthCommandOptions& options, std::ostream& out, std::ostream& err);

struct TruthCommandOptions {
  std::string dataset_dir;
  int frame = 0;
  int roi[4] = {0, 0, 0, 0};  // x, y, width, height in pixels
  bool json = false;          // print one JSON object instead of a table
};
int RunTruth(const TruthCommandOptions& options, std::ostream& out, std::ostream& err);

struct RunFlightOptions {
  std::string dataset_dir;
  std::optional<std::pair<int, int>> frames;  // default: reference::DefaultFramePair
  std::string out_dir;                        // created if missing; files of the same names replaced
  std::optional<double> flight_instructions_per_s;  // HdaOptions::flight_instructions_per_s; default: the options'
  std::optional<double> budget_s;             // HdaOptions::compute_budget_s; default: the options'
  std::optional<double> site_size_m;          // hda QuadtreeOptions::site_size_m; default: from the geometry
  std::string params_file;                    // --params: JSON of HdaOptions keys (empty: none)
  std::vector<std::string> hda_sets;          // --set hda.KEY=VALUE, in order
  std::vector<cv::Rect> rois_px;              // --roi: given ROIs in image 1 (empty: the quadtree's)
  bool figures = true;                        // write figures/ (PNG)
  bool report = true;                         // write report.html and report.md (docs/report.md)
  bool quiet = false;                         // no progress lines on err
  // --calibration-check N: re-solve the dataset's calibration N times and set
  // each ROI's slope spread beside its predicted calibration sigma
  // (reference/flight/calibration_check.h); 0: no check.
  int calibration_check_samples = 0;
  std::uint64_t calibration_check_seed = 1;
};
// hdabench run: the flight method on two frames of a dataset, its outputs
// written into out_dir (docs/flight-results.md) and the report with the
// per-ROI table printed to out.
int RunFlight(const RunFlightOptions& options, std::ostream& out, std::ostream& err);

struct CompareCommandOptions {
  std::string dataset_dir;
  std::optional<std::pair<int, int>> frames;  // default: reference::DefaultFramePair
  std::string methods = "all";                // comma-separated (reference::ParseMethodList) or "all"
  std::string out_dir;                        // created if missing; files of the same names replaced
  std::optional<double> site_size_m;          // hda QuadtreeOptions::site_size_m; default: from the geometry
  std::string params_file;                    // --params: JSON of HdaOptions keys (empty: none)
  std::vector<std::string> hda_sets;          // --set hda.KEY=VALUE, in order
  std::optional<double> fault_match_noise_px;  // HdaOptions::fault_match_noise_px (gate tests only)
  std::string colmap_executable = "colmap";   // a name looked up on PATH, or a path
  double colmap_timeout_s = 600.0;            // per COLMAP step
  bool colmap_all_frames = false;             // colmap-free on every frame of the collection window
  int colmap_max_features = 131072;           // SIFT features COLMAP keeps per image (ColmapOptions)
  // colmap-nav's matching: guided by the nav epipolar geometry within this
  // many pixels (ColmapOptions::nav_guided_max_error_px), or exact when 0.
  double colmap_nav_band_px = 0.0;
  std::optional<int> colmap_first_octave;     // ColmapOptions::sift_first_octave (unset: from the ROIs)
  int colmap_octave_resolution = 3;           // ColmapOptions::sift_octave_resolution
  double colmap_peak_threshold = 0.02 / 3;    // ColmapOptions::sift_peak_threshold
  bool opengv_dense = false;                  // OpenGV on denser ORB matches than the flight's
  std::string external_program;               // the external method's program (--external-program)
  std::vector<std::string> external_args;     // its arguments before the two files (--external-arg)
  std::optional<double> external_timeout_s;   // --external-timeout-s (default ExternalMethodOptions's)
  int opengv_overlap_tiles = 128;             // OpenGV's pose: overlap tiles at most (0: ROIs only)
  bool figures = true;                        // write flight/figures/ (PNG)
  bool report = true;                         // write report.html and report.md (docs/report.md)
  bool quiet = false;                         // no progress lines on err
};
// hdabench compare: the flight method and the reference methods on two frames
// of a dataset, per ROI; outputs in out_dir (docs/compare-results.md), the
// Markdown table printed to out. Exit codes: 0 every method ran; 4 a method
// failed for the run (its column says why; every other output is written);
// 2 bad flags; 3 an unusable dataset or output folder.
int RunCompareCommand(const CompareCommandOptions& options, std::ostream& out, std::ostream& err);

struct ReportCommandOptions {
  std::string run_dir;                  // a folder written by hdabench run or hdabench compare
  std::string dataset_dir;              // the dataset (for its maps); empty: looked for beside run_dir
  std::string python = "/usr/bin/python3";  // the interpreter that draws the plots (matplotlib)
  bool quiet = false;                   // no note lines on err
};
// hdabench report: report.html and report.md of a run or compare folder
// (docs/report.md). Exit codes: 0 written with every plot; 3 run_dir is not a
// run or compare folder, a file in it is malformed, --dataset is not a folder,
// or the report cannot be written; 4 the plots could not be drawn (no Python,
// no matplotlib, the script failed): the report is written without them.
int RunReportCommand(const ReportCommandOptions& options, std::ostream& out, std::ostream& err);

// Writes the report of a folder that `command` ("run", "compare") has just
// written from `dataset_dir`. A problem is one warning line on err
// ("hdabench <command>: report: ..."); it never changes the command's exit
// code (docs/report.md). Returns true when the report has every plot.
bool WriteReportAfterCommand(const std::string& out_dir, const std::string& dataset_dir,
                             const std::string& command, bool quiet, std::ostream& out,
                             std::ostream& err);

struct GateCommandOptions {
  std::string suite_file;             // the suite (docs/gate.md)
  std::string thresholds_file;        // the thresholds (docs/gate.md)
  std::string baseline_file;          // empty: no baseline
  std::string write_baseline_file;    // empty: do not write one
  std::string out_dir;                // entries, datasets, metrics.json, gate.md; reused by a rerun
  int jobs = 2;                       // entries at a time
  std::string colmap_executable = "colmap";
  double fault_match_noise_px = 0.0;  // fault injection into the flight method (tests of the gate)
  // hda.KEY=VALUE over every entry's own parameters: a what-if run (the
  // gate's own test sets hda.max_slope_deg=90, every site declared safe).
  std::vector<std::string> hda_sets;
  std::string shard = "1/1";          // K/N: run the entries shard K of N holds, for `gate merge`
  // Empty: the whole suite. Else only these entries, and only the thresholds
  // of the pools they give (reference::SuiteGivesThresholdPool).
  std::vector<std::string> entries;
  // Empty: every entry's methods. Else only these of each entry's methods
  // (the flight method always runs), and only the thresholds of the methods
  // left (reference::SelectGateMethods).
  std::vector<std::string> methods;
  bool quiet = false;
};
// hdabench gate: the suite through the comparison, the metrics against the
// thresholds and the baseline. Exit codes: 0 every check passed; 1 a metric
// failed its threshold, regressed against the baseline, or an entry failed;
// 2 bad flags; 3 an unusable suite, thresholds, baseline or output folder.
// With --shard K/N (N > 1): only the shard's entries, their outcomes in
// out_dir/gate_shard.json and no verdict; exit 0 when they all ran, 1 when one
// failed (the merge reports it).
int RunGateCommand(const GateCommandOptions& options, std::ostream& out, std::ostream& err);

struct GateMergeOptions {
  std::vector<std::string> shard_dirs;  // the shards' --out folders
  std::string suite_file;               // the suite the shards ran
  std::string thresholds_file;
  std::string baseline_file;            // empty: no baseline
  std::string write_baseline_file;      // empty: do not write one
  std::string out_dir;                  // entries gathered, metrics.json, gate.md, gate.html
  bool quiet = false;
};
// hdabench gate merge: the shards' entries into out_dir, then the metrics,
// table and verdict as `hdabench gate` gives them for the whole suite; the
// same exit codes, 3 also for shards that are not the suite's 1..N once each.
int RunGateMerge(const GateMergeOptions& options, std::ostream& out, std::ostream& err);

struct DemoOptions {
  std::string out_dir = "hdabench-demo";  // replaced on each run; the dataset goes in out_dir/dataset
  std::uint64_t seed = 1;                 // same seed, same bytes
  int image_size_px = 0;                  // 0: the default camera's 1024
  int threads = 0;                        // 0: every core this process may use
};
// The main job on the built-in default: generate the default synthetic
// dataset (hdabench synth, preset novac-lateral) into out_dir/dataset, then
// compare every method on it (hdabench compare) into out_dir/compare and print
// the table.
int RunDemo(const DemoOptions& options, std::ostream& out, std::ostream& err);

struct IngestStereoLunarOptions {
  std::string pair_dir;      // a StereoLunar pair folder (im_NNNNN.jpg and .exr)
  std::string out_dir;       // folder to create; must not exist or be empty
  std::string cameras_file;  // cameras.txt; empty: datasets::DefaultStereoLunarCamerasFile
  int sun = 0;               // sun position, 0-based (0, 1 or 2 for the shared pairs)
};
// hdabench ingest stereolunar: convert one sun position of a pair
// (datasets/stereolunar.h) and write it with WriteDataset. Exit codes: 0
// written and loads cleanly; 2 bad flags or an output folder in use; 3 an
// unusable source (the message names the file and line).
int RunIngestStereoLunar(const IngestStereoLunarOptions& options, std::ostream& out,
                         std::ostream& err);

struct IngestFieldOptions {
  std::string log_file;  // the field log description (JSON, docs/field-ingest.md)
  std::string out_dir;   // must not exist, or be empty
};
// hdabench ingest field: a campaign's images, navigation, LRF, camera model
// and mount into a dataset. Exit codes: 0 written (and loads cleanly); 2 the
// output folder exists and is not empty; 3 the log cannot be used (the file
// and line named; nothing written); 70 the written dataset does not load.
int RunIngestField(const IngestFieldOptions& options, std::ostream& out, std::ostream& err);

struct IngestTargetOptions {
  std::string image1;        // first image of the board
  std::string image2;        // second image
  std::string camera1;       // image 1's .cameramodel
  std::string camera2;       // image 2's; empty: camera1 (one camera moved)
  std::string board;         // "WxH" inner corners
  double spacing = 1.0;      // between neighbouring corners, the unit of every length
  std::string detector = "auto";
  std::string name;          // empty: from the image names
  std::string out_dir;       // must not exist, or be empty
};
// hdabench ingest target: two images of a chessboard as a dataset whose
// navigation is PnP on each image and whose truth is the board's plane
// (datasets/planar_target.h, docs/planar-target.md). Exit codes: 0 written
// (and loads cleanly); 2 bad flags or the output folder in use; 3 an image,
// model or board that cannot be used (nothing written); 70 the written
// dataset does not load.
int RunIngestTarget(const IngestTargetOptions& options, std::ostream& out, std::ostream& err);

struct ExportFieldOptions {
  std::string dataset_dir;
  std::string out_dir;                       // must not exist, or be empty
  std::string origin_text = "0,0,0";         // LAT,LON,HEIGHT of the local origin (WGS84)
  double clock_offset_s = 0.0;               // navigation time minus image time
};
// hdabench export field: a dataset as a field log. Exit codes: 0 written;
// 2 a bad flag; 3 an unusable dataset or output folder.
int RunExportField(const ExportFieldOptions& options, std::ostream& out, std::ostream& err);

struct CalibrateCommandOptions {
  std::vector<std::string> images;       // camera 0's chessboard images
  std::vector<std::string> pair_images;  // camera 1's, the i-th with the i-th of `images`; may be empty
  std::string board;                     // "WxH" inner corners, e.g. "9x6"
  double spacing = 0.0;                  // corner spacing (metres, or squares)
  std::string lensmodel = "LENSMODEL_OPENCV8";
  std::string detector = "auto";         // auto, opencv, mrgingham
  double focal_px = 0.0;                 // focal seed; 0: estimated
  int min_views = 5;                     // fewest usable views per camera
  std::string out_dir;                   // folder to create; must not exist or be empty
  double hda_range_m = 570.0;            // the HDA geometry of the slope-error figure
  double hda_baseline_m = 30.0;
  double hda_site_m = 10.0;
  int slope_samples = 30;                // Monte Carlo re-solves for that figure
  double slope_share = 0.1;              // the calibration's slope term under this share of...
  double method_sigma_deg = 0.0;         // ...the flight method's own slope sigma (0: not given)
  std::uint64_t seed = 1;                // of the Monte Carlo noise
  bool quiet = false;                    // no progress lines
};
// hdabench calibrate (calib/calibrate.h, docs/calibration.md). Exit codes: 0
// calibrated; 2 bad flags (board size, spacing, lens model name); 3 unusable
// inputs (unreadable images, too few views with the board: nothing calibrated,
// no model written); 4 mrcal's tool or the analysis failed.
int RunCalibrate(const CalibrateCommandOptions& options, std::ostream& out, std::ostream& err);

struct CalibDiffCommandOptions {
  std::string model_a;  // the reference calibration (e.g. the last one)
  std::string model_b;  // the new one
  std::string out_dir;  // created if missing: calib-diff.json, calib-diff.png
  int gridn = 60;       // grid points across the imager's width
  bool with_uncertainty = false;  // also A's projection uncertainty on the grid (needs its optimization inputs)
};
// hdabench calib-diff: projection difference between two calibrations of one
// camera. Exit codes: 0 ok; 2 bad flags; 3 unusable models (missing,
// unreadable, different imager sizes); 4 the analysis script failed.
int RunCalibDiff(const CalibDiffCommandOptions& options, std::ostream& out, std::ostream& err);

}  // namespace hdabench::tools
