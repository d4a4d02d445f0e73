// One HDA run on disk: camera model, frames, navigation, LRF, camera mount,
// gravity, ILS and optional truth. The format is specified in
// docs/dataset-format.md (format_version 1); frames and transforms follow
// docs/conventions.md.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "calib/camera_model.h"
#include "calib/rigid3.h"
#include "datasets/navigation.h"
#include "datasets/problem.h"

namespace hdabench::datasets {

constexpr char kDatasetFormatName[] = "hdabench-dataset";
constexpr int kDatasetFormatVersion = 1;
constexpr char kManifestFileName[] = "manifest.json";
// A quaternion is accepted when | |q| - 1 | <= this (docs/conventions.md).
constexpr double kUnitNormTolerance = 1e-6;

struct FrameRecord {
  int index = 0;       // 0..N-1 in table order
  double time_s = 0.0;
  // Relative to the dataset folder, '/' separated; empty for a frame of the
  // trajectory that has no image (a scene rendered with only some frames:
  // hdabench synth --frames). Its time still counts.
  std::string image_path;
  // CV_8UC1 or CV_16UC1, camera imager size. Filled by LoadDataset when
  // LoadOptions::keep_images; required by WriteDataset for a frame with an
  // image path.
  cv::Mat image;

  bool HasImage() const { return !image_path.empty(); }
};

// The indices of the frames that have an image, ascending.
std::vector<int> FramesWithImages(const std::vector<FrameRecord>& frames);

// Truth 3D points of one frame: the local-frame point each pixel's ray hits.
struct TruthPoints {
  int frame = 0;     // frame index
  std::string file;  // .npy, relative to the dataset folder
  // CV_32FC3, camera height x width; (NaN, NaN, NaN) where the ray hits
  // nothing. Filled by LoadDataset when LoadOptions::keep_truth; required by
  // WriteDataset.
  cv::Mat points_in_local_m;
};

// Truth terrain heights on a regular grid of the local x-y plane. Cell (r, c)
// is the height (local z, metres) at x = origin.x + c * spacing_m,
// y = origin.y - r * spacing_m: rows run from north to south, columns from west
// to east, like a north-up map.
struct TruthDem {
  std::string file;  // .npy, relative to the dataset folder
  Eigen::Vector2d origin_in_local_m = Eigen::Vector2d::Zero();  // centre of cell (0, 0)
  double spacing_m = 1.0;                                        // > 0
  int width_cells = 0;   // from the file (columns)
  int height_cells = 0;  // from the file (rows)
  // CV_32FC1, height_cells x width_cells, all finite. Filled by LoadDataset when
  // LoadOptions::keep_truth; required by WriteDataset.
  cv::Mat height_in_local_m;
};

// A truth rock: a boulder of the scene, for scoring hazard maps.
struct TruthRock {
  Eigen::Vector3d center_in_local_m = Eigen::Vector3d::Zero();  // rock centre, local frame
  double diameter_m = 0.0;             // > 0
  double height_above_ground_m = 0.0;  // > 0 and <= diameter_m
};

// How a synthetic dataset's images were made, for checks of the imagery
// itself (hdabench imagery): the sun and the sensor noise. Absent from field
// data.
struct TruthImaging {
  Eigen::Vector3d sun_in_local = Eigen::Vector3d::UnitZ();  // unit vector toward the sun, local frame
  double gain_electrons_per_dn = 40.0;  // shot noise variance = DN / gain; 0 = no shot noise
  double read_noise_dn = 0.0;           // >= 0: read noise, DN (1 sigma)
};

// The largest sensor gain and read noise a dataset may state (and the
// renderer take): a read noise beyond a 16-bit pixel's full scale, or a gain
// beyond a million electrons per DN, describes no imager.
constexpr double kMaxGainElectronsPerDn = 1e6;
constexpr double kMaxReadNoiseDn = 65535.0;

struct Truth {
  std::vector<TruthPoints> points;  // any subset of the frames, at most one each
  std::optional<TruthDem> dem;
  std::optional<TruthImaging> imaging;
  // True body poses local_from_body (Dataset::nav holds the measured ones, with
  // their errors): same table schema and checks as the navigation table, and
  // its span covers every frame time. Present when navigation_file is not
  // empty (.csv, relative to the dataset folder). Always loaded. The writer
  // writes the velocity (or sigma) columns when a sample has a non-zero
  // velocity (or sigma).
  std::string navigation_file;
  std::vector<NavSample> navigation;  // strictly increasing times
  // Rocks of the scene. Present when rocks_file is not empty (.csv, relative to
  // the dataset folder); an empty table (no rocks) is valid. Always loaded.
  std::string rocks_file;
  std::vector<TruthRock> rocks;

  bool Empty() const {
    return points.empty() && !dem.has_value() && !imaging.has_value() && navigation_file.empty() && navigation.empty() &&
           rocks_file.empty() && rocks.empty();
  }
};

struct Dataset {
  explicit Dataset(calib::CameraModel camera_model) : camera(std::move(camera_model)) {}

  std::string name;
  std::string description;
  // Folder the dataset was loaded from; empty for one built in memory.
  std::string dir;

