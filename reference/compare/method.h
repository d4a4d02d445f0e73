// A method of the comparison as one unit: its name, what it needs of the
// pair, and a run from the pair's context to its per-ROI results and summary.
// The table of methods (MethodTable) gives `--methods`, the CLI's help and
// the guarded loop of RunCompare: every method runs inside it, so a method
// that throws fails its own column only.
//
// Adding a method: one file in reference/compare/methods/ that defines a
// function returning its MethodEntry, and its line in methods/method_table.cc.
#pragma once

#include <functional>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/rigid3.h"
#include "hda/pipeline.h"
#include "reference/colmap/colmap_runner.h"
#include "reference/compare/compare.h"
#include "reference/opengv/opengv_solvers.h"

namespace hdabench::reference {

// One ROI's (or overlap tile's) matches before any use of navigation: the
// flight matcher on the flight's boxes (RANSAC inliers), with their bearings.
struct RoiBearings {
  bool has_box = false;
  std::vector<cv::Point2d> pixels1;
  std::vector<Eigen::Vector3d> bearings1;
  std::vector<Eigen::Vector3d> bearings2;
};

// The matches of the pair: the ROIs' (parallel to the flight's ROIs) and the
// overlap tiles' (OverlapTiles).
struct PairMatches {
  std::vector<RoiBearings> rois;
  std::vector<RoiBearings> overlap;
  int overlap_tiles = 0;  // tiles laid (some may have no search box or no match)
  bool empty() const { return rois.empty(); }
};

// Which of COLMAP's reconstructions a method reads (COLMAP runs once for all).
enum class ColmapNeed { kNone, kNav, kFree };

// What a method needs of the pair beyond the flight method's run and the
// geometry; RunCompare prepares it once for every method that asks.
struct MethodNeeds {
  bool pair_matches = false;           // PairContext::Matches and PairConfiguration
  ColmapNeed colmap = ColmapNeed::kNone;  // PairContext::Colmap
};

// Everything a method may read: the dataset and pair, the options, the
// flight method's run (it found the ROIs), the navigation geometry, and what
// MethodNeeds asked for. Matches and COLMAP's results are computed when
// first asked for; what their computation threw is thrown again to every
// method that asks, inside its own guard.
class PairContext {
 public:
  PairContext(const datasets::Dataset& dataset, int frame1, int frame2, const CompareOptions& options,
              const CompareProgress& progress);
  PairContext(const PairContext&) = delete;
  PairContext& operator=(const PairContext&) = delete;
  ~PairContext();

  const datasets::Dataset& dataset() const { return *dataset_; }
  int frame1() const { return frame1_; }
  int frame2() const { return frame2_; }
  const CompareOptions& options() const { return *options_; }
  const FlightRun& flight() const { return *flight_; }

  // The navigation geometry of the pair.
  const hda::HdaInput& input() const { return input_; }  // the flight inputs (and the images)
  const Rigid3d& local_from_cam1() const { return input_.local_from_cam1; }
  const Rigid3d& local_from_cam2() const { return local_from_cam2_; }
  bool has_true_pose() const { return has_true_pose_; }
  const Rigid3d& true_cam2_from_cam1() const { return true_cam2_from_cam1_; }
  double focal_px() const { return focal_px_; }  // pixels per radian at the image centre

  // The pair's matches without navigation (MethodNeeds::pair_matches).
  const PairMatches& Matches() const;
  // The configuration of the whole pair from all its matches.
  const ConfigurationReport& PairConfiguration() const;
  // COLMAP's reconstructions (MethodNeeds::colmap), waiting for the run.
  const ColmapResults& Colmap() const;

  void Say(const std::string& message) const;

  // RunCompare's: the flight method's run, then COLMAP started alongside
  // the other methods when `nav` or `free` is wanted.
  void SetFlight(const FlightRun* flight) { flight_ = flight; }
  void StartColmap(bool nav, bool free, const std::string& workspace);

 private:
  const datasets::Dataset* dataset_;
  int frame1_, frame2_;
  const CompareOptions* options_;
  CompareProgress progress_;
  const FlightRun* flight_ = nullptr;
  hda::HdaInput input_;
  Rigid3d local_from_cam2_;
  bool has_true_pose_ = false;
  Rigid3d true_cam2_from_cam1_;
  double focal_px_ = 0.0;
  struct Lazy;
  std::unique_ptr<Lazy> lazy_;
};

// A method as the table holds it.
struct MethodEntry {
  std::string name;     // as on the command line and in every record
  std::string summary;  // one line: what it is (the CLI's help, the docs)
  MethodNeeds needs;
  // False: run only when named (`--methods all` and the default leave it out),
  // for a method that needs something the user gives (external: a program).
  bool in_all = true;
  // Fills the method's ROIs (parallel to the flight's) and its summary. A
  // method that cannot run on this pair throws (InputError with what and
  // where): the loop marks its column failed with the message.
  std::function<void(const PairContext& ctx, std::vector<MethodRoi>* rois, MethodSummary* summary)> run;
};

// Every method, in the order of the tables: the built-in ones
// (methods/method_table.cc), then those registered while a
// ScopedMethodRegistration lives.
std::vector<MethodEntry> MethodTable();

// The table's entry of a method; nullptr for an unknown name.
std::unique_ptr<MethodEntry> FindMethod(const std::string& name);

// "name  summary" per line, for the CLI's help.
std::string MethodListText();

// A method added to the table while this lives (a test's own method, or one
// that replaces a built-in of the same name, keeping its place).
class ScopedMethodRegistration {
 public:
  explicit ScopedMethodRegistration(MethodEntry entry);
  ~ScopedMethodRegistration();
  ScopedMethodRegistration(const ScopedMethodRegistration&) = delete;
  ScopedMethodRegistration& operator=(const ScopedMethodRegistration&) = delete;

 private:
  std::string name_;
};

}  // namespace hdabench::reference
