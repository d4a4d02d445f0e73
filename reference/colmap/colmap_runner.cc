#include "reference/colmap/colmap_runner.h"

#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <sstream>

#include <Eigen/SVD>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tools/images/codecs.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/util/options_check.h"
#include "tools/util/process.h"
#include "tools/util/parallel_for.h"
#include "reference/colmap/colmap_adapter.h"
#include "reference/colmap/colmap_model.h"
#include "reference/colmap/sift_matching.h"
#include "tools/util/text.h"

namespace hdabench::reference {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr char kNavMethod[] = "colmap-nav";
constexpr char kFreeMethod[] = "colmap-free";

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string JoinParams(const std::vector<double>& params) {
  std::string text;
  for (size_t i = 0; i < params.size(); ++i) text += (i > 0 ? "," : "") + util::ShortestText(params[i]);
  return text;
}

std::string ImageName(size_t index) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "frame_%03zu.png", index);
  return buffer;
}

// How COLMAP's images relate to the original ones.
struct CameraSetup {
  ColmapCameraParams colmap;  // what COLMAP is given
  bool resampled = false;     // images resampled to a pinhole camera
  // The pinhole camera of the resampled images, hdabench pixels.
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::string note;
};

// The pinhole camera used to resample a model without a COLMAP equivalent.
CameraSetup PinholeFor(const calib::CameraModel& camera, const std::string& why) {
  CameraSetup setup;
  setup.resampled = true;
  const double w = camera.WidthPx(), h = camera.HeightPx();
  if (camera.HasCore()) {
    const std::vector<double>& in = camera.Intrinsics();
    setup.fx = in[0];
    setup.fy = in[1];
    setup.cx = in[2];
    setup.cy = in[3];
  } else {
    // Focal length at the imager centre: the angle between the bearings of
    // two pixels one pixel apart on either side of it.
    setup.cx = 0.5 * (w - 1.0);
    setup.cy = 0.5 * (h - 1.0);
    std::vector<Eigen::Vector2d> pixels = {{setup.cx - 1, setup.cy},
                                           {setup.cx + 1, setup.cy},
                                           {setup.cx, setup.cy - 1},
                                           {setup.cx, setup.cy + 1}};
    std::vector<Eigen::Vector3d> bearings;
    std::vector<unsigned char> valid;
    if (camera.Unproject(pixels, &bearings, &valid) != 4) {
      throw InputError("colmap: camera " + camera.LensModelName() +
                       ": cannot unproject the imager centre to derive a pinhole camera");
    }
    const auto angle = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
      return std::atan2(a.cross(b).norm(), a.dot(b));
    };
    setup.fx = 2.0 / angle(bearings[0], bearings[1]);
    setup.fy = 2.0 / angle(bearings[2], bearings[3]);
  }
  if (!(setup.fx > 0 && setup.fy > 0 && std::isfinite(setup.fx) && std::isfinite(setup.fy))) {
    throw InputError("colmap: camera " + camera.LensModelName() +
                     ": no usable focal length for the pinhole resampling");
  }
  const Eigen::Vector2d c = PixelToColmap(Eigen::Vector2d(setup.cx, setup.cy));
  setup.colmap.model = "PINHOLE";
  setup.colmap.params = {setup.fx, setup.fy, c.x(), c.y()};
  setup.note = why + "; images resampled to PINHOLE fx=" + util::ShortestText(setup.fx) +
               " fy=" + util::ShortestText(setup.fy) + " through the mrcal model";
  return setup;
}

CameraSetup SetupCamera(const calib::CameraModel& camera) {
  try {
    CameraSetup setup;
    setup.colmap = ToColmapCamera(camera);
    setup.note = camera.LensModelName() + " given to COLMAP as " + setup.colmap.model;
    return setup;
  } catch (const UnsupportedError& e) {
    return PinholeFor(camera, e.what());
  }
}

// Reads an image as 8-bit grey (16-bit divided by 257, rounded; colour to grey).
cv::Mat ReadGrey8(const std::string& path, const calib::CameraModel& camera) {
  std::string error;
  cv::Mat image = images::ReadWholeImage(path, cv::IMREAD_UNCHANGED, &error);
  if (image.empty()) throw InputError(path + ": " + error);
  if (image.cols != camera.WidthPx() || image.rows != camera.HeightPx()) {
    throw InputError(path + ": image is " + std::to_string(image.cols) + " x " +
                     std::to_string(image.rows) + " px, the camera's imager " +
                     std::to_string(camera.WidthPx()) + " x " + std::to_string(camera.HeightPx()));
  }
  if (image.channels() == 3) {
    cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, image, cv::COLOR_BGRA2GRAY);
  } else if (image.channels() != 1) {
    throw InputError(path + ": image has " + std::to_string(image.channels()) +
                     " channels: expected 1, 3 or 4");
  }
  if (image.depth() == CV_16U) {
    cv::Mat eight;
    image.convertTo(eight, CV_8U, 1.0 / 257.0);
    return eight;
  }
  if (image.depth() != CV_8U) throw InputError(path + ": image is neither 8 nor 16 bit");
  return image;
}

// The resampling maps: for each pixel of the pinhole image, where to read the
// original image.
void ResamplingMaps(const calib::CameraModel& camera, const CameraSetup& setup, cv::Mat* map_x,
                    cv::Mat* map_y) {
  const int w = camera.WidthPx(), h = camera.HeightPx();
  std::vector<Eigen::Vector3d> rays;
  rays.reserve(static_cast<size_t>(w) * static_cast<size_t>(h));
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      rays.emplace_back((u - setup.cx) / setup.fx, (v - setup.cy) / setup.fy, 1.0);
    }
  }
  std::vector<Eigen::Vector2d> pixels;
  std::vector<unsigned char> valid;
  camera.Project(rays, &pixels, &valid);
  map_x->create(h, w, CV_32FC1);
  map_y->create(h, w, CV_32FC1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const size_t i = static_cast<size_t>(v) * static_cast<size_t>(w) + static_cast<size_t>(u);
      map_x->at<float>(v, u) = valid[i] ? static_cast<float>(pixels[i].x()) : -1.0f;
      map_y->at<float>(v, u) = valid[i] ? static_cast<float>(pixels[i].y()) : -1.0f;
    }
  }
}

// COLMAP pixels of COLMAP's image 1 to hdabench pixels of the original image
// 1; valid[i] = 0 where the mapping fails.
std::vector<Eigen::Vector2d> ToOriginalPixels(const std::vector<Eigen::Vector2d>& colmap_pixels,
                                              const calib::CameraModel& camera,
                                              const CameraSetup& setup,
                                              std::vector<unsigned char>* valid) {
  std::vector<Eigen::Vector2d> pixels;
  for (const Eigen::Vector2d& p : colmap_pixels) pixels.push_back(PixelFromColmap(p));
  if (!setup.resampled) {
    valid->assign(pixels.size(), 1);
    return pixels;
  }
  std::vector<Eigen::Vector3d> rays;
  for (const Eigen::Vector2d& p : pixels) {
    rays.emplace_back((p.x() - setup.cx) / setup.fx, (p.y() - setup.cy) / setup.fy, 1.0);
  }
  std::vector<Eigen::Vector2d> original;
  camera.Project(rays, &original, valid);
  return original;
}

// ---------------------------------------------------------------------------
// COLMAP's database: the ids it gave the images and the camera, the features,
// the verified matches.