  // File names in the dataset folder (relative, '/' separated).
  std::string camera_model_file = "camera.cameramodel";
  std::string frames_file = "frames.csv";
  std::string nav_file = "nav.csv";
  std::string lrf_file = "lrf.csv";

  calib::CameraModel camera;
  std::vector<FrameRecord> frames;  // frames[i].index == i
  std::vector<NavSample> nav;       // strictly increasing times
  bool nav_has_velocity = false;    // vx_mps, vy_mps, vz_mps columns
  bool nav_has_sigmas = false;      // sigma_* columns
  std::vector<LrfSample> lrf;       // strictly increasing times

  Rigid3d cam_from_body;                                             // camera mount
  Eigen::Vector3d gravity_in_local_mps2 = Eigen::Vector3d(0.0, 0.0, -1.62);
  Eigen::Vector3d ils_in_local_m = Eigen::Vector3d::Zero();          // intended landing site
  Eigen::Vector3d lrf_origin_in_body_m = Eigen::Vector3d::Zero();    // start of the LRF beam

  Truth truth;

  // Poses. Frame indices must be in [0, frames.size()) and times inside the
  // navigation span (true for every frame of a loaded dataset); otherwise these
  // throw std::out_of_range with the index or time and the valid range.
  //
  // local_from_body at a time (InterpolateLocalFromBody).
  Rigid3d LocalFromBodyAt(double time_s) const;
  // cam_from_local = cam_from_body * inverse(local_from_body(t_frame)).
  Rigid3d CamFromLocal(int frame) const;
  // cam2_from_cam1 = cam_j_from_local * inverse(cam_i_from_local), i = frame1, j = frame2.
  Rigid3d Cam2FromCam1(int frame1, int frame2) const;
  // Distance between the two camera centres in the local frame, metres.
  double BaselineM(int frame1, int frame2) const;
  // LRF slant range at a time, linear between samples (InterpolateLrfRange).
  double LrfRangeAt(double time_s) const;
  // Camera centre of a frame in the local frame, metres.
  Eigen::Vector3d CameraCenterInLocal(int frame) const;

  // The same poses from the truth navigation (truth.navigation) instead of the
  // measured one. Throw std::out_of_range naming the truth navigation when the
  // dataset has none or the time is outside its span, and for a bad frame
  // index as above.
  Rigid3d TrueLocalFromBodyAt(double time_s) const;
  Rigid3d TrueCamFromLocal(int frame) const;
  Rigid3d TrueCam2FromCam1(int frame1, int frame2) const;
};

struct LoadOptions {
  // Decode every image to prove it is readable. When false, only the PNG chunk
  // structure, CRCs and header (size, channels, bit depth) are checked.
  bool decode_images = true;
  // Keep the decoded images in Dataset::frames[i].image (implies decoding).
  bool keep_images = false;
  // Read every truth value to check it (finite, NaN only as whole points). When
  // false, only the .npy headers and sizes are checked.
  bool check_truth_values = true;
  // Keep the truth arrays in Dataset::truth (implies reading them).
  bool keep_truth = false;
  // The frames a command uses, chosen from the dataset as read before the
  // images and the truth (its frames, navigation and LRF tables; called only
  // when they have no problem): only their images are decoded (and kept) and
  // only their truth points read (and kept); every other frame's image and
  // truth file is checked as with decode_images and check_truth_values false.
  // Empty function, or one that throws: every frame.
  std::function<std::vector<int>(const Dataset&)> frames_used;
  // With keep_truth or check_truth_values: false leaves the DEM's heights
  // unread (its header and size are checked), for commands that do not use it.
  bool read_dem = true;
};

struct DatasetLoadResult {
  std::optional<Dataset> dataset;  // present exactly when problems is empty
  std::vector<Problem> problems;   // every defect found, in file order

  bool Ok() const { return problems.empty() && dataset.has_value(); }
  // "ok: NAME, N frames" or "N problem(s)".
  std::string Summary() const;
};

// Reads and checks the dataset in folder `dir` (docs/dataset-format.md, "What
// the loader checks"). Every problem is reported, not only the first; the
// dataset is returned only when there is none. Never throws for anything found
// on disk and prints nothing. Decoding images redirects stderr (fd 2) for the
// duration of each decode, so do not load from several threads at once.
DatasetLoadResult LoadDataset(const std::string& dir, const LoadOptions& options = LoadOptions());

// Writes `dataset` into folder `dir` in the format LoadDataset reads, using the
// file names held in `dataset` (doubles printed so they read back identical,
// images as PNG, truth as .npy). Everything is written into a temporary sibling
// folder that is renamed to `dir` at the end, so `dir` either receives the
// whole dataset or is left as it was. `dir` must not exist or be an empty
// folder. Throws std::invalid_argument when the dataset cannot be written as is
// (an image or truth array missing, of the wrong type or size; a bad or
// repeated path; frame indices not 0..N-1; truth navigation samples or rocks
// without a file name), and InputError when `dir` is not
// usable or a file cannot be written.
void WriteDataset(const Dataset& dataset, const std::string& dir);

}  // namespace hdabench::datasets
