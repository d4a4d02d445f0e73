// mrcal adapter: the one file that talks to libmrcal (docs/conventions.md).
//
// libmrcal's parser is the authority on what a .cameramodel holds. It reports
// problems on stderr with byte offsets and returns NULL, so the reader here
// first scans the file itself (to name the line and the key of a problem), and
// captures libmrcal's stderr for anything the scan let through.
#include "calib/camera_model.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <system_error>

#include "tools/util/files.h"
#include "tools/util/error.h"
#include "tools/util/stderr_capture.h"
#include "tools/util/text.h"

extern "C" {
#include <mrcal/mrcal.h>
}

namespace hdabench::calib {

namespace {

const char* const kRequiredKeys[] = {"lensmodel", "intrinsics", "extrinsics", "imagersize"};

// Line and column (both 1-based) of a byte offset in text.
std::string LineCol(const std::string& text, size_t offset) {
  offset = std::min(offset, text.size());
  size_t line = 1;
  size_t line_start = 0;
  for (size_t i = 0; i < offset; ++i) {
    if (text[i] == '\n') {
      ++line;
      line_start = i + 1;
    }
  }
  return std::to_string(line) + ":" + std::to_string(offset - line_start + 1);
}

// One top-level "'key': value" of the model's dictionary, as byte spans.
struct RawEntry {
  size_t key_offset = 0;
  size_t value_begin = 0;
  size_t value_end = 0;
};

// Scans the Python-literal dictionary that a .cameramodel is. Only the
// structure is checked here; values are read by libmrcal.
class ModelScanner {
 public:
  // The deepest nesting of brackets a value may have.
  static constexpr int kMaxNesting = 32;

  ModelScanner(const std::string& text, const std::string& origin) : text_(text), origin_(origin) {}

  std::map<std::string, RawEntry> Scan() {
    SkipBlank();
    if (pos_ >= text_.size()) Fail(pos_, "the file is empty (expected a { ... } dictionary)");
    if (text_[pos_] != '{') Fail(pos_, "expected '{' to open the model, found '" + Here() + "'");
    ++pos_;
    std::map<std::string, RawEntry> entries;
    for (;;) {
      SkipBlank();
      if (pos_ >= text_.size()) Fail(pos_, "the file ends before the closing '}'");
      if (text_[pos_] == '}') {
        ++pos_;
        break;
      }
      RawEntry entry;
      entry.key_offset = pos_;
      if (text_[pos_] != '\'' && text_[pos_] != '"') {
        Fail(pos_, "expected a quoted key, found '" + Here() + "'");
      }
      const size_t key_begin = pos_ + 1;
      SkipString();
      const std::string key = text_.substr(key_begin, pos_ - key_begin - 1);
      SkipBlank();
      if (pos_ >= text_.size() || text_[pos_] != ':') {
        Fail(pos_, "expected ':' after key '" + key + "'");
      }
      ++pos_;
      SkipBlank();
      entry.value_begin = pos_;
      SkipValue(1);
      entry.value_end = pos_;
      if (entries.count(key) != 0) Fail(entry.key_offset, "key '" + key + "' appears twice");
      entries[key] = entry;
      SkipBlank();
      if (pos_ < text_.size() && text_[pos_] == ',') {
        ++pos_;
      } else if (pos_ < text_.size() && text_[pos_] != '}') {
        Fail(pos_, "expected ',' or '}' after the value of '" + key + "', found '" + Here() + "'");
      }
    }
    SkipBlank();
    if (pos_ < text_.size()) {
      Fail(pos_, "unexpected text after the closing '}': '" + Here() + "'");
    }
    return entries;
  }

  [[noreturn]] void Fail(size_t offset, const std::string& what) const {
    throw InputError(origin_ + ":" + LineCol(text_, offset) + ": " + what);
  }