// A read-only connection; error() is non-empty once anything failed.
class DatabaseReader {
 public:
  explicit DatabaseReader(std::string path) : path_(std::move(path)) {
    if (sqlite3_open_v2(path_.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      error_ = path_ + ": cannot open COLMAP's database: " +
               (db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory");
    }
  }
  ~DatabaseReader() { sqlite3_close(db_); }
  DatabaseReader(const DatabaseReader&) = delete;
  DatabaseReader& operator=(const DatabaseReader&) = delete;

  // Runs `sql`, calling on_row(statement) for each row; false (error() set)
  // on failure or after an earlier one.
  template <typename OnRow>
  bool Query(const char* sql, const OnRow& on_row) {
    if (!error_.empty()) return false;
    sqlite3_stmt* statement = nullptr;
    if (sqlite3_prepare_v2(db_, sql, -1, &statement, nullptr) != SQLITE_OK) {
      error_ = path_ + ": " + sqlite3_errmsg(db_) + " in '" + sql + "'";
      sqlite3_finalize(statement);
      return false;
    }
    int rc = SQLITE_ROW;
    while ((rc = sqlite3_step(statement)) == SQLITE_ROW) on_row(statement);
    if (rc != SQLITE_DONE) error_ = path_ + ": " + sqlite3_errmsg(db_) + " in '" + sql + "'";
    sqlite3_finalize(statement);
    return error_.empty();
  }
  const std::string& error() const { return error_; }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
  std::string error_;
};

struct DatabaseIds {
  std::map<std::string, std::uint32_t> image_ids;  // by name
  std::map<std::string, std::uint32_t> image_cameras;
  std::uint32_t camera_id = 0;
  int camera_count = 0;
};

// COLMAP's pair id of two image ids (smaller id first).
std::int64_t PairId(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return static_cast<std::int64_t>(a) * 2147483647LL + static_cast<std::int64_t>(b);
}

// Empty on success, else the error.
std::string ReadDatabaseIds(const std::string& path, DatabaseIds* ids) {
  DatabaseReader db(path);
  db.Query("SELECT image_id, name, camera_id FROM images", [&](sqlite3_stmt* s) {
    const unsigned char* name = sqlite3_column_text(s, 1);
    const std::string text = name != nullptr ? reinterpret_cast<const char*>(name) : "";
    ids->image_ids[text] = static_cast<std::uint32_t>(sqlite3_column_int64(s, 0));
    ids->image_cameras[text] = static_cast<std::uint32_t>(sqlite3_column_int64(s, 2));
  });
  db.Query("SELECT camera_id FROM cameras", [&](sqlite3_stmt* s) {
    ids->camera_id = static_cast<std::uint32_t>(sqlite3_column_int64(s, 0));
    ++ids->camera_count;
  });
  return db.error();
}

// Verified (inlier) matches per image pair, keyed by COLMAP's pair id. Empty
// on success, else the error.
std::string ReadVerifiedMatches(const std::string& path,
                                std::map<std::int64_t, std::int64_t>* verified) {
  DatabaseReader db(path);
  db.Query("SELECT pair_id, rows FROM two_view_geometries", [&](sqlite3_stmt* s) {
    (*verified)[sqlite3_column_int64(s, 0)] = sqlite3_column_int64(s, 1);
  });
  return db.error();
}

// The size of the images as COLMAP's SIFT sees them: downscaled as its
// extractor does when a side exceeds max_image_size, the keypoints then
// scaled back to the image's pixels.
struct SiftImageSize {
  int width = 0, height = 0;
  double from_image_x = 1.0, from_image_y = 1.0;  // SIFT pixels per image pixel
  SiftOctaves octaves;                            // the extraction's scale space
};

SiftImageSize SiftImageSizeOf(int width, int height, const ColmapOptions& options) {
  const int max_image_size = options.sift_max_image_size_px;
  SiftImageSize size{width, height, 1.0, 1.0, SiftOctaves()};
  size.octaves.first_octave = *options.sift_first_octave;
  size.octaves.octave_resolution = options.sift_octave_resolution;
  if (width > max_image_size || height > max_image_size) {
    const double scale = static_cast<double>(max_image_size) / std::max(width, height);
    size.width = static_cast<int>(width * scale);
    size.height = static_cast<int>(height * scale);
    size.from_image_x = static_cast<double>(size.width) / width;
    size.from_image_y = static_cast<double>(size.height) / height;
  }
  return size;
}

// One image's features for the exact matcher.
struct ImageFeatures {
  SiftDescriptors descriptors;
  int unset = 0;  // descriptors set to zero: COLMAP may not have computed them
  std::vector<Eigen::Vector2d> keypoints;  // COLMAP's positions, pixels of COLMAP's image
};

// The SIFT descriptors of every image in `names` (by image name), checked
// against the keypoints: as many rows, 128 bytes each. An image without rows
// in the tables has no features. The descriptor of a keypoint whose
// descriptor COLMAP may never have computed (SiftDescriptorMayBeUnset) is set
// to zero, which matches nothing. Empty on success, else the error.
std::string ReadFeatures(const std::string& path, const DatabaseIds& ids,
                         const std::vector<std::string>& names, const SiftImageSize& sift,
                         std::map<std::string, ImageFeatures>* features) {
  struct Rows {
    std::vector<float> keypoints;  // keypoint_cols per keypoint
    std::int64_t keypoint_rows = 0, keypoint_cols = 0;
    SiftDescriptors descriptors;
    std::string error;
  };
  std::map<std::uint32_t, Rows> by_id;
  for (const std::string& name : names) by_id[ids.image_ids.at(name)];
  DatabaseReader db(path);
  db.Query("SELECT image_id, rows, cols, data FROM keypoints", [&](sqlite3_stmt* s) {
    const auto it = by_id.find(static_cast<std::uint32_t>(sqlite3_column_int64(s, 0)));
    if (it == by_id.end()) return;
    Rows& r = it->second;
    r.keypoint_rows = sqlite3_column_int64(s, 1);
    r.keypoint_cols = sqlite3_column_int64(s, 2);
    const void* blob = sqlite3_column_blob(s, 3);
    const std::int64_t bytes = sqlite3_column_bytes(s, 3);
    if (r.keypoint_rows == 0) return;
    // COLMAP's layouts: x y; x y scale orientation; x y a11 a12 a21 a22.
    const bool known_cols = r.keypoint_cols == 2 || r.keypoint_cols == 4 || r.keypoint_cols == 6;
    if (!known_cols || r.keypoint_rows < 0 || r.keypoint_rows > std::numeric_limits<int>::max() ||
        bytes != r.keypoint_rows * r.keypoint_cols * 4 || blob == nullptr) {
      r.error = "keypoints are " + std::to_string(r.keypoint_rows) + " x " +
                std::to_string(r.keypoint_cols) + " in " + std::to_string(bytes) +
                " bytes: expected rows x 2, 4 or 6 floats";
      return;
    }
    r.keypoints.resize(static_cast<size_t>(bytes) / 4);
    std::memcpy(r.keypoints.data(), blob, static_cast<size_t>(bytes));
  });
  db.Query("SELECT image_id, rows, cols, data FROM descriptors", [&](sqlite3_stmt* s) {
    const auto it = by_id.find(static_cast<std::uint32_t>(sqlite3_column_int64(s, 0)));
    if (it == by_id.end()) return;
    const std::int64_t rows = sqlite3_column_int64(s, 1), cols = sqlite3_column_int64(s, 2);
    const void* blob = sqlite3_column_blob(s, 3);
    const std::int64_t bytes = sqlite3_column_bytes(s, 3);
    if (rows == 0) return;
    if (cols != 128 || rows < 0 || rows > std::numeric_limits<int>::max() / 128 ||
        bytes != rows * cols || blob == nullptr) {
      if (it->second.error.empty()) {
        it->second.error = "descriptors are " + std::to_string(rows) + " x " +
                           std::to_string(cols) + " in " + std::to_string(bytes) +
                           " bytes: expected rows x 128 bytes";
      }
      return;
    }
    SiftDescriptors& d = it->second.descriptors;
    d.rows = static_cast<int>(rows);
    const auto* begin = static_cast<const std::uint8_t*>(blob);
    d.data.assign(begin, begin + bytes);
  });
  if (!db.error().empty()) return db.error();
  for (const std::string& name : names) {
    Rows& rows = by_id.at(ids.image_ids.at(name));
    if (rows.error.empty() && rows.keypoint_rows != rows.descriptors.rows) {
      rows.error = std::to_string(rows.keypoint_rows) + " keypoints but " +
                   std::to_string(rows.descriptors.rows) + " descriptors";
    }
    if (!rows.error.empty()) return path + ": image " + name + ": " + rows.error;
    ImageFeatures& out = (*features)[name];
    out.descriptors = std::move(rows.descriptors);
    const size_t cols = static_cast<size_t>(rows.keypoint_cols);
    for (int k = 0; k < out.descriptors.rows; ++k) {
      const float* kp = rows.keypoints.data() + static_cast<size_t>(k) * cols;
      out.keypoints.emplace_back(static_cast<double>(kp[0]), static_cast<double>(kp[1]));
      double scale = 0.0;  // unknown for the x y layout: every octave is checked
      if (cols == 4) scale = static_cast<double>(kp[2]);
      if (cols == 6) {
        scale = 0.5 * (std::hypot(static_cast<double>(kp[2]), static_cast<double>(kp[4])) +
                       std::hypot(static_cast<double>(kp[3]), static_cast<double>(kp[5])));
      }
      const double to_sift = 0.5 * (sift.from_image_x + sift.from_image_y);
      if (SiftDescriptorMayBeUnset(static_cast<double>(kp[0]) * sift.from_image_x,
                                   static_cast<double>(kp[1]) * sift.from_image_y, scale * to_sift,
                                   sift.width, sift.height, sift.octaves)) {
        std::fill_n(out.descriptors.data.begin() + static_cast<std::ptrdiff_t>(k) * 128, 128, 0);
        ++out.unset;
      }
    }
  }
  return "";
}

// ---------------------------------------------------------------------------
// Running the steps.

class StepRunner {
 public:
  StepRunner(std::string executable, const fs::path& logs, const ColmapOptions& options,
             ColmapResults* results)
      : executable_(std::move(executable)), logs_(logs), options_(options), results_(results) {}

  // Runs `colmap <name> <args>`; on failure *failure gets the one-line reason.
  bool Run(const std::string& name, const std::vector<std::string>& args, std::string* failure) {
    ColmapStep step = NewStep(name);
    std::vector<std::string> argv = {executable_, name};
    argv.insert(argv.end(), args.begin(), args.end());
    argv.push_back("--log_to_stderr");
    argv.push_back("1");
    {
      std::ofstream log(step.log_file, std::ios::trunc);
      log << "#";
      for (const std::string& a : argv) log << ' ' << a;
      log << "\n";
    }
    util::ProcessOptions process;
    process.log_file = step.log_file;
    process.timeout_s = options_.timeout_s;
    process.environment = {{"GLOG_log_dir", logs_.string()}, {"GLOG_logtostderr", "1"}};
    const util::ProcessResult run = util::RunProcess(argv, process);
    step.wall_s = run.wall_s;
    step.ok = run.Ok();
    if (!step.ok) {
      step.error = run.error;
      *failure = "colmap " + name + " failed: " + run.error + " (log: " + step.log_file + ")";
    }
    results_->steps.push_back(step);
    return step.ok;
  }
  // Runs a step of the bench's own: work(log, &error) writes its log and
  // returns false with a one-line error on failure; *failure then gets the
  // one-line reason.
  bool RunInProcess(const std::string& name,
                    const std::function<bool(std::ostream& log, std::string* error)>& work,
                    std::string* failure) {
    ColmapStep step = NewStep(name);
    const Clock::time_point start = Clock::now();
    std::ofstream log(step.log_file, std::ios::trunc);
    std::string error;
    step.ok = log.good() && work(log, &error);
    if (!log.good() && error.empty()) error = "cannot write its log file";
    log << (step.ok ? "# done\n" : "# failed: " + error + "\n");
    step.wall_s = SecondsSince(start);
    if (!step.ok) {
      step.error = error;
      *failure = name + " failed: " + error + " (log: " + step.log_file + ")";
    }
    results_->steps.push_back(step);
    return step.ok;
  }
  // Log file of the most recent step.
  std::string LastLog() const {
    return results_->steps.empty() ? "" : results_->steps.back().log_file;
  }

 private:
  // A step numbered after the previous ones, with its log file's name.
  ColmapStep NewStep(const std::string& name) {
    ColmapStep step;
    step.name = name;
    char prefix[16];
    std::snprintf(prefix, sizeof(prefix), "%02d-", ++count_);
    step.log_file = (logs_ / (prefix + name + ".log")).string();
    return step;
  }

  std::string executable_;
  fs::path logs_;
  const ColmapOptions& options_;
  ColmapResults* results_;
  int count_ = 0;
};

void Fail(PairReconstruction* method, const std::string& failure) {
  method->ok = false;
  method->failure = failure;
  method->points.clear();
  method->has_pose = false;
}

// matches_importer's two-view geometric verification: COLMAP's defaults but
// for the RANSAC threshold (its other --SiftMatching options are those of
// the descriptor matching, which the exact matcher does instead).
std::vector<std::string> VerificationArgs(const ColmapOptions& o) {
  return {"--SiftMatching.use_gpu",     "0",
          "--SiftMatching.num_threads", std::to_string(o.threads),
          "--SiftMatching.max_error",   util::ShortestText(o.sift_max_error_px)};
}

// ColmapOptions::matcher_threads, 0 resolved to the cores this process may use.
int MatcherThreads(const ColmapOptions& o) { return util::WorkerThreads(o.matcher_threads); }

// The exact matcher's options: COLMAP's defaults (max_distance 0.7,
// cross-check) but for the ratio and for the number of matches, which only
// the number of features bounds (COLMAP's 32768 would cut the pairs of
// 50000 features that the first octave -2 gives).
SiftMatchOptions ExactMatchOptions(const ColmapOptions& o) {
  SiftMatchOptions match;
  match.max_ratio = o.sift_max_ratio;
  match.max_num_matches = o.sift_max_num_features;
  match.threads = MatcherThreads(o);
  return match;
}

// Guided matching of images 1 and 2 under their nav relative pose
// (ColmapOptions::nav_guided_max_error_px > 0): the camera as COLMAP's images have it,
// the pose, and the band's half-width as the sine of an angle.
struct NavGuide {
  const calib::CameraModel* camera = nullptr;
  const CameraSetup* setup = nullptr;
  Rigid3d cam2_from_cam1;
  double max_sin = 0.0;
};

// The bearings of COLMAP keypoints (pixels of COLMAP's image) in the camera
// frame; zero where the camera cannot unproject the pixel.
std::vector<Eigen::Vector3d> KeypointBearings(const std::vector<Eigen::Vector2d>& keypoints,
                                              const NavGuide& guide) {
  std::vector<Eigen::Vector3d> bearings;
  std::vector<Eigen::Vector2d> pixels;
  for (const Eigen::Vector2d& k : keypoints) pixels.push_back(PixelFromColmap(k));
  const CameraSetup& setup = *guide.setup;
  if (setup.resampled) {
    for (const Eigen::Vector2d& p : pixels) {
      bearings.emplace_back((p.x() - setup.cx) / setup.fx, (p.y() - setup.cy) / setup.fy, 1.0);
    }
    return bearings;
  }
  std::vector<unsigned char> valid;
  guide.camera->Unproject(pixels, &bearings, &valid);
  for (size_t i = 0; i < bearings.size(); ++i) {
    if (!valid[i]) bearings[i].setZero();
  }
  return bearings;
}

// The guided matches of one pair, with the candidate count in the log.
std::vector<SiftMatch> MatchGuided(const ImageFeatures& one, const ImageFeatures& two,
                                   const NavGuide& guide, const SiftMatchOptions& match,
                                   std::ostream& log) {
  const std::vector<std::vector<int>> candidates = EpipolarCandidates(
      KeypointBearings(one.keypoints, guide), KeypointBearings(two.keypoints, guide),
      guide.cam2_from_cam1.RotationMatrix(), guide.cam2_from_cam1.translation, guide.max_sin);
  size_t total = 0;
  for (const std::vector<int>& c : candidates) total += c.size();
  log << "nav epipolar candidates: " << total << " pairs, "
      << util::ShortestText(candidates.empty() ? 0.0 : static_cast<double>(total) / static_cast<double>(candidates.size()))
      << " per descriptor of image 1\n";
  return MatchSiftGuided(one.descriptors, two.descriptors, candidates, match);
}

// Matches every pair of `names` (in that order, first with second, ...) with
// MatchSiftExact (with MatchSiftGuided under `guide`, which `names` must then
// be images 1 and 2 for) and writes matches_importer's raw match list: per pair a line
// "name1 name2", a line "index1 index2" per match, then an empty line. The
// pairs share one time limit, checked before each pair. false with *error on
// failure.
bool MatchAllPairs(const std::string& database, const DatabaseIds& ids,
                   const std::vector<std::string>& names, const SiftImageSize& sift,
                   const SiftMatchOptions& match, const NavGuide* guide, double timeout_s,
                   const fs::path& match_list, std::ostream& log, std::string* error) {
  const Clock::time_point start = Clock::now();
  log << (guide != nullptr ? "# SIFT matching of images 1 and 2 guided by the nav epipolar geometry, band "
                           "of " + util::ShortestText(std::asin(guide->max_sin) * util::kRadToDeg) +
                                 " deg, in front of both cameras"
                           : std::string("# exact SIFT matching of every image pair"))
      << " (reference/colmap/sift_matching.h): max_ratio "
      << util::ShortestText(match.max_ratio) << ", max_distance " << util::ShortestText(match.max_distance)
      << ", cross_check " << (match.cross_check ? 1 : 0) << ", max_num_matches "
      << match.max_num_matches << "\n";
  std::map<std::string, ImageFeatures> features;
  *error = ReadFeatures(database, ids, names, sift, &features);
  if (!error->empty()) return false;
  for (const std::string& name : names) {
    const ImageFeatures& f = features.at(name);
    log << name << ": " << f.descriptors.rows << " descriptors, " << f.unset
        << " left out (COLMAP may not have computed them: SiftDescriptorMayBeUnset)\n";
  }
  std::ofstream out(match_list, std::ios::trunc);
  if (!out) {
    *error = match_list.string() + ": cannot write the match list";
    return false;
  }
  const size_t num_pairs = names.size() * (names.size() - 1) / 2;
  size_t done = 0;
  for (size_t i = 0; i < names.size(); ++i) {
    for (size_t j = i + 1; j < names.size(); ++j) {
      if (SecondsSince(start) > timeout_s) {
        *error = "timed out after " + util::ShortestText(timeout_s) + " s (" + std::to_string(done) +
                 " of " + std::to_string(num_pairs) + " pairs matched)";
        return false;
      }
      const Clock::time_point pair_start = Clock::now();
      const SiftDescriptors& d1 = features.at(names[i]).descriptors;
      const SiftDescriptors& d2 = features.at(names[j]).descriptors;
      const std::vector<SiftMatch> matches =
          guide != nullptr ? MatchGuided(features.at(names[i]), features.at(names[j]), *guide, match, log)
                           : MatchSiftExact(d1, d2, match);
      out << names[i] << ' ' << names[j] << '\n';
      for (const SiftMatch& m : matches) out << m.index1 << ' ' << m.index2 << '\n';
      out << '\n';
      ++done;
      char seconds[32];
      std::snprintf(seconds, sizeof(seconds), "%.3f", SecondsSince(pair_start));
      log << names[i] << ' ' << names[j] << ": " << d1.rows << " x " << d2.rows << " descriptors, "
          << matches.size() << " matches, " << seconds << " s\n";
    }
  }
  out.close();
  if (!out) {
    *error = match_list.string() + ": cannot write the match list";
    return false;
  }
  return true;
}

std::vector<std::string> MapperArgs(const ColmapOptions& o) {
  return {"--Mapper.num_threads",
          std::to_string(o.threads),
          "--Mapper.ba_refine_focal_length",
          "0",
          "--Mapper.ba_refine_principal_point",
          "0",
          "--Mapper.ba_refine_extra_params",
          "0",
          "--Mapper.tri_ignore_two_view_tracks",
          "0",
          "--Mapper.tri_min_angle",
          util::ShortestText(o.min_tri_angle_deg),
          "--Mapper.filter_min_tri_angle",
          util::ShortestText(o.min_tri_angle_deg)};
}

// Points of `model` observed in image `image1_id`, moved into the local frame
// by local_from_world (scale s, rotation R, translation t).
std::vector<ReconstructedPoint> PointsSeenInImage1(const ColmapModel& model,
                                                   std::uint32_t image1_id, double scale,
                                                   const Eigen::Matrix3d& rotation,
                                                   const Eigen::Vector3d& translation,
                                                   const calib::CameraModel& camera,
                                                   const CameraSetup& setup) {
  const ColmapImage* image1 = model.FindImage(image1_id);
  std::vector<ReconstructedPoint> points;
  if (image1 == nullptr) return points;
  std::vector<Eigen::Vector2d> colmap_pixels;
  std::vector<Eigen::Vector3d> xyz;
  for (const ColmapPoint3D& p : model.points3D) {
    for (const ColmapTrackElement& e : p.track) {
      if (e.image_id != image1_id) continue;
      colmap_pixels.push_back(image1->points2D[e.point2D_idx].xy);
      xyz.push_back(p.xyz);
      break;  // one observation per image
    }
  }
  std::vector<unsigned char> valid;
  const std::vector<Eigen::Vector2d> pixels =
      ToOriginalPixels(colmap_pixels, camera, setup, &valid);
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (!valid[i]) continue;
    ReconstructedPoint point;
    point.point_in_local_m = scale * (rotation * xyz[i]) + translation;
    point.pixel1 = pixels[i];
    points.push_back(point);
  }
  return points;
}

std::string ReadLog(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Reads the model in `dir`; on failure *failure says why, naming the step.
bool ReadModel(const fs::path& dir, const std::string& step, const std::string& log,
               ColmapModel* model, std::string* failure) {
  try {
    *model = ReadColmapModel(dir.string());
    return true;
  } catch (const InputError& e) {
    *failure = "colmap " + step + ": unusable model: " + e.what() + " (log: " + log + ")";
    return false;
  }
}

// ---------------------------------------------------------------------------
// RunColmap's steps, in the order it runs them.

// RunColmap's argument checks, so that a bad call throws before the workspace
// is touched.
void CheckRunColmapInput(const ColmapInput& input, const ColmapOptions& options) {
  ThrowIfInvalid("RunColmap: invalid ColmapOptions: ", options.Validate());
  if (input.image_paths.size() < 2) {
    throw InputError("RunColmap: " + std::to_string(input.image_paths.size()) +
                     " image(s) given: expected at least 2 (image 1 and image 2)");
  }
  if (input.local_from_cam.size() != input.image_paths.size()) {
    throw InputError("RunColmap: " + std::to_string(input.local_from_cam.size()) +
                     " navigation poses for " + std::to_string(input.image_paths.size()) +
                     " images: expected one each");
  }
  if (!input.camera.has_value()) throw InputError("RunColmap: no camera model given");
  if (input.workspace.empty()) throw InputError("RunColmap: no workspace folder given");
}

// The results before anything ran, so that a method not requested says so.
ColmapResults InitialResults(const ColmapOptions& options) {
  ColmapResults results;
  results.nav_requested = options.run_nav;
  results.free_requested = options.run_free;
  results.nav.method = kNavMethod;
  results.free.method = kFreeMethod;
  if (!options.run_nav) results.nav.failure = "not requested";
  if (!options.run_free) results.free.failure = "not requested";
  return results;
}

// The workspace's folders and COLMAP's database in it.
struct WorkspacePaths {
  fs::path root;
  fs::path images_dir;
  fs::path logs_dir;
  fs::path database;
};

// Clears what an earlier run left in the workspace, so that no stale image,
// log, model or database is read back, and creates its folders.
WorkspacePaths PrepareWorkspace(const std::string& workspace_dir) {
  const fs::path workspace(workspace_dir);
  const fs::path images_dir = workspace / "images";
  const fs::path logs_dir = workspace / "logs";
  const fs::path database = workspace / "database.db";
  try {
    fs::create_directories(workspace);
    for (const fs::path& old :
         {images_dir, logs_dir, workspace / "nav", workspace / "free", database,
          workspace / "database.db-journal", workspace / "matches.txt", workspace / "free.db",
          workspace / "free.db-journal", workspace / "nav_matches.txt"}) {
      fs::remove_all(old);
    }
    fs::create_directories(images_dir);
    fs::create_directories(logs_dir);
  } catch (const fs::filesystem_error& e) {
    throw InputError(workspace_dir + ": cannot prepare the COLMAP workspace: " + e.what());
  }
  return {workspace, images_dir, logs_dir, database};
}

// Writes the first num_used images as COLMAP reads them: 8-bit grey PNG,
// resampled when COLMAP has no equivalent camera.
void WriteImages(const std::vector<std::string>& image_paths, const calib::CameraModel& camera,
                 const CameraSetup& setup, size_t num_used, const fs::path& images_dir) {
  cv::Mat map_x, map_y;
  if (setup.resampled) ResamplingMaps(camera, setup, &map_x, &map_y);
  for (size_t i = 0; i < num_used; ++i) {
    cv::Mat image = ReadGrey8(image_paths[i], camera);
    if (setup.resampled) {
      cv::Mat resampled;
      cv::remap(image, resampled, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                cv::Scalar(0));
      image = resampled;
    }
    const fs::path out = images_dir / ImageName(i);
    if (!images::Write(out.string(), image)) throw InputError(out.string() + ": cannot write image");
  }
}

// A failure of a shared step fails both requested methods, whose time is then
// the shared time alone.
void FailBoth(const ColmapOptions& options, Clock::time_point start, const std::string& failure,
              ColmapResults* results) {
  if (options.run_nav) Fail(&results->nav, failure);
  if (options.run_free) Fail(&results->free, failure);
  results->shared_s = SecondsSince(start);
  results->nav.wall_s = options.run_nav ? results->shared_s : 0.0;
  results->free.wall_s = options.run_free ? results->shared_s : 0.0;
}

// What the COLMAP steps share: the inputs, the workspace, the step runner,
// the results, and what feature extraction found in COLMAP's database.
struct ColmapRun {
  const ColmapInput& input;
  const ColmapOptions& options;
  const calib::CameraModel& camera;
  const WorkspacePaths& paths;
  const CameraSetup& setup;
  size_t num_used;  // images given to COLMAP
  Clock::time_point start;
  StepRunner* steps;
  ColmapResults* results;
  DatabaseIds ids;                 // set by ExtractFeatures
  std::vector<std::string> names;  // the images' names in COLMAP, set by ExtractFeatures
};

// COLMAP's feature_extractor, then the ids it gave the camera and the images
// (needed by every later step); false, both methods failed, on failure.
bool ExtractFeatures(ColmapRun* run) {
  const ColmapOptions& options = run->options;
  const fs::path& database = run->paths.database;
  std::string failure;
  const std::vector<std::string> extract_args = {"--database_path",
                                                 database.string(),
                                                 "--image_path",
                                                 run->paths.images_dir.string(),
                                                 "--ImageReader.single_camera",
                                                 "1",
                                                 "--ImageReader.camera_model",
                                                 run->setup.colmap.model,
                                                 "--ImageReader.camera_params",
                                                 JoinParams(run->setup.colmap.params),
                                                 "--SiftExtraction.use_gpu",
                                                 "0",
                                                 "--SiftExtraction.num_threads",
                                                 std::to_string(options.threads),
                                                 "--SiftExtraction.max_image_size",
                                                 std::to_string(options.sift_max_image_size_px),
                                                 "--SiftExtraction.max_num_features",
                                                 std::to_string(options.sift_max_num_features),
                                                 "--SiftExtraction.first_octave",
                                                 std::to_string(*options.sift_first_octave),
                                                 "--SiftExtraction.octave_resolution",
                                                 std::to_string(options.sift_octave_resolution),
                                                 "--SiftExtraction.peak_threshold",
                                                 util::ShortestText(options.sift_peak_threshold)};
  if (!run->steps->Run("feature_extractor", extract_args, &failure)) {
    FailBoth(options, run->start, failure, run->results);
    return false;
  }
  const std::string db_error = ReadDatabaseIds(database.string(), &run->ids);
  std::string id_failure;
  for (size_t i = 0; i < run->num_used; ++i) run->names.push_back(ImageName(i));
  if (!db_error.empty()) {
    id_failure = "colmap feature_extractor: " + db_error;
  } else if (run->ids.camera_count != 1) {
    id_failure = "colmap feature_extractor: " + database.string() + " holds " +
                 std::to_string(run->ids.camera_count) + " cameras, expected 1";
  } else {
    for (const std::string& name : run->names) {
      if (run->ids.image_ids.count(name) == 0) {
        id_failure = "colmap feature_extractor: " + database.string() + " lacks image " + name +
                     " (log: " + run->results->steps.front().log_file + ")";
        break;
      }
    }
  }
  if (!id_failure.empty()) {
    FailBoth(options, run->start, id_failure, run->results);
    return false;
  }
  return true;
}

// How one database's images are matched: every pair exactly, or images 1
// and 2 alone guided by their nav relative pose.
struct MatchPlan {
  fs::path database;
  fs::path match_list;              // the raw matches for matches_importer
  std::vector<std::string> names;   // the images matched, pair by pair
  std::optional<NavGuide> guide;    // guided matching (names: images 1 and 2)
  std::string step;                 // the matching step's name in the logs
};

// Matching: the exact matcher instead of COLMAP's exhaustive_matcher, whose
// approximate search differs from run to run (header, "Determinism"), or the
// nav-guided one, then COLMAP's own two-view geometric verification of those
// raw matches, then the check that images 1 and 2 have verified matches
// (without any nothing can be triangulated, and COLMAP 3.8's
// point_triangulator aborts on an empty bundle adjustment). false with
// *failure on failure.
bool MatchAndVerify(const ColmapRun& run, const MatchPlan& plan, std::string* failure) {
  const ColmapOptions& options = run.options;
  const auto match_all = [&](std::ostream& log, std::string* error) {
    return MatchAllPairs(
        plan.database.string(), run.ids, plan.names,
        SiftImageSizeOf(run.camera.WidthPx(), run.camera.HeightPx(), options),
        ExactMatchOptions(options), plan.guide ? &*plan.guide : nullptr, options.timeout_s,
        plan.match_list, log, error);
  };
  std::vector<std::string> import_args = {"--database_path",   plan.database.string(),
                                          "--match_list_path", plan.match_list.string(),
                                          "--match_type",      "raw"};
  for (const std::string& a : VerificationArgs(options)) import_args.push_back(a);
  if (!run.steps->RunInProcess(plan.step, match_all, failure) ||
      !run.steps->Run("matches_importer", import_args, failure)) {
    return false;
  }
  std::map<std::int64_t, std::int64_t> verified;
  const std::string verified_error = ReadVerifiedMatches(plan.database.string(), &verified);
  if (!verified_error.empty()) {
    *failure = "colmap matches_importer: " + verified_error;
    return false;
  }
  const auto pair = verified.find(
      PairId(run.ids.image_ids.at(ImageName(0)), run.ids.image_ids.at(ImageName(1))));
  if (pair == verified.end() || pair->second == 0) {
    *failure = "colmap matches_importer: no points: no verified matches between images 1 and 2 (log: " +
               run.steps->LastLog() + ")";
    return false;
  }
  return true;
}

// The nav-guided matching of images 1 and 2 into `database`.
MatchPlan NavGuidedPlan(const ColmapRun& run, const fs::path& database) {
  MatchPlan plan{database, run.paths.root / "nav_matches.txt", {ImageName(0), ImageName(1)}, NavGuide(),
                 "nav_guided_matcher"};
  NavGuide& guide = *plan.guide;
  guide.camera = &run.camera;
  guide.setup = &run.setup;
  guide.cam2_from_cam1 = run.input.local_from_cam[1].Inverse() * run.input.local_from_cam[0];
  // The band in pixels at the focal length of COLMAP's camera.
  const double focal = run.setup.resampled
                           ? 0.5 * (run.setup.fx + run.setup.fy)
                           : 0.5 * (run.setup.colmap.params[0] + run.setup.colmap.params[1]);
  guide.max_sin = std::sin(std::atan(run.options.nav_guided_max_error_px / focal));
  return plan;
}

// point_triangulator's input model: COLMAP's camera, and images 1 and 2 at
// their nav poses (which it keeps fixed).
ColmapModel NavInputModel(const ColmapRun& run) {
  ColmapCamera colmap_camera;
  colmap_camera.id = run.ids.camera_id;
  colmap_camera.model = run.setup.colmap.model;
  colmap_camera.width = static_cast<std::uint64_t>(run.camera.WidthPx());
  colmap_camera.height = static_cast<std::uint64_t>(run.camera.HeightPx());
  colmap_camera.params = run.setup.colmap.params;
  ColmapModel model;
  model.cameras.push_back(colmap_camera);
  for (size_t i = 0; i < 2; ++i) {
    ColmapImage image;
    image.id = run.ids.image_ids.at(ImageName(i));
    image.camera_id = run.ids.image_cameras.at(ImageName(i));
    const std::array<double, 7> pose =
        ColmapFromCamFromWorld(run.input.local_from_cam[i].Inverse());
    std::copy(pose.begin(), pose.begin() + 4, image.qvec.begin());
    std::copy(pose.begin() + 4, pose.end(), image.tvec.begin());
    image.name = ImageName(i);
    model.images.push_back(image);
  }
  return model;
}

// colmap-nav: point_triangulator with the nav poses fixed, on the matches in
// `database`. Its time: the shared steps' and its own since nav_start.
void ReconstructWithNav(const ColmapRun& run, const fs::path& database, Clock::time_point nav_start) {
  PairReconstruction& nav_result = run.results->nav;
  const fs::path nav_input = run.paths.root / "nav" / "input";
  const fs::path nav_model = run.paths.root / "nav" / "model";
  fs::create_directories(nav_input);
  fs::create_directories(nav_model);
  WriteColmapTextModel(NavInputModel(run), nav_input.string());
  std::vector<std::string> args = {"--database_path",
                                   database.string(),
                                   "--image_path",
                                   run.paths.images_dir.string(),
                                   "--input_path",
                                   nav_input.string(),
                                   "--output_path",
                                   nav_model.string()};
  for (const std::string& a : MapperArgs(run.options)) args.push_back(a);
  std::string failure;
  ColmapModel result;
  if (!run.steps->Run("point_triangulator", args, &failure)) {
    // COLMAP 3.8 aborts (CHECK) in its bundle adjustment when it
    // triangulated nothing: say so instead of "signal 6", with the nav
    // baseline and the angle each point needs (no baseline, no points).
    if (ReadLog(run.steps->LastLog()).find("bundle_adjuster.Solve") != std::string::npos) {
      const double baseline_m =
          (run.input.local_from_cam[1].translation - run.input.local_from_cam[0].translation).norm();
      std::ostringstream reason;
      reason << "colmap point_triangulator: no points triangulated (COLMAP aborted in its bundle adjustment; "
             << "the nav poses put the camera centres " << util::FixedText(baseline_m, 3)
             << " m apart, and a point needs a triangulation angle of "
             << util::ShortestText(run.options.min_tri_angle_deg) << " deg; log: " << run.steps->LastLog()
             << ")";
      failure = reason.str();
    }
    Fail(&nav_result, failure);
  } else if (!ReadModel(nav_model, "point_triangulator", run.steps->LastLog(), &result, &failure)) {
    Fail(&nav_result, failure);
  } else {
    nav_result.points = PointsSeenInImage1(result, run.ids.image_ids.at(ImageName(0)), 1.0,
                                    Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(),
                                    run.camera, run.setup);
    if (nav_result.points.empty()) {
      Fail(&nav_result, "colmap point_triangulator: no points observed in image 1 (" +
                     std::to_string(result.points3D.size()) +
                     " points in the model; log: " + run.steps->LastLog() + ")");
    } else {
      nav_result.ok = true;
      nav_result.failure.clear();
    }
  }
  // The nav pose, not an estimate of the method's own.
  nav_result.has_pose = false;
  nav_result.cam2_from_cam1 = run.input.local_from_cam[1].Inverse() * run.input.local_from_cam[0];
  nav_result.wall_s = run.results->shared_s + SecondsSince(nav_start);
}

// A model image's cam_from_world.
Rigid3d CamFromWorldOf(const ColmapImage& image) {
  return CamFromWorldFromColmap({image.qvec[0], image.qvec[1], image.qvec[2], image.qvec[3],
                                 image.tvec[0], image.tvec[1], image.tvec[2]});
}

// local_from_world = scale * rotation * world + translation.
struct Similarity {
  double scale = 1.0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};

// The similarity taking the free model's frame to the local one, from the
// registered frames' model and nav poses: the rotation their chordal mean,
// the scale the ratio of the camera centres' spreads. false when the centres
// (model or navigation) coincide, which leaves the scale undefined.
bool FitLocalFromWorld(const std::vector<Rigid3d>& cam_from_world,
                       const std::vector<Rigid3d>& cam_from_local, Similarity* local_from_world) {
  // Rotation: chordal mean of R_local_from_world estimates.
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d mean_world = Eigen::Vector3d::Zero(), mean_local = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> centres_world, centres_local;
  for (size_t k = 0; k < cam_from_world.size(); ++k) {
    sum += cam_from_local[k].RotationMatrix().transpose() * cam_from_world[k].RotationMatrix();
    centres_world.push_back(cam_from_world[k].Inverse().translation);
    centres_local.push_back(cam_from_local[k].Inverse().translation);
    mean_world += centres_world.back();
    mean_local += centres_local.back();
  }
  const double n = static_cast<double>(cam_from_world.size());
  mean_world /= n;
  mean_local /= n;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) fix(2, 2) = -1.0;
  const Eigen::Matrix3d rotation = svd.matrixU() * fix * svd.matrixV().transpose();
  double spread_world = 0.0, spread_local = 0.0;
  for (size_t k = 0; k < centres_world.size(); ++k) {
    spread_world += (centres_world[k] - mean_world).squaredNorm();
    spread_local += (centres_local[k] - mean_local).squaredNorm();
  }
  if (!(spread_world > 0) || !(spread_local > 0) || !std::isfinite(spread_world)) return false;
  const double scale = std::sqrt(spread_local / spread_world);
  const Eigen::Vector3d translation = mean_local - scale * rotation * mean_world;
  local_from_world->scale = scale;
  local_from_world->rotation = rotation;
  local_from_world->translation = translation;
  return true;
}

// Alignment of the free model into the local frame: its points seen in image
// 1, and cam2_from_cam1 scaled to metres.
void AlignFreeModel(const ColmapRun& run, const ColmapModel& model) {
  PairReconstruction& free_result = run.results->free;
  const std::uint32_t image1_id = run.ids.image_ids.at(ImageName(0));
  const std::uint32_t image2_id = run.ids.image_ids.at(ImageName(1));
  // Registered frames with their nav poses.
  std::vector<Rigid3d> cam_from_world, cam_from_local;
  const ColmapImage* model1 = model.FindImage(image1_id);
  const ColmapImage* model2 = model.FindImage(image2_id);
  for (size_t i = 0; i < run.num_used; ++i) {
    const ColmapImage* image = model.FindImage(run.ids.image_ids.at(ImageName(i)));
    if (image == nullptr) continue;
    cam_from_world.push_back(CamFromWorldOf(*image));
    cam_from_local.push_back(run.input.local_from_cam[i].Inverse());
  }
  if (model1 == nullptr || model2 == nullptr) {
    Fail(&free_result, std::string("colmap mapper: image ") + (model1 == nullptr ? "1" : "2") +
                    " was not registered (log: " + run.steps->LastLog() + ")");
    return;
  }
  Similarity local_from_world;
  if (!FitLocalFromWorld(cam_from_world, cam_from_local, &local_from_world)) {
    Fail(&free_result,
         "colmap mapper: degenerate alignment: the camera centres (model or "
         "navigation) coincide (log: " +
             run.steps->LastLog() + ")");
    return;
  }
  free_result.points = PointsSeenInImage1(model, image1_id, local_from_world.scale,
                                   local_from_world.rotation, local_from_world.translation,
                                   run.camera, run.setup);
  const Rigid3d w1 = CamFromWorldOf(*model1);
  const Rigid3d w2 = CamFromWorldOf(*model2);
  Rigid3d relative = w2 * w1.Inverse();
  relative.translation *= local_from_world.scale;
  free_result.cam2_from_cam1 = relative;
  if (free_result.points.empty()) {
    Fail(&free_result, "colmap mapper: no points observed in image 1 (" +
                    std::to_string(model.points3D.size()) +
                    " points in the model; log: " + run.steps->LastLog() + ")");
  } else {
    free_result.ok = true;
    free_result.failure.clear();
    free_result.has_pose = true;
  }
}

// colmap-free: mapper from images 1 and 2 on the matches in `database`, then
// the similarity into the local frame. Its time: the shared steps' and its
// own since free_start.
void ReconstructFree(const ColmapRun& run, const fs::path& database, Clock::time_point free_start) {
  PairReconstruction& free_result = run.results->free;
  const fs::path free_dir = run.paths.root / "free";
  fs::create_directories(free_dir);
  std::vector<std::string> args = {"--database_path",
                                   database.string(),
                                   "--image_path",
                                   run.paths.images_dir.string(),
                                   "--output_path",
                                   free_dir.string(),
                                   "--Mapper.multiple_models",
                                   "0",
                                   "--Mapper.init_image_id1",
                                   std::to_string(run.ids.image_ids.at(ImageName(0))),
                                   "--Mapper.init_image_id2",
                                   std::to_string(run.ids.image_ids.at(ImageName(1))),
                                   "--Mapper.init_min_tri_angle",
                                   util::ShortestText(run.options.init_min_tri_angle_deg),
                                   "--Mapper.init_min_num_inliers",
                                   std::to_string(run.options.init_min_num_inliers)};
  for (const std::string& a : MapperArgs(run.options)) args.push_back(a);
  std::string failure;
  ColmapModel model;
  if (!run.steps->Run("mapper", args, &failure)) {
    const std::string why =
        MapperInitialisationFailure(run.options, ReadLog(run.steps->LastLog()), run.steps->LastLog());
    Fail(&free_result, why.empty() ? failure : why);
  } else if (!fs::is_directory(free_dir / "0")) {
    Fail(&free_result, "colmap mapper: no model written in " + free_dir.string() +
                    " (log: " + run.steps->LastLog() + ")");
  } else if (!ReadModel(free_dir / "0", "mapper", run.steps->LastLog(), &model, &failure)) {
    Fail(&free_result, failure);
  } else {
    AlignFreeModel(run, model);
  }
  free_result.wall_s = run.results->shared_s + SecondsSince(free_start);
}

}  // namespace

