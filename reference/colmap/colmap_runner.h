// The COLMAP references (README, "The references"): the Debian `colmap` 3.8
// command-line program, CPU only, on an image pair (optionally on every frame
// of the collection window):
//
//   feature_extractor   SIFT, one camera for all images with the intrinsics
//                       given (never estimated), no GPU
//   exact_matcher       not a COLMAP program: the bench reads the descriptors
//                       from COLMAP's database and matches every image pair
//                       exactly with COLMAP's rules (reference/colmap/sift_matching.h),
//                       in place of COLMAP's approximate exhaustive_matcher
//   nav_guided_matcher  colmap-nav's matching when ColmapOptions::
//                       nav_guided_max_error_px > 0: COLMAP's rules, each keypoint
//                       compared only with those of the other image near its
//                       epipolar line under the nav relative pose and in
//                       front of both cameras, as COLMAP's guided matching
//                       does with the geometry it estimated. colmap-free then
//                       matches exactly in a copy of the database, so that
//                       nothing of the navigation reaches it.
//   matches_importer    COLMAP's two-view geometric verification (RANSAC) of
//                       those raw matches (--match_type raw), no GPU
//   colmap-nav          point_triangulator on the pair with the navigation
//                       poses held fixed (cam_from_local): points come out in
//                       the local frame directly. COLMAP 3.8 holds poses and
//                       intrinsics fixed in this step's bundle adjustment.
//   colmap-free         mapper (incremental SfM, initial pair = images 1 and 2,
//                       intrinsics fixed), then a similarity transform into the
//                       local frame from the navigation poses (below).
//
// Camera: the mrcal model becomes COLMAP's camera where the formulas are the
// same: LENSMODEL_PINHOLE -> PINHOLE (fx fy cx cy), LENSMODEL_OPENCV4 ->
// OPENCV (fx fy cx cy k1 k2 p1 p2), LENSMODEL_OPENCV5 and _OPENCV8 ->
// FULL_OPENCV (fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6; k3..k6 zero where the
// model lacks them): mrcal's OPENCV models and COLMAP's OPENCV/FULL_OPENCV
// are OpenCV's distortion, radial (1 + k1 r2 + k2 r4 + k3 r6) /
// (1 + k4 r2 + k5 r4 + k6 r6) then tangential 2 p1 x y + p2 (r2 + 2 x2),
// p1 (r2 + 2 y2) + 2 p2 x y. The principal point moves by +0.5 px (COLMAP's
// pixel origin, reference/colmap/colmap_adapter.h). Every other lens model (splined,
// CAHVOR, CAHVORE, OPENCV12, LATLON, LONLAT, STEREOGRAPHIC, ...) has no COLMAP
// equivalent: the images are resampled to a pinhole camera of the same imager
// size (fx fy cx cy of the model's core when it has one, else the focal length
// at the imager centre and the centre as principal point) through
// CameraModel::Project/Unproject, COLMAP works on those, and every observation
// is mapped back to the original image's pixel through its bearing.
//
// Alignment of colmap-free: with R_i the rotation of cam_i_from_local (nav)
// and W_i that of cam_i_from_world (mapper), each camera gives an estimate
// R_i^T W_i of local_from_world's rotation; the rotation is their chordal L2
// mean (for the pair: the mean of two), so the orientations fix all three
// axes (the centres alone leave a rotation about the baseline free). The scale
// is the ratio of the centres' RMS spreads about their centroids (for the
// pair: nav baseline / model baseline), the translation maps the model
// centroid of the centres onto the nav one. cam2_from_cam1 of colmap-free is
// the mapper's relative pose with its translation scaled by that scale.
//
// Every reconstructed point observed in image 1 becomes a ReconstructedPoint
// (point in the local frame, its image-1 observation in hdabench pixels of the
// original image). `seconds` of each method is the wall time of the shared
// steps (image preparation, extraction, exact matching, verification) plus its
// own step and post-processing: the shared time is counted in both methods.
//
// Determinism (measured with COLMAP 3.8 on this bench's synthetic pairs):
//  * feature_extractor gives the same keypoints every run, and the same
//    descriptors but for about one keypoint in 10000: those refined onto the
//    last pixel row of their octave, whose descriptor VLFeat never computes,
//    so COLMAP stores whatever its buffer held (zeros in one run, another
//    vector in the next; seen on 1024 x 1024 frames). The exact matcher
//    leaves every keypoint where that may happen out of the matching
//    (SiftDescriptorMayBeUnset in reference/colmap/sift_matching.h; its log counts
//    them per image: 0 to 4 of ~11000 per 1024 x 1024 frame, 1 or 2 of ~4100
//    per 512 x 512 frame).
//  * COLMAP's exhaustive_matcher is NOT, which is why the bench does not use
//    it: on the CPU it searches FLANN's randomised kd-trees (approximate,
//    seeded from the C library's global rand(), outside COLMAP's own
//    seeding), so every run kept a slightly different match set (e.g. 1756
//    vs 1748 of ~4100 features), even with threads = 1, and no option of 3.8
//    selects an exact matcher.
//  * exact_matcher compares every pair of descriptors (integer dot products,
//    exact, single-threaded): its matches depend on the keypoints, the
//    reliable descriptors and the options alone (the same match list on
//    every run).
//  * matches_importer (COLMAP 3.8's FeaturePairsFeatureMatcher) verifies the
//    pairs one after the other in one thread whatever
//    --SiftMatching.num_threads, with COLMAP's random numbers: a per-thread
//    std::mt19937 with a fixed seed. point_triangulator and mapper
//    draw from the same generators. `--random_seed` changes nothing visible
//    (seed 5 gave the same model as the default 0).
// So with threads = 1 a run gives the same bytes every time: two runs on the
// same images give identical matches.txt and byte-identical nav and free
// models (cameras.bin, images.bin, points3D.bin), and `hdabench compare`
// gives an identical compare.json, also with use_all_frames on 13 frames, 6
// of which had a descriptor that differed between the two extractions
// (tests/reference/colmap_runner_test.cc, tests/reference/compare_test.cc). With threads = 2
// the models usually agree too, but not always: in one of 8 double runs the
// mapper's points3D.bin differed (multi-threaded bundle adjustment sums in a
// varying order), hence the default of 1. All of this is on one machine:
// COLMAP's bundle adjustment goes through the system's BLAS/LAPACK (ATLAS
// here), and another implementation may round differently.
// Workspace layout (one folder per run):
//   images/frame_NNN.png   the frames as 8-bit grey PNG (resampled when the
//                          lens model has no COLMAP equivalent); NNN = index
//                          in ColmapInput::image_paths
//   database.db            COLMAP's database (features, matches; colmap-nav's
//                          guided matches when nav_guided_max_error_px > 0)
//   free.db                colmap-free's copy of it with the exact matches
//                          (guided matching with both methods only)
//   matches.txt            exact_matcher's raw matches, matches_importer's input
//   nav_matches.txt        nav_guided_matcher's raw matches
//   logs/NN-<step>.log     stdout and stderr of each COLMAP step (glog
//                          included: --log_to_stderr 1); exact_matcher's
//                          own: its options, per image the descriptors and
//                          those left out, per pair the matches and time
//   nav/input/             cameras.txt, images.txt (nav poses), points3D.txt (empty)
//   nav/model/             point_triangulator's output (binary)
//   free/0/                mapper's output (binary)
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "calib/rigid3.h"
#include "reference/reconstruction/reconstruction.h"