 private:
  std::string Here() const {
    std::string s = text_.substr(pos_, 20);
    const size_t nl = s.find('\n');
    if (nl != std::string::npos) s.resize(nl);
    return s;
  }
  void SkipBlank() {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '#') {
        while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
      } else if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
        ++pos_;
      } else {
        return;
      }
    }
  }
  void SkipString() {
    const size_t start = pos_;
    const char quote = text_[pos_++];
    while (pos_ < text_.size() && text_[pos_] != quote) {
      if (text_[pos_] == '\\') ++pos_;
      ++pos_;
    }
    if (pos_ >= text_.size()) Fail(start, "unterminated string");
    ++pos_;
  }
  // Skips one value whose brackets, if it opens one, are at nesting level
  // `depth` (a key's value is at 1). Deeper than kMaxNesting is an error: no
  // model nests its values more than a few levels, and the scan recurses once
  // a level, so it stops there rather than on the stack's end.
  void SkipValue(int depth) {
    if (pos_ >= text_.size()) Fail(pos_, "expected a value, found the end of the file");
    const char c = text_[pos_];
    if (c == '\'' || c == '"') {
      SkipString();
    } else if ((c == 'b' || c == 'B') && pos_ + 1 < text_.size() &&
               (text_[pos_ + 1] == '\'' || text_[pos_ + 1] == '"')) {
      ++pos_;
      SkipString();
    } else if (c == '[' || c == '(' || c == '{') {
      if (depth > kMaxNesting) {
        Fail(pos_, "values nested more than " + std::to_string(kMaxNesting) + " levels deep");
      }
      const size_t start = pos_;
      const char close = c == '[' ? ']' : (c == '(' ? ')' : '}');
      ++pos_;
      for (;;) {
        SkipBlank();
        if (pos_ >= text_.size()) Fail(start, std::string("unclosed '") + c + "'");
        if (text_[pos_] == close) {
          ++pos_;
          return;
        }
        if (text_[pos_] == ',' || text_[pos_] == ':') {
          ++pos_;
          continue;
        }
        SkipValue(depth + 1);
      }
    } else {
      const size_t start = pos_;
      while (pos_ < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[pos_])) ||
                                     text_[pos_] == '.' || text_[pos_] == '-' ||
                                     text_[pos_] == '+' || text_[pos_] == '_')) {
        ++pos_;
      }
      if (pos_ == start) Fail(pos_, "expected a value, found '" + Here() + "'");
    }
  }

  const std::string& text_;
  const std::string& origin_;
  size_t pos_ = 0;
};

// The items of a flat list value "[a, b, c,]" as trimmed strings with offsets.
std::vector<std::pair<std::string, size_t>> ListItems(const std::string& text, const RawEntry& e) {
  std::vector<std::pair<std::string, size_t>> items;
  size_t i = e.value_begin + 1;
  const size_t end = e.value_end - 1;
  while (i < end) {
    while (i < end && (std::isspace(static_cast<unsigned char>(text[i])) || text[i] == '#')) {
      if (text[i] == '#') {
        while (i < end && text[i] != '\n') ++i;
      } else {
        ++i;
      }
    }
    const size_t start = i;
    while (i < end && text[i] != ',' && !std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i > start) items.emplace_back(text.substr(start, i - start), start);
    while (i < end && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i < end && text[i] == ',') ++i;
  }
  return items;
}

// Parses a list of exactly `expected` finite numbers; fails naming key and index.
std::vector<double> ParseNumberList(const ModelScanner& scanner, const std::string& text,
                                    const std::string& key, const RawEntry& e, int expected,
                                    const std::string& what_expected) {
  if (text[e.value_begin] != '[' && text[e.value_begin] != '(') {
    scanner.Fail(e.value_begin, "'" + key + "' must be a list of numbers");
  }
  const auto items = ListItems(text, e);
  if (static_cast<int>(items.size()) != expected) {
    scanner.Fail(e.value_begin, "'" + key + "' has " + std::to_string(items.size()) +
                                    " values; " + what_expected);
  }
  std::vector<double> values;
  for (size_t i = 0; i < items.size(); ++i) {
    const std::string& item = items[i].first;
    // Decimal notation only, as libmrcal reads it (no hex, no '_' separators).
    const char* first = item.c_str();
    if (*first == '+') ++first;
    double v = 0.0;
    const auto [end, ec] = std::from_chars(first, item.c_str() + item.size(), v);
    if (ec != std::errc() || end != item.c_str() + item.size() || !std::isfinite(v)) {
      scanner.Fail(items[i].second, "'" + key + "'[" + std::to_string(i) + "] = '" + item +
                                        "' is not a finite decimal number");
    }
    values.push_back(v);
  }
  return values;
}