std::vector<std::string> ColmapOptions::Validate() const {
  std::vector<std::string> errors;
  if (executable.empty()) errors.push_back("executable = '': expected a program name or path");
  RequireOption(timeout_s > 0, "timeout_s", timeout_s, "> 0", &errors);
  RequireOption(threads >= 1, "threads", threads, ">= 1", &errors);
  RequireOption(matcher_threads >= 0, "matcher_threads", matcher_threads, ">= 0 (0: every core)", &errors);
  RequireOption(sift_max_image_size_px >= 16, "sift_max_image_size_px", sift_max_image_size_px,
                ">= 16", &errors);
  RequireOption(sift_max_num_features >= 10, "sift_max_num_features", sift_max_num_features,
                ">= 10", &errors);
  if (sift_first_octave) {
    RequireOption(*sift_first_octave >= -2 && *sift_first_octave <= 2, "sift_first_octave",
                  *sift_first_octave, "in [-2, 2]", &errors);
  }
  RequireOption(sift_octave_resolution >= 1 && sift_octave_resolution <= 12, "sift_octave_resolution",
                sift_octave_resolution, "in [1, 12]", &errors);
  RequireOption(sift_peak_threshold > 0 && sift_peak_threshold < 1, "sift_peak_threshold",
                sift_peak_threshold, "in (0, 1)", &errors);
  RequireOption(sift_max_ratio > 0 && sift_max_ratio <= 1, "sift_max_ratio", sift_max_ratio,
                "in (0, 1]", &errors);
  RequireOption(sift_max_error_px > 0, "sift_max_error_px", sift_max_error_px, "> 0", &errors);
  RequireOption(nav_guided_max_error_px >= 0 && nav_guided_max_error_px <= 1000, "nav_guided_max_error_px",
                nav_guided_max_error_px, "in [0, 1000] (0: exact matching)", &errors);
  RequireOption(min_tri_angle_deg > 0 && min_tri_angle_deg < 90, "min_tri_angle_deg",
                min_tri_angle_deg, "in (0, 90)", &errors);
  RequireOption(init_min_tri_angle_deg > 0 && init_min_tri_angle_deg < 90, "init_min_tri_angle_deg",
                init_min_tri_angle_deg, "in (0, 90)", &errors);
  RequireOption(init_min_num_inliers >= 10, "init_min_num_inliers", init_min_num_inliers, ">= 10",
                &errors);
  return errors;
}