namespace hdabench::reference {

struct ColmapInput {
  // Image files of the frames (PNG or anything OpenCV reads; 8 or 16 bit,
  // grey or colour), of the camera's imager size. [0] is image 1 and [1]
  // image 2 of the pair; further frames are used only by colmap-free with
  // ColmapOptions::use_all_frames.
  std::vector<std::string> image_paths;
  // Navigation pose of each frame, local_from_cam (local: the ground ENU
  // frame), metres; one per image path.
  std::vector<Rigid3d> local_from_cam;
  // The dataset's camera (an mrcal model); required.
  std::optional<calib::CameraModel> camera;
  // Folder for this run's files (layout above). Created when missing; the
  // files of a previous run in it (the names above) are replaced.
  std::string workspace;
  // The side of the smallest region the points will be judged on, pixels of
  // image 1 (compare: the smallest ROI box); 0: unknown. It sets the SIFT
  // first octave when ColmapOptions::sift_first_octave is unset.
  double smallest_roi_px = 0.0;
};

// The SIFT first octave for regions of `smallest_roi_px` on a side in
// images of width x height px: -2 (the image upsampled four times) when the
// regions are under 64 px and the image's larger side at most 2048 px, else
// -1. The density of COLMAP's keypoints on the bench's regolith at -1 is
// about 22 per 1000 px^2, so a 32 px ROI (10 m at 566 m) holds about 22 and
// a 64 px one about 90; -2 doubles the count (about 50000 per 1024 x 1024
// frame, 40 per 32 px ROI) at 4 times the extraction's memory (1.2 GB on a
// 1024 px pair) and 4 times the exact matching's time, which the 2048 px
// bound keeps within this machine's means. Unknown (0): -1.
int DefaultSiftFirstOctave(double smallest_roi_px, int width, int height);

struct ColmapOptions {
  std::string executable = "colmap";  // a name looked up on PATH, or a path
  double timeout_s = 600.0;           // wall-time limit of each step, seconds, > 0
  int threads = 1;                    // threads of COLMAP's steps, >= 1 (1: reproducible output)
  // Threads of the exact matcher (sift_matching.h, SiftMatchOptions::
  // threads), >= 0 (0: every core); its matches do not depend on them.
  // COLMAP's feature_extractor keeps `threads`: with two, the images' ids in
  // the database followed the order the extractions finished in, and the
  // models' bytes changed between runs.
  int matcher_threads = 0;
  bool run_nav = true;                // colmap-nav (point_triangulator, nav poses fixed)
  bool run_free = true;               // colmap-free (mapper, then alignment)
  bool use_all_frames = false;        // colmap-free on every frame given instead of the pair