// Turns libmrcal's last stderr line, e.g.
//   "cameramodel-parser.re(540): Garbage after trailing } at 117. Giving up"
// into "<line>:<col>: libmrcal: Garbage after trailing }. Giving up", turning
// its byte offset ("at N" or "at position N") into a line and column.
std::string TranslateMrcalMessage(const std::string& captured, const std::string& text) {
  std::string message = captured;
  while (!message.empty() && (message.back() == '\n' || message.back() == ' ')) message.pop_back();
  const size_t nl = message.rfind('\n');
  if (nl != std::string::npos) message = message.substr(nl + 1);
  const size_t prefix = message.find("): ");
  if (prefix != std::string::npos && message.compare(0, 11, "cameramodel") == 0) {
    message = message.substr(prefix + 3);
  }
  if (message.empty()) message = "could not parse the model";
  for (const char* marker : {" at position ", " at "}) {
    const size_t at = message.find(marker);
    if (at == std::string::npos) continue;
    const size_t digits_begin = at + std::char_traits<char>::length(marker);
    size_t digits_end = digits_begin;
    while (digits_end < message.size() && std::isdigit(static_cast<unsigned char>(message[digits_end]))) {
      ++digits_end;
    }
    if (digits_end == digits_begin) continue;
    const size_t offset = std::stoul(message.substr(digits_begin, digits_end - digits_begin));
    return LineCol(text, offset) + ": libmrcal: " + message.substr(0, at) + message.substr(digits_end);
  }
  return " libmrcal: " + message;
}

bool ParseLensModel(const std::string& name, mrcal_lensmodel_t* lensmodel) {
  return mrcal_lensmodel_from_name(lensmodel, name.c_str()) &&
         mrcal_lensmodel_type_is_valid(lensmodel->type);
}

std::string ReadWholeFile(const std::string& path) {
  std::string bytes;
  std::string error;
  if (!util::ReadFileBytes(path, &bytes, &error)) {
    throw InputError(path + ": camera model file: " + error);
  }
  return bytes;
}

void RefineBearings(const mrcal_lensmodel_t* model, const std::vector<double>& intrinsics,
                    const std::vector<Eigen::Vector2d>& pixels,
                    const std::vector<unsigned char>& valid,
                    std::vector<Eigen::Vector3d>* bearings) {
  // libmrcal's unprojection stops at about 1e-8 px. Gauss-Newton on the tangent
  // plane of each bearing, with libmrcal's projection gradients, brings the
  // reprojection error to the level of floating-point noise. A step is kept
  // only when it lowers that point's error.
  // One point per mrcal_project call: libmrcal 2.2 writes every point's dq_dp
  // of an OPENCV model into the first slot when given a batch.
  const auto project = [&](const Eigen::Vector3d& b, Eigen::Vector2d* q, Eigen::Matrix<double, 2, 3>* dq_db) {
    mrcal_point3_t p;
    for (int k = 0; k < 3; ++k) p.xyz[k] = b[k];
    mrcal_point2_t out;
    mrcal_point3_t gradient[2];
    if (!mrcal_project(&out, dq_db ? gradient : nullptr, nullptr, &p, 1, model, intrinsics.data())) {
      return false;
    }
    *q = Eigen::Vector2d(out.x, out.y);
    if (dq_db != nullptr) {
      for (int row = 0; row < 2; ++row) {
        for (int k = 0; k < 3; ++k) (*dq_db)(row, k) = gradient[row].xyz[k];
      }
    }
    return q->allFinite();
  };
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (!valid[i]) continue;
    Eigen::Vector3d& b = (*bearings)[i];
    for (int iteration = 0; iteration < 3; ++iteration) {
      Eigen::Vector2d q;
      Eigen::Matrix<double, 2, 3> dq_db;
      if (!project(b, &q, &dq_db) || !dq_db.allFinite()) break;
      const Eigen::Vector2d residual = q - pixels[i];
      if (residual.norm() == 0.0) break;
      // An orthonormal basis (e1, e2) of the plane perpendicular to b.
      const Eigen::Vector3d helper =
          std::abs(b.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
      const Eigen::Vector3d e1 = b.cross(helper).normalized();
      const Eigen::Vector3d e2 = b.cross(e1);
      Eigen::Matrix2d j;
      j.col(0) = dq_db * e1;
      j.col(1) = dq_db * e2;
      if (std::abs(j.determinant()) < 1e-300) break;
      const Eigen::Vector2d step = j.partialPivLu().solve(-residual);
      const Eigen::Vector3d candidate = (b + step.x() * e1 + step.y() * e2).normalized();
      Eigen::Vector2d q_candidate;
      if (!project(candidate, &q_candidate, nullptr) ||
          (q_candidate - pixels[i]).norm() >= residual.norm()) {
        break;
      }
      b = candidate;
    }
  }
}

}  // namespace