std::string MapperInitialisationFailure(const ColmapOptions& options, const std::string& log,
                                        const std::string& log_path) {
  const auto count = [&log](const std::string& line) {
    int n = 0;
    for (size_t at = log.find(line); at != std::string::npos; at = log.find(line, at + line.size())) ++n;
    return n;
  };
  if (count("Initializing with image pair") == 0 || count("failed to create sparse model") == 0) return "";
  const int tries = 1 + count("Relaxing the initialization constraints");
  int inliers = options.init_min_num_inliers;
  double angle_deg = options.init_min_tri_angle_deg;
  for (int relaxation = 1; relaxation < tries; ++relaxation) {
    if (relaxation % 2 == 1) {
      inliers /= 2;
    } else {
      angle_deg /= 2.0;
    }
  }
  std::ostringstream reason;
  reason << "colmap mapper: no initial pose from images 1 and 2 (COLMAP's initialisation failed ";
  if (tries == 1) {
    reason << "once, asking for " << inliers << " inliers and a triangulation angle of "
           << util::ShortestText(angle_deg) << " deg";
  } else {
    reason << tries << " times, the last asking for " << inliers << " inliers and a triangulation angle of "
           << util::ShortestText(angle_deg) << " deg, relaxed from " << options.init_min_num_inliers << " and "
           << util::ShortestText(options.init_min_tri_angle_deg) << " deg";
  }
  reason << ": too few matches agree on a pose, the images have too little parallax, or the motion is too "
            "close to the line of sight; log: "
         << log_path << ")";
  return reason.str();
}