  // SIFT (feature_extractor, exact_matcher, matches_importer). The exact
  // matcher's other rules are COLMAP's defaults: max_distance 0.7 rad,
  // cross-check; the matches per pair bounded by sift_max_num_features only.
  int sift_max_image_size_px = 3200;  // images larger than this are downscaled for SIFT
  // Features kept per image, >= 10. COLMAP keeps the largest scales first: a
  // 1024 x 1024 regolith frame has about 23000 SIFT keypoints at the first
  // octave -1 and 50000 at -2, and COLMAP's own cap of 8192 dropped the
  // small-scale ones, which are those in the smooth blocks the quadtree keeps
  // (9 points per 10 m ROI at the median). The exact matching's time grows
  // with the product of the two images' counts.
  int sift_max_num_features = 131072;
  // COLMAP's scale space and detector threshold (--SiftExtraction options of
  // the same names). The first octave, in [-2, 2]: -1 (COLMAP's default)
  // upsamples the image twice first, -2 four times; unset: from the ROIs'
  // size in pixels (DefaultSiftFirstOctave).
  std::optional<int> sift_first_octave;
  int sift_octave_resolution = 3;       // levels per octave, in [1, 12] (COLMAP's default)
  double sift_peak_threshold = 0.02 / 3;  // DoG peak threshold, in (0, 1) (COLMAP's default)
  double sift_max_ratio = 0.8;        // Lowe ratio test (exact_matcher), in (0, 1]
  double sift_max_error_px = 4.0;     // two-view geometry RANSAC threshold, pixels, > 0
  // colmap-nav's matching guided by the nav epipolar geometry (header): the
  // band's half-width, the largest distance of a keypoint from its epipolar
  // line under the nav pose, pixels at the focal length, in [0, 1000]; 0:
  // exact matching of every pair of descriptors, as colmap-free. A band must
  // cover the nav pose's error as seen in the image (the bench's NOVA-C nav
  // puts matches 0.2-0.7 px off their lines) and the keypoints' own noise.
  // Guided matching is cheaper (0.9 s against 6.7 s on the default pair's
  // 23000 keypoints per image), but a descriptor then meets in the ratio test
  // only the hundred or so of the other image on its band: a wrong match along
  // the band whose true partner was not detected has no rival to fail it, and
  // lies on the epipolar line, so neither the verification nor the
  // triangulation removes it. Measured on the default pair (seed 1, first
  // octave -2): a 4 px band gave ROI slopes up to 84 deg off (bias +2.7 deg)
  // where exact matching stays within 6.9 deg (+0.9 deg); hence exact by
  // default (docs/compare-results.md, "COLMAP's options").
  double nav_guided_max_error_px = 0.0;