CameraModel::CameraModel(const std::string& lensmodel, std::vector<double> intrinsics,
                         int width_px, int height_px, const std::array<double, 6>& rt_cam_ref,
                         const std::string& origin)
    : lensmodel_(lensmodel),
      intrinsics_(std::move(intrinsics)),
      width_px_(width_px),
      height_px_(height_px),
      rt_cam_ref_(rt_cam_ref) {
  const int expected = LensModelParameterCount(lensmodel_, origin);
  if (static_cast<int>(intrinsics_.size()) != expected) {
    throw InputError(origin + ": lens model " + lensmodel_ + " takes " + std::to_string(expected) +
                     " intrinsics, got " + std::to_string(intrinsics_.size()));
  }
  for (size_t i = 0; i < intrinsics_.size(); ++i) {
    if (!std::isfinite(intrinsics_[i])) {
      throw InputError(origin + ": intrinsics[" + std::to_string(i) + "] is not finite");
    }
  }
  for (size_t i = 0; i < rt_cam_ref_.size(); ++i) {
    if (!std::isfinite(rt_cam_ref_[i])) {
      throw InputError(origin + ": extrinsics[" + std::to_string(i) + "] is not finite");
    }
  }
  if (width_px_ <= 0 || height_px_ <= 0) {
    throw InputError(origin + ": imager size " + std::to_string(width_px_) + "x" +
                     std::to_string(height_px_) + " is not positive");
  }
  mrcal_lensmodel_t model;
  ParseLensModel(lensmodel_, &model);  // known valid: LensModelParameterCount accepted it
  const mrcal_lensmodel_metadata_t meta = mrcal_lensmodel_metadata(&model);
  has_core_ = meta.has_core;
  can_project_behind_camera_ = meta.can_project_behind_camera;
  is_cahvore_ = model.type == MRCAL_LENSMODEL_CAHVORE;
  has_opencv_equivalent_ =
      model.type == MRCAL_LENSMODEL_PINHOLE || MRCAL_LENSMODEL_IS_OPENCV(model.type);
  if (has_core_ && (intrinsics_[0] <= 0.0 || intrinsics_[1] <= 0.0)) {
    throw InputError(origin + ": focal lengths fx=" + util::ShortestText(intrinsics_[0]) +
                     ", fy=" + util::ShortestText(intrinsics_[1]) + " must be positive");
  }
}

CameraModel CameraModel::Load(const std::string& path) {
  return Parse(ReadWholeFile(path), path);
}

CameraModel CameraModel::Parse(const std::string& text, const std::string& origin) {
  ModelScanner scanner(text, origin);
  const std::map<std::string, RawEntry> entries = scanner.Scan();

  std::string missing;
  for (const char* key : kRequiredKeys) {
    if (entries.count(key) == 0) missing += std::string(missing.empty() ? "" : ", ") + "'" + key + "'";
  }
  if (!missing.empty()) {
    throw InputError(origin + ": missing key " + missing +
                     " (a .cameramodel needs 'lensmodel', 'intrinsics', 'extrinsics', 'imagersize')");
  }

  const RawEntry& lens_entry = entries.at("lensmodel");
  const char quote = text[lens_entry.value_begin];
  if (quote != '\'' && quote != '"') scanner.Fail(lens_entry.value_begin, "'lensmodel' must be a string");
  const std::string lensmodel =
      text.substr(lens_entry.value_begin + 1, lens_entry.value_end - lens_entry.value_begin - 2);
  mrcal_lensmodel_t model;
  if (!ParseLensModel(lensmodel, &model)) {
    if (mrcal_lensmodel_type_from_name(lensmodel.c_str()) >= 0) {
      scanner.Fail(lens_entry.value_begin,
                   "lens model '" + lensmodel + "' has a missing or invalid configuration");
    }
    scanner.Fail(lens_entry.value_begin, "unknown lens model '" + lensmodel + "'");
  }
  const int num_params = mrcal_lensmodel_num_params(&model);
  const std::vector<double> intrinsics =
      ParseNumberList(scanner, text, "intrinsics", entries.at("intrinsics"), num_params,
                      lensmodel + " takes " + std::to_string(num_params));
  ParseNumberList(scanner, text, "extrinsics", entries.at("extrinsics"), 6,
                  "expected 6 (rt_cam_ref: rotation vector, translation)");
  const std::vector<double> imagersize = ParseNumberList(
      scanner, text, "imagersize", entries.at("imagersize"), 2, "expected 2 (width, height)");
  for (int i = 0; i < 2; ++i) {
    if (imagersize[i] < 1 || imagersize[i] > 1e6 || imagersize[i] != std::floor(imagersize[i])) {
      scanner.Fail(entries.at("imagersize").value_begin,
                   "'imagersize' must be two positive whole numbers of pixels, got " +
                       util::ShortestText(imagersize[0]) + ", " + util::ShortestText(imagersize[1]));
    }
  }

  // libmrcal reads the values: it is the authority on the format. It is given
  // the text with a newline added: libmrcal 2.x ends the whole process when a
  // comment runs to the end of its input (the cameramodel fuzzer found it);
  // a newline at the end changes nothing else, and every offset stays.
  const std::string terminated = text + "\n";
  mrcal_cameramodel_t* parsed = nullptr;
  const std::string captured = util::CaptureStderr([&] {
    parsed = mrcal_read_cameramodel_string(terminated.c_str(), static_cast<int>(terminated.size()));
  });
  if (parsed == nullptr) throw InputError(origin + ":" + TranslateMrcalMessage(captured, text));
  std::unique_ptr<mrcal_cameramodel_t, void (*)(mrcal_cameramodel_t*)> owner(
      parsed, [](mrcal_cameramodel_t* m) { mrcal_free_cameramodel(&m); });

  char name[1024];
  if (!mrcal_lensmodel_name(name, sizeof(name), &parsed->lensmodel)) {
    throw InputError(origin + ": libmrcal cannot name the lens model it parsed");
  }
  const int n = mrcal_lensmodel_num_params(&parsed->lensmodel);
  std::vector<double> values(parsed->intrinsics, parsed->intrinsics + n);
  std::array<double, 6> rt;
  std::copy(parsed->rt_cam_ref, parsed->rt_cam_ref + 6, rt.begin());
  // The scan and libmrcal must agree; a disagreement is a parser difference
  // worth reporting rather than guessing which is right.
  if (values != intrinsics) {
    throw InputError(origin + ": libmrcal read different intrinsics than the file holds");
  }
  return CameraModel(name, std::move(values), static_cast<int>(parsed->imagersize[0]),
                     static_cast<int>(parsed->imagersize[1]), rt, origin);
}