ColmapCameraParams ToColmapCamera(const calib::CameraModel& camera) {
  const std::string& name = camera.LensModelName();
  const std::vector<double>& in = camera.Intrinsics();
  ColmapCameraParams out;
  if (name == "LENSMODEL_PINHOLE") {
    out.model = "PINHOLE";
  } else if (name == "LENSMODEL_OPENCV4") {
    out.model = "OPENCV";
  } else if (name == "LENSMODEL_OPENCV5" || name == "LENSMODEL_OPENCV8") {
    out.model = "FULL_OPENCV";
  } else {
    throw UnsupportedError(
        "colmap: lens model " + name +
        " has no COLMAP equivalent (COLMAP takes PINHOLE, OPENCV4, OPENCV5 and OPENCV8 as they "
        "are; OPENCV12's thin-prism terms, CAHVOR(E), splined and projective-family models "
        "differ)");
  }
  out.params = in;
  const Eigen::Vector2d c = PixelToColmap(Eigen::Vector2d(in[2], in[3]));
  out.params[2] = c.x();
  out.params[3] = c.y();
  out.params.resize(static_cast<size_t>(ColmapCameraParamCount(out.model)), 0.0);
  return out;
}

int DefaultSiftFirstOctave(double smallest_roi_px, int width, int height) {
  constexpr double kSmallRoiPx = 64.0;
  constexpr int kLargestUpsampledSidePx = 2048;
  const bool small = smallest_roi_px > 0 && smallest_roi_px < kSmallRoiPx;
  return small && std::max(width, height) <= kLargestUpsampledSidePx ? -2 : -1;
}