  // Triangulation (both methods): smallest angle between the rays of a
  // point, degrees, > 0. The NOVA-C pair has about 3 deg of parallax (30 m at
  // 566 m); COLMAP's default of 1.5 deg keeps it.
  double min_tri_angle_deg = 1.5;
  // mapper's initial pair (colmap-free): smallest median triangulation angle,
  // degrees, > 0 (COLMAP's default of 16 deg rejects the NOVA-C pair), and
  // fewest inlier matches, >= 10 (COLMAP's default: 100).
  double init_min_tri_angle_deg = 1.0;
  int init_min_num_inliers = 50;

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

// One step: a COLMAP program run, or the bench's exact_matcher.
struct ColmapStep {
  // "feature_extractor", "exact_matcher", "matches_importer", "point_triangulator", "mapper"
  std::string name;
  std::string log_file;  // its stdout and stderr
  bool ok = false;
  double wall_s = 0.0;  // wall time
  std::string error;     // when not ok: one line
};

struct ColmapResults {
  bool nav_requested = false;   // ColmapOptions::run_nav
  bool free_requested = false;  // ColmapOptions::run_free
  // method "colmap-nav" / "colmap-free". A method not requested has ok = false
  // and failure "not requested". log_dir: the workspace's logs/ folder.
  PairReconstruction nav;
  PairReconstruction free;
  std::vector<ColmapStep> steps;  // in the order they ran
  // Preparation, extraction, matching and verification (in both methods' seconds).
  double shared_s = 0.0;
  std::string camera_note;  // how the camera was given to COLMAP (model or resampling and why)
  // The SIFT extraction's scale space as run and why ("SIFT first octave -2:
  // the smallest ROI is 32 px on a side").
  std::string extraction_note;
};

// Runs the COLMAP references. Throws InputError for invalid options or
// inputs: fewer than 2 images, poses not one per image, no camera, an image
// that is missing, unreadable or not of the camera's size, a workspace that
// cannot be created. Everything that goes wrong with COLMAP itself (the
// executable missing, a step exiting non-zero or timing out, a database the
// exact matcher cannot use, the matching exceeding timeout_s, a model missing
// or without points, an alignment that is degenerate) marks the affected
// method ok = false with a one-line failure naming the step and its log file;
// the other method still runs where it can.
ColmapResults RunColmap(const ColmapInput& input, const ColmapOptions& options);

// colmap-free's failure when COLMAP's mapper could not start a model from
// images 1 and 2, read from the mapper's log (COLMAP 3.8): it tries the pair
// with init_min_num_inliers and init_min_tri_angle_deg, then up to four
// times more (each "Relaxing the initialization constraints"), halving the
// inliers and the angle in turn, and exits with "failed to create sparse
// model". The reason names the tries and the last constraints asked for.
// Empty when the log does not show that failure.
std::string MapperInitialisationFailure(const ColmapOptions& options, const std::string& log,
                                        const std::string& log_path);

// The COLMAP camera (model name and parameters, COLMAP pixel convention) for
// an mrcal model whose lens model has a COLMAP equivalent. Throws
// UnsupportedError naming the lens model and saying why for any other.
struct ColmapCameraParams {
  std::string model;
  std::vector<double> params;
};
ColmapCameraParams ToColmapCamera(const calib::CameraModel& camera);

}  // namespace hdabench::reference