std::string CameraModel::ToText() const {
  std::string s = "{\n    'lensmodel':  '" + lensmodel_ + "',\n\n";
  s += "    # intrinsics are fx,fy,cx,cy,distortion0,distortion1,....\n    'intrinsics': [";
  for (double v : intrinsics_) s += " " + util::ShortestText(v) + ",";
  s += " ],\n\n    # extrinsics are rt_fromref\n    'extrinsics': [";
  for (double v : rt_cam_ref_) s += " " + util::ShortestText(v) + ",";
  s += " ],\n\n    'imagersize': [ " + std::to_string(width_px_) + ", " +
       std::to_string(height_px_) + ", ],\n}\n";
  return s;
}

void CameraModel::Save(const std::string& path) const {
  // The folder must exist: a model is never the first file of a new folder
  // by accident of a mistyped path.
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty() && !std::filesystem::is_directory(parent, ec)) {
    throw InputError(path + ": cannot write the camera model (No such file or directory)");
  }
  util::WriteFileAtomically(path, ToText());
}

Rigid3d CameraModel::CamFromRef() const {
  const Eigen::Vector3d r(rt_cam_ref_[0], rt_cam_ref_[1], rt_cam_ref_[2]);
  const double angle = r.norm();
  const Eigen::Quaterniond q =
      angle > 0.0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, r / angle)) : Eigen::Quaterniond::Identity();
  return Rigid3d(q, Eigen::Vector3d(rt_cam_ref_[3], rt_cam_ref_[4], rt_cam_ref_[5]));
}

int CameraModel::Project(const std::vector<Eigen::Vector3d>& points_in_cam,
                         std::vector<Eigen::Vector2d>* pixels,
                         std::vector<unsigned char>* valid) const {
  const size_t n = points_in_cam.size();
  pixels->assign(n, Eigen::Vector2d::Zero());
  valid->assign(n, 0);
  std::vector<mrcal_point3_t> p(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& v = points_in_cam[i];
    const bool ok = v.allFinite() && v.squaredNorm() > 0.0 &&
                    (can_project_behind_camera_ || v.z() > 0.0);
    (*valid)[i] = ok ? 1 : 0;
    const Eigen::Vector3d use = ok ? v : Eigen::Vector3d(0, 0, 1);
    for (int k = 0; k < 3; ++k) p[i].xyz[k] = use[k];
  }
  if (n == 0) return 0;
  mrcal_lensmodel_t model;
  ParseLensModel(lensmodel_, &model);
  std::vector<mrcal_point2_t> q(n);
  if (!mrcal_project(q.data(), nullptr, nullptr, p.data(), static_cast<int>(n), &model,
                     intrinsics_.data())) {
    valid->assign(n, 0);
    return 0;
  }
  int count = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d pixel(q[i].x, q[i].y);
    if ((*valid)[i] && pixel.allFinite()) {
      (*pixels)[i] = pixel;
      ++count;
    } else {
      (*valid)[i] = 0;
    }
  }
  return count;
}