ColmapResults RunColmap(const ColmapInput& input, const ColmapOptions& given) {
  const Clock::time_point start = Clock::now();
  CheckRunColmapInput(input, given);
  if (!(input.smallest_roi_px >= 0) || !std::isfinite(input.smallest_roi_px)) {
    throw InputError("RunColmap: smallest_roi_px = " + util::ShortestText(input.smallest_roi_px) +
                     ": expected a finite number >= 0");
  }
  const calib::CameraModel& camera = *input.camera;
  ColmapOptions options = given;
  std::string extraction_note;
  if (!options.sift_first_octave) {
    options.sift_first_octave =
        DefaultSiftFirstOctave(input.smallest_roi_px, camera.WidthPx(), camera.HeightPx());
    extraction_note = "SIFT first octave " + std::to_string(*options.sift_first_octave) + ": " +
                      (input.smallest_roi_px > 0 ? "the smallest ROI is " + util::ShortestText(input.smallest_roi_px) +
                                                       " px on a side"
                                                 : std::string("no ROI size given")) +
                      ", the image " + std::to_string(camera.WidthPx()) + " x " +
                      std::to_string(camera.HeightPx()) + " px";
  } else {
    extraction_note = "SIFT first octave " + std::to_string(*options.sift_first_octave) + " (set)";
  }

  ColmapResults results = InitialResults(options);
  results.extraction_note = extraction_note;
  if (!options.run_nav && !options.run_free) return results;

  const WorkspacePaths paths = PrepareWorkspace(input.workspace);
  results.nav.log_dir = paths.logs_dir.string();
  results.free.log_dir = paths.logs_dir.string();

  const CameraSetup setup = SetupCamera(camera);
  results.camera_note = setup.note;
  const size_t num_used = options.run_free && options.use_all_frames ? input.image_paths.size() : 2;
  WriteImages(input.image_paths, camera, setup, num_used, paths.images_dir);

  const std::string executable = util::FindExecutable(options.executable);
  if (executable.empty()) {
    FailBoth(options, start,
             "colmap executable '" + options.executable + "' not found" +
                 (options.executable.find('/') == std::string::npos ? " on PATH" : "") +
                 " or not executable (ColmapOptions::executable)",
             &results);
    return results;
  }

  StepRunner steps(executable, paths.logs_dir, options, &results);
  ColmapRun run{input, options, camera, paths, setup, num_used, start, &steps, &results, {}, {}};
  if (!ExtractFeatures(&run)) return results;
  const MatchPlan exact{paths.database, paths.root / "matches.txt", run.names, std::nullopt,
                        "exact_matcher"};
  std::string failure;
  if (!(options.run_nav && options.nav_guided_max_error_px > 0)) {
    // One matching for both methods.
    if (!MatchAndVerify(run, exact, &failure)) {
      FailBoth(options, start, failure, &results);
      return results;
    }
    results.shared_s = SecondsSince(start);
    if (options.run_nav) ReconstructWithNav(run, paths.database, Clock::now());
    if (options.run_free) ReconstructFree(run, paths.database, Clock::now());
    return results;
  }
  // colmap-nav's guided matches stay out of colmap-free: each method matches
  // into its own copy of the extraction's database.
  MatchPlan free_plan = exact;
  free_plan.database = paths.root / "free.db";
  if (options.run_free) {
    std::error_code copy_error;
    fs::copy_file(paths.database, free_plan.database, fs::copy_options::overwrite_existing, copy_error);
    if (copy_error) {
      FailBoth(options, start,
               "cannot copy " + paths.database.string() + " to " + free_plan.database.string() +
                   ": " + copy_error.message(),
               &results);
      return results;
    }
  }
  results.shared_s = SecondsSince(start);
  const Clock::time_point nav_start = Clock::now();
  if (MatchAndVerify(run, NavGuidedPlan(run, paths.database), &failure)) {
    ReconstructWithNav(run, paths.database, nav_start);
  } else {
    Fail(&results.nav, failure);
    results.nav.wall_s = results.shared_s + SecondsSince(nav_start);
  }
  if (!options.run_free) return results;
  const Clock::time_point free_start = Clock::now();
  if (MatchAndVerify(run, free_plan, &failure)) {
    ReconstructFree(run, free_plan.database, free_start);
  } else {
    Fail(&results.free, failure);
    results.free.wall_s = results.shared_s + SecondsSince(free_start);
  }
  return results;
}

}  // namespace hdabench::reference