int CameraModel::Unproject(const std::vector<Eigen::Vector2d>& pixels,
                           std::vector<Eigen::Vector3d>* bearings_in_cam,
                           std::vector<unsigned char>* valid) const {
  if (is_cahvore_) {
    throw UnsupportedError("lens model " + lensmodel_ +
                           ": libmrcal cannot unproject CAHVORE models");
  }
  const size_t n = pixels.size();
  bearings_in_cam->assign(n, Eigen::Vector3d::Zero());
  valid->assign(n, 0);
  std::vector<mrcal_point2_t> q(n);
  for (size_t i = 0; i < n; ++i) {
    const bool ok = pixels[i].allFinite();
    (*valid)[i] = ok ? 1 : 0;
    q[i].x = ok ? pixels[i].x() : 0.0;
    q[i].y = ok ? pixels[i].y() : 0.0;
  }
  if (n == 0) return 0;
  mrcal_lensmodel_t model;
  ParseLensModel(lensmodel_, &model);
  std::vector<mrcal_point3_t> v(n);
  if (!mrcal_unproject(v.data(), q.data(), static_cast<int>(n), &model, intrinsics_.data())) {
    valid->assign(n, 0);
    return 0;
  }
  int count = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d d(v[i].x, v[i].y, v[i].z);
    const double norm = d.norm();
    if ((*valid)[i] && std::isfinite(norm) && norm > 0.0) {
      (*bearings_in_cam)[i] = d / norm;
      ++count;
    } else {
      (*valid)[i] = 0;
    }
  }
  RefineBearings(&model, intrinsics_, pixels, *valid, bearings_in_cam);
  return count;
}

bool CameraModel::HasOpenCvEquivalent() const { return has_opencv_equivalent_; }

void CameraModel::ToOpenCv(cv::Mat* camera_matrix, cv::Mat* distortion) const {
  if (!has_opencv_equivalent_) {
    throw UnsupportedError("lens model " + lensmodel_ +
                           " has no OpenCV equivalent (OpenCV's camera model covers only "
                           "LENSMODEL_PINHOLE and LENSMODEL_OPENCV4/5/8/12); undistort the "
                           "images with the mrcal model and use a pinhole camera instead");
  }
  *camera_matrix = (cv::Mat_<double>(3, 3) << intrinsics_[0], 0.0, intrinsics_[2], 0.0,
                    intrinsics_[1], intrinsics_[3], 0.0, 0.0, 1.0);
  const int num_distortion = static_cast<int>(intrinsics_.size()) - 4;
  *distortion = cv::Mat(1, num_distortion, CV_64F);
  for (int i = 0; i < num_distortion; ++i) distortion->at<double>(0, i) = intrinsics_[4 + i];
}

int LensModelParameterCount(const std::string& lensmodel, const std::string& origin) {
  mrcal_lensmodel_t model;
  if (!ParseLensModel(lensmodel, &model)) {
    if (mrcal_lensmodel_type_from_name(lensmodel.c_str()) >= 0) {
      throw InputError(origin + ": lens model '" + lensmodel +
                       "' has a missing or invalid configuration");
    }
    throw InputError(origin + ": unknown lens model '" + lensmodel +
                     "' (libmrcal 2.2 knows LENSMODEL_PINHOLE, LENSMODEL_OPENCV4/5/8/12, "
                     "LENSMODEL_STEREOGRAPHIC, LENSMODEL_LONLAT, LENSMODEL_LATLON, "
                     "LENSMODEL_CAHVOR, LENSMODEL_CAHVORE_..., LENSMODEL_SPLINED_STEREOGRAPHIC_...)");
  }
  return mrcal_lensmodel_num_params(&model);
}

std::vector<std::string> SupportedLensModels() {
  std::vector<std::string> names;
  for (const char* const* p = mrcal_supported_lensmodel_names(); *p != nullptr; ++p) {
    names.emplace_back(*p);
  }
  return names;
}

}  // namespace hdabench::calib
