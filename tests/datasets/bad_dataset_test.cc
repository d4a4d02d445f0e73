// The catalogue of bad datasets: each case writes a valid (small) example
// dataset, applies one defect, and checks that LoadDataset reports exactly the
// expected problem and that `hdabench dataset check` exits 1 printing it.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "datasets/dataset.h"
#include "datasets/example.h"
#include "datasets/npy.h"
#include "tests/support/test_support.h"
#include "tools/images/codecs.h"

namespace hdabench::datasets {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;
using testing_support::CurrentTestSeed;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::ReplaceLine;
using testing_support::SetCsvValue;
using testing_support::SplitLines;
using testing_support::WriteText;

// The example at 64 x 64 px: the same generator and files, small enough that
// each case writes its own copy in a few tens of milliseconds.
constexpr int kImageSizePx = 64;

fs::path WriteSmallExample(const fs::path& dir, std::uint64_t seed) {
  ExampleDatasetOptions options;
  options.seed = seed;
  options.image_size_px = kImageSizePx;
  WriteDataset(MakeExampleDataset(options), dir.string());
  return dir;
}

void EditManifest(const fs::path& dir, const std::function<void(json&)>& edit) {
  json manifest = json::parse(ReadText(dir / "manifest.json"));
  edit(manifest);
  WriteText(dir / "manifest.json", manifest.dump(2) + "\n");
}

void ReplaceText(const fs::path& path, const std::string& from, const std::string& to) {
  std::string text = ReadText(path);
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << from << " not in " << path;
  text.replace(at, from.size(), to);
  WriteText(path, text);
}

// Keeps the first `count` lines of a text file.
void KeepLines(const fs::path& path, size_t count) {
  std::vector<std::string> lines = SplitLines(ReadText(path));
  lines.resize(std::min(count, lines.size()));
  WriteText(path, testing_support::JoinLines(lines));
}

// Applies `edit` to every line of a CSV file (header included, index 0).
void EditCsvLines(const fs::path& path,
                  const std::function<void(size_t, std::vector<std::string>*)>& edit) {
  std::vector<std::string> lines = SplitLines(ReadText(path));
  for (size_t i = 0; i < lines.size(); ++i) {
    std::vector<std::string> fields = testing_support::SplitCsv(lines[i]);
    edit(i, &fields);
    lines[i] = testing_support::JoinCsv(fields);
  }
  WriteText(path, testing_support::JoinLines(lines));
}

std::uint32_t BigEndian32(const std::string& bytes, size_t offset) {
  std::uint32_t value = 0;
  for (size_t i = 0; i < 4; ++i) value = (value << 8) | static_cast<unsigned char>(bytes[offset + i]);
  return value;
}

std::uint32_t PngCrc(const std::string& bytes, size_t begin, size_t length) {
  std::uint32_t crc = 0xffffffffU;
  for (size_t i = begin; i < begin + length; ++i) {
    crc ^= static_cast<unsigned char>(bytes[i]);
    for (int k = 0; k < 8; ++k) crc = (crc & 1U) != 0 ? 0xedb88320U ^ (crc >> 1) : crc >> 1;
  }
  return crc ^ 0xffffffffU;
}

// Gives the dataset a valid truth navigation (a copy of nav.csv, whose span
// covers the frames) at truth/navigation.csv.
void AddTruthNavigation(const fs::path& dir) {
  WriteText(dir / "truth/navigation.csv", ReadText(dir / "nav.csv"));
  EditManifest(dir, [](json& m) { m["truth"]["navigation"] = "truth/navigation.csv"; });
}

const char kRocksCsv[] =
    "x_m,y_m,z_m,diameter_m,height_above_ground_m\n"
    "12.5,-3.25,0.4,1.2,0.6\n"
    "-40,220,0.9,2,1.1\n"
    "3,410.75,0.25,0.5,0.5\n";

// Gives the dataset a truth rocks table at truth/rocks.csv.
void AddTruthRocks(const fs::path& dir, const std::string& text = kRocksCsv) {
  WriteText(dir / "truth/rocks.csv", text);
  EditManifest(dir, [](json& m) { m["truth"]["rocks"] = "truth/rocks.csv"; });
}

constexpr size_t kFirstIdatOffset = 33;  // signature (8) + IHDR chunk (25)

std::string Manifest(const std::string& field) { return "manifest.json: field '" + field + "'"; }

const char kManifestFields[] =
    "format, format_version, name, description, camera_model, frames, navigation, lrf, "
    "cam_from_body, gravity_in_local_mps2, ils_in_local_m, lrf_origin_in_body_m, truth";
const char kNavColumns[] =
    "expected columns time_s, x_m, y_m, z_m, qw, qx, qy, qz (optional: vx_mps, vy_mps, vz_mps; "
    "sigma_x_m, sigma_y_m, sigma_z_m, sigma_rx_rad, sigma_ry_rad, sigma_rz_rad)";

struct Defect {
  std::string name;
  // Damages the dataset in `dir` and returns the one problem it must cause.
  std::function<Problem(const fs::path& dir)> apply;
};

std::ostream& operator<<(std::ostream& os, const Defect& defect) { return os << defect.name; }

std::vector<Defect> Catalogue() {
  return {
      // ------------------------------------------------------------ manifest
      {"ManifestMissing",
       [](const fs::path& dir) {
         fs::remove(dir / "manifest.json");
         return Problem{"manifest.json", "file not found"};
       }},
      {"ManifestIsAFolder",
       [](const fs::path& dir) {
         fs::remove(dir / "manifest.json");
         fs::create_directory(dir / "manifest.json");
         return Problem{"manifest.json", "is a directory; expected a file"};
       }},
      {"ManifestNotJson",
       [](const fs::path& dir) {
         WriteText(dir / "manifest.json",
                   "{\n  \"format\": \"hdabench-dataset\",\n  \"format_version\": 1,\n  oops\n}\n");
         return Problem{"manifest.json",
                        "is not valid JSON (parse error at line 4, column 3: syntax error while "
                        "parsing object key - invalid literal; last read: '1,<U+000A>  o'; "
                        "expected string literal)"};
       }},
      {"ManifestNanLiteral",
       [](const fs::path& dir) {
         ReplaceText(dir / "manifest.json", "-1.62", "NaN");
         return Problem{"manifest.json",
                        "is not valid JSON (parse error at line 26, column 5: syntax error while "
                        "parsing value - invalid literal; last read: '0.0,<U+000A>    N')"};
       }},
      {"ManifestNumberOverflow",
       [](const fs::path& dir) {
         ReplaceText(dir / "manifest.json", "-1.62", "-1e999");
         return Problem{"manifest.json", "is not valid JSON (number overflow parsing '-1e999')"};
       }},
      {"ManifestNotAnObject",
       [](const fs::path& dir) {
         WriteText(dir / "manifest.json", "[1, 2]\n");
         return Problem{"manifest.json",
                        "is an array of 2 elements; expected a JSON object {\"format\": "
                        "\"hdabench-dataset\", ...}"};
       }},
      {"WrongFormat",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["format"] = "colmap-model"; });
         return Problem{Manifest("format"),
                        "is a string (\"colmap-model\"); expected \"hdabench-dataset\""};
       }},
      {"WrongFormatVersion",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["format_version"] = 2; });
         return Problem{Manifest("format_version"), "is 2; this build reads format_version 1 only"};
       }},
      {"MissingKey",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m.erase("ils_in_local_m"); });
         return Problem{Manifest("ils_in_local_m"), "is missing; expected [x, y, z] in metres"};
       }},
      {"MissingPath",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m.erase("navigation"); });
         return Problem{Manifest("navigation"),
                        "is missing; expected a string: the path of the navigation table, "
                        "relative to the dataset folder"};
       }},
      {"UnknownKey",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["gravity_mps2"] = json::array({0, 0, -1.62}); });
         return Problem{Manifest("gravity_mps2"),
                        std::string("is not a field of format_version 1; expected only ") +
                            kManifestFields};
       }},
      {"RepeatedKey",
       [](const fs::path& dir) {
         ReplaceText(dir / "manifest.json", "\"format_version\": 1,",
                     "\"format_version\": 1,\n  \"name\": \"first\",");
         return Problem{Manifest("name"), "appears twice; the last value would win"};
       }},
      {"WrongValueType",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["ils_in_local_m"] = "origin"; });
         return Problem{Manifest("ils_in_local_m"),
                        "is a string (\"origin\"); expected 3 numbers: [x, y, z] in metres"};
       }},
      {"NumberAsString",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["gravity_in_local_mps2"][2] = "-1.62"; });
         return Problem{Manifest("gravity_in_local_mps2[2]"),
                        "is a string (\"-1.62\"); expected a number"};
       }},
      {"WrongArrayLength",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["lrf_origin_in_body_m"] = json::array({0.4, 0.1}); });
         return Problem{Manifest("lrf_origin_in_body_m"),
                        "is an array of 2 elements; expected 3 numbers: [x, y, z] in metres"};
       }},
      {"MountQuaternionNotUnit",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) {
           m["cam_from_body"]["quaternion_wxyz"] = json::array({0.9, 0.0, 0.0, 0.0});
         });
         return Problem{Manifest("cam_from_body.quaternion_wxyz"),
                        "quaternion (0.9, 0, 0, 0) has norm 0.9; expected a unit quaternion "
                        "(| |q| - 1 | <= 1e-6)"};
       }},
      {"ZeroGravity",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["gravity_in_local_mps2"] = json::array({0, 0, 0}); });
         return Problem{Manifest("gravity_in_local_mps2"),
                        "is (0, 0, 0), which has no direction; expected the gravity vector in the "
                        "local frame, e.g. [0, 0, -1.62] on the Moon"};
       }},
      {"PathLeavesDataset",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["frames"] = "../frames.csv"; });
         return Problem{Manifest("frames"),
                        "'../frames.csv' leaves the dataset folder ('..'); expected a path inside "
                        "it"};
       }},
      {"EmptyName",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["name"] = ""; });
         return Problem{Manifest("name"), "is empty; expected a name for the dataset"};
       }},
      // -------------------------------------------------------------- camera
      {"CameraModelMissing",
       [](const fs::path& dir) {
         fs::remove(dir / "camera.cameramodel");
         return Problem{"camera.cameramodel",
                        "file not found (manifest.json field 'camera_model')"};
       }},
      {"UnknownLensModel",
       [](const fs::path& dir) {
         ReplaceText(dir / "camera.cameramodel", "LENSMODEL_OPENCV8", "LENSMODEL_FISHEYE9");
         return Problem{"camera.cameramodel:2:19", "unknown lens model 'LENSMODEL_FISHEYE9'"};
       }},
      // -------------------------------------------------------------- tables
      {"FramesTableEmpty",
       [](const fs::path& dir) {
         WriteText(dir / "frames.csv", "");
         return Problem{"frames.csv", "file is empty; expected a header line: frame, time_s, image"};
       }},
      {"MissingColumn",
       [](const fs::path& dir) {
         EditCsvLines(dir / "frames.csv",
                      [](size_t, std::vector<std::string>* fields) { fields->pop_back(); });
         return Problem{"frames.csv:1",
                        "missing column 'image'; expected columns frame, time_s, image"};
       }},
      {"UnknownColumn",
       [](const fs::path& dir) {
         EditCsvLines(dir / "nav.csv", [](size_t i, std::vector<std::string>* fields) {
           fields->push_back(i == 0 ? "temperature_c" : "20");
         });
         return Problem{"nav.csv:1", std::string("unknown column 'temperature_c'; ") + kNavColumns};
       }},
      {"RepeatedColumn",
       [](const fs::path& dir) {
         EditCsvLines(dir / "lrf.csv", [](size_t i, std::vector<std::string>* fields) {
           fields->push_back(i == 0 ? "range_m" : "500");
         });
         return Problem{"lrf.csv:1", "column 'range_m' appears twice"};
       }},
      {"PartialOptionalColumns",
       [](const fs::path& dir) {
         EditCsvLines(dir / "nav.csv", [](size_t, std::vector<std::string>* fields) {
           fields->erase(fields->begin() + 10);  // vz_mps
         });
         return Problem{"nav.csv:1",
                        "optional columns vx_mps, vy_mps, vz_mps must all be present or all "
                        "absent; missing vz_mps"};
       }},
      {"WrongValueCount",
       [](const fs::path& dir) {
         EditCsvLines(dir / "nav.csv", [](size_t i, std::vector<std::string>* fields) {
           if (i == 4) fields->pop_back();
         });
         return Problem{"nav.csv:5", "row has 16 values; the header has 17 columns"};
       }},
      {"EmptyLine",
       [](const fs::path& dir) {
         ReplaceLine(dir / "nav.csv", 10, "");
         return Problem{"nav.csv:10", "empty line; expected 17 comma-separated values"};
       }},
      {"UnparsableNumber",
       [](const fs::path& dir) {
         SetCsvValue(dir / "nav.csv", 10, "x_m", "12.5m");
         return Problem{"nav.csv:10", "column 'x_m': '12.5m' is not a number"};
       }},
      {"NanInNavigation",
       [](const fs::path& dir) {
         SetCsvValue(dir / "nav.csv", 7, "z_m", "nan");
         return Problem{"nav.csv:7", "column 'z_m': value 'nan' is not finite; expected a finite "
                                     "number"};
       }},
      {"InfInLrf",
       [](const fs::path& dir) {
         SetCsvValue(dir / "lrf.csv", 4, "range_m", "inf");
         return Problem{"lrf.csv:4", "column 'range_m': value 'inf' is not finite; expected a "
                                     "finite number"};
       }},
      {"NumberOutOfRange",
       [](const fs::path& dir) {
         SetCsvValue(dir / "lrf.csv", 4, "range_m", "1e999");
         return Problem{"lrf.csv:4", "column 'range_m': value '1e999' is out of the range of a "
                                     "double"};
       }},
      {"NavTimeNotIncreasing",
       [](const fs::path& dir) {
         SetCsvValue(dir / "nav.csv", 20, "time_s", "0.34");  // line 19 holds 0.34
         return Problem{"nav.csv:20", "time_s 0.34 is not after the previous navigation time 0.34 "
                                      "s (line 19); times must strictly increase"};
       }},
      {"FrameTimeNotIncreasing",
       [](const fs::path& dir) {
         SetCsvValue(dir / "frames.csv", 4, "time_s", "0.5");
         return Problem{"frames.csv:4", "time_s 0.5 is not after the previous frame time 0.58 s "
                                        "(line 3); times must strictly increase"};
       }},
      {"LrfTimeNotIncreasing",
       [](const fs::path& dir) {
         SetCsvValue(dir / "lrf.csv", 10, "time_s", "0.3");
         return Problem{"lrf.csv:10", "time_s 0.3 is not after the previous LRF time 0.35 s "
                                      "(line 9); times must strictly increase"};
       }},
      {"NavQuaternionNotUnit",
       [](const fs::path& dir) {
         SetCsvValue(dir / "nav.csv", 30, "qw", "1");
         SetCsvValue(dir / "nav.csv", 30, "qx", "0.1");
         SetCsvValue(dir / "nav.csv", 30, "qy", "0");
         SetCsvValue(dir / "nav.csv", 30, "qz", "0");
         return Problem{"nav.csv:30", "quaternion (qw, qx, qy, qz) = (1, 0.1, 0, 0) has norm "
                                      "1.004987562112089; expected a unit quaternion "
                                      "(| |q| - 1 | <= 1e-6)"};
       }},
      {"NegativeSigma",
       [](const fs::path& dir) {
         SetCsvValue(dir / "nav.csv", 3, "sigma_z_m", "-1");
         return Problem{"nav.csv:3", "column 'sigma_z_m': value -1 is negative; expected a "
                                     "standard deviation >= 0"};
       }},
      {"FrameOutsideNavSpan",
       [](const fs::path& dir) {
         KeepLines(dir / "nav.csv", 1 + 121);  // samples 0 .. 2.4 s
         return Problem{"frames.csv:7", "time_s 2.5 is outside the navigation span [0, 2.4] s of "
                                        "nav.csv"};
       }},
      {"FrameOutsideLrfSpan",
       [](const fs::path& dir) {
         KeepLines(dir / "lrf.csv", 1 + 49);  // samples 0 .. 2.4 s
         return Problem{"frames.csv:7",
                        "time_s 2.5 is outside the LRF span [0, 2.4] s of lrf.csv"};
       }},
      {"LrfOneRow",
       [](const fs::path& dir) {
         KeepLines(dir / "lrf.csv", 2);
         return Problem{"lrf.csv", "has 1 row after the header; expected at least 2 (frame times "
                                   "are interpolated between samples; none at all: no LRF, the range from "
                                   "the navigation)"};
       }},
      {"NegativeLrfRange",
       [](const fs::path& dir) {
         SetCsvValue(dir / "lrf.csv", 6, "range_m", "-5");
         return Problem{"lrf.csv:6", "column 'range_m': value -5 is not positive; expected a slant "
                                     "range > 0 m (leave out rows without a return)"};
       }},
      {"ZeroBoresight",
       [](const fs::path& dir) {
         ReplaceLine(dir / "lrf.csv", 8, "0.3,567,0,0,0");
         return Problem{"lrf.csv:8", "boresight (bx, by, bz) = (0, 0, 0) has zero norm; expected a "
                                     "unit vector in the body frame"};
       }},
      {"BoresightNotUnit",
       [](const fs::path& dir) {
         ReplaceLine(dir / "lrf.csv", 8, "0.3,567,1,1,0");
         return Problem{"lrf.csv:8", "boresight (bx, by, bz) = (1, 1, 0) has norm "
                                     "1.4142135623730951; expected a unit vector "
                                     "(| |b| - 1 | <= 1e-6)"};
       }},
      // -------------------------------------------------------------- frames
      {"FrameIndexSkipped",
       [](const fs::path& dir) {
         SetCsvValue(dir / "frames.csv", 5, "frame", "4");
         return Problem{"frames.csv:5", "frame 4 where 3 was expected; frames must be numbered 0, "
                                        "1, 2, ... in row order"};
       }},
      {"FrameIndexNotWhole",
       [](const fs::path& dir) {
         SetCsvValue(dir / "frames.csv", 4, "frame", "2.5");
         return Problem{"frames.csv:4", "column 'frame': '2.5' is not a whole number"};
       }},
      {"TooFewFrames",
       [](const fs::path& dir) {
         KeepLines(dir / "frames.csv", 2);
         EditManifest(dir, [](json& m) { m.erase("truth"); });
         return Problem{"frames.csv",
                        "has 1 row after the header; expected at least 2 (a run needs two views)"};
       }},
      {"DuplicateImage",
       [](const fs::path& dir) {
         SetCsvValue(dir / "frames.csv", 4, "image", "images/frame_000000.png");
         return Problem{"frames.csv:4",
                        "column 'image': 'images/frame_000000.png' is also the image of frame 0 "
                        "(line 2); each frame needs its own image file"};
       }},
      {"AbsoluteImagePath",
       [](const fs::path& dir) {
         SetCsvValue(dir / "frames.csv", 3, "image", "/tmp/frame.png");
         return Problem{"frames.csv:3", "column 'image': '/tmp/frame.png' is absolute; expected a "
                                        "path relative to the dataset folder"};
       }},
      {"ImageMissing",
       [](const fs::path& dir) {
         fs::remove(dir / "images/frame_000003.png");
         return Problem{"images/frame_000003.png",
                        "file not found (image of frame 3, frames.csv:5)"};
       }},
      {"ImageNotPng",
       [](const fs::path& dir) {
         WriteText(dir / "images/frame_000001.png", "\xff\xd8\xff\xe0 a JPEG, perhaps");
         return Problem{"images/frame_000001.png",
                        "is not a PNG file (no PNG signature); expected an 8-bit or 16-bit "
                        "greyscale PNG"};
       }},
      {"ImageEmpty",
       [](const fs::path& dir) {
         WriteText(dir / "images/frame_000001.png", "");
         return Problem{"images/frame_000001.png", "is empty (0 bytes); expected a PNG image"};
       }},
      {"ImageCorruptCrc",
       [](const fs::path& dir) {
         const fs::path path = dir / "images/frame_000002.png";
         std::string bytes = ReadText(path);
         bytes[kFirstIdatOffset + 8 + 20] ^= 0x5a;  // a byte of compressed data
         WriteText(path, bytes);
         return Problem{"images/frame_000002.png",
                        "is corrupt: CRC mismatch in chunk 'IDAT' at byte 33"};
       }},
      {"ImageTruncated",
       [](const fs::path& dir) {
         const fs::path path = dir / "images/frame_000004.png";
         const std::string bytes = ReadText(path);
         const std::uint32_t idat_length = BigEndian32(bytes, kFirstIdatOffset);
         WriteText(path, bytes.substr(0, 100));
         return Problem{"images/frame_000004.png",
                        "is truncated: chunk 'IDAT' at byte 33 needs " +
                            std::to_string(idat_length + 12) +
                            " bytes but the file ends after 67 (file size 100 bytes)"};
       }},
      {"ImageTruncatedAtChunkEnd",
       [](const fs::path& dir) {
         const fs::path path = dir / "images/frame_000004.png";
         const std::string bytes = ReadText(path);
         const size_t without_iend = bytes.size() - 12;
         WriteText(path, bytes.substr(0, without_iend));
         return Problem{"images/frame_000004.png",
                        "is truncated: the file ends after " + std::to_string(without_iend) +
                            " bytes without the IEND chunk"};
       }},
      {"ImageTrailingBytes",
       [](const fs::path& dir) {
         const fs::path path = dir / "images/frame_000004.png";
         WriteText(path, ReadText(path) + "junk");
         return Problem{"images/frame_000004.png",
                        "has 4 bytes after the IEND chunk; expected the file to end there"};
       }},
      {"ImageBadDeflateWithValidCrc",
       [](const fs::path& dir) {
         // Damage the compressed data and fix the CRC: only the decoder can
         // tell, and libpng's complaint must not reach the terminal.
         const fs::path path = dir / "images/frame_000005.png";
         std::string bytes = ReadText(path);
         const std::uint32_t length = BigEndian32(bytes, kFirstIdatOffset);
         for (size_t i = 2; i < length; ++i) bytes[kFirstIdatOffset + 8 + i] = '\xff';
         const std::uint32_t crc = PngCrc(bytes, kFirstIdatOffset + 4, length + 4);
         for (size_t i = 0; i < 4; ++i) {
           bytes[kFirstIdatOffset + 8 + length + i] = static_cast<char>((crc >> (24 - 8 * i)) & 0xffU);
         }
         WriteText(path, bytes);
         return Problem{"images/frame_000005.png",
                        "cannot be decoded as a PNG (libpng error: IDAT: invalid block type)"};
       }},
      {"ImageRgb",
       [](const fs::path& dir) {
         hdabench::images::Write((dir / "images/frame_000002.png").string(),
                     cv::Mat(kImageSizePx, kImageSizePx, CV_8UC3, cv::Scalar(10, 20, 30)));
         return Problem{"images/frame_000002.png",
                        "is a 3-channel RGB PNG; expected a single-channel greyscale PNG (colour "
                        "type 0)"};
       }},
      {"ImageWrongSize",
       [](const fs::path& dir) {
         hdabench::images::Write((dir / "images/frame_000002.png").string(),
                     cv::Mat(32, 48, CV_8UC1, cv::Scalar(100)));
         return Problem{"images/frame_000002.png",
                        "is 48 x 32 px; the camera model (camera.cameramodel) has a 64 x 64 px "
                        "imager"};
       }},
      // --------------------------------------------------------------- truth
      {"TruthWrongDtype",
       [](const fs::path& dir) {
         ReplaceText(dir / "truth/points_000001.npy", "'<f4'", "'<f8'");
         return Problem{"truth/points_000001.npy",
                        "has dtype '<f8'; expected '<f4' (little-endian float32)"};
       }},
      {"TruthWrongShape",
       [](const fs::path& dir) {
         const std::vector<float> values(kImageSizePx * kImageSizePx, 0.0f);
         WriteText(dir / "truth/points_000001.npy",
                   EncodeNpyFloat32({kImageSizePx, kImageSizePx}, values.data(), values.size()));
         return Problem{"truth/points_000001.npy",
                        "has shape (64, 64); expected (64, 64, 3) (imager height, width, then x, "
                        "y, z in the local frame)"};
       }},
      {"TruthTruncated",
       [](const fs::path& dir) {
         const fs::path path = dir / "truth/points_000002.npy";
         const std::string bytes = ReadText(path);
         WriteText(path, bytes.substr(0, bytes.size() - 100));
         return Problem{"truth/points_000002.npy",
                        "holds 49052 bytes of data; shape (64, 64, 3) of float32 needs 49152 "
                        "(truncated file?)"};
       }},
      {"TruthInfinitePoint",
       [](const fs::path& dir) {
         const fs::path path = dir / "truth/points_000003.npy";
         NpyFloat32 array;
         std::string error;
         EXPECT_TRUE(ParseNpyFloat32(ReadText(path), &array, &error)) << error;
         float* point = &array.values[3 * (10 * kImageSizePx + 20)];
         point[0] = std::numeric_limits<float>::infinity();
         point[1] = 1.0f;
         point[2] = 2.0f;
         WriteText(path, EncodeNpyFloat32(array.shape, array.values.data(), array.values.size()));
         return Problem{"truth/points_000003.npy",
                        "has 1 point with an infinite or partly NaN coordinate, the first at row "
                        "10, column 20: (inf, 1, 2); expected finite points, or (nan, nan, nan) "
                        "where the ray hits nothing"};
       }},
      {"TruthFrameOutOfRange",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["truth"]["points_in_local"][0]["frame"] = 9; });
         return Problem{Manifest("truth.points_in_local[0].frame"),
                        "is 9; frames.csv has frames 0..5"};
       }},
      {"TruthFrameRepeated",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["truth"]["points_in_local"][3]["frame"] = 1; });
         return Problem{Manifest("truth.points_in_local[3].frame"),
                        "frame 1 already has truth points (truth.points_in_local[1])"};
       }},
      {"DemZeroSpacing",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["truth"]["dem"]["spacing_m"] = 0; });
         return Problem{Manifest("truth.dem.spacing_m"), "is 0; expected a cell size > 0 m"};
       }},
      {"ImagingSunNotUnit",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) {
           m["truth"]["imaging"] = {{"sun_in_local", {0.0, 0.0, 2.0}}, {"gain_electrons_per_dn", 40.0},
                                    {"read_noise_dn", 0.5}};
         });
         return Problem{Manifest("truth.imaging.sun_in_local"), "has norm 2; expected a unit vector"};
       }},
      {"ImagingNegativeReadNoise",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) {
           m["truth"]["imaging"] = {{"sun_in_local", {0.0, 0.6, 0.8}}, {"gain_electrons_per_dn", 40.0},
                                    {"read_noise_dn", -1.0}};
         });
         return Problem{Manifest("truth.imaging.read_noise_dn"), "is -1; expected 0 to 65535"};
       }},
      {"ImagingAbsurdReadNoise",  // finite, but imagery pair wrote null from it
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) {
           m["truth"]["imaging"] = {{"sun_in_local", {0.0, 0.6, 0.8}}, {"gain_electrons_per_dn", 40.0},
                                    {"read_noise_dn", 1e308}};
         });
         return Problem{Manifest("truth.imaging.read_noise_dn"), "is 1e+308; expected 0 to 65535"};
       }},
      {"DemNanHeight",
       [](const fs::path& dir) {
         const fs::path path = dir / "truth/dem.npy";
         NpyFloat32 array;
         std::string error;
         EXPECT_TRUE(ParseNpyFloat32(ReadText(path), &array, &error)) << error;
         array.values[static_cast<size_t>(3 * array.shape[1] + 4)] =
             std::numeric_limits<float>::quiet_NaN();
         WriteText(path, EncodeNpyFloat32(array.shape, array.values.data(), array.values.size()));
         return Problem{"truth/dem.npy", "has 1 non-finite height, the first at row 3, column 4 "
                                         "(nan); expected finite heights in metres"};
       }},
      {"DemTruncated",
       [](const fs::path& dir) {
         const fs::path path = dir / "truth/dem.npy";
         const std::string bytes = ReadText(path);
         NpyFloat32 array;
         std::string error;
         EXPECT_TRUE(ParseNpyFloat32Header(bytes, &array, &error)) << error;
         WriteText(path, bytes.substr(0, bytes.size() - 6));
         const std::int64_t needs = 4 * array.NumValues();
         return Problem{"truth/dem.npy", "holds " + std::to_string(needs - 6) + " bytes of data; shape " +
                                             FormatNpyShape(array.shape) + " of float32 needs " +
                                             std::to_string(needs) + " (truncated file?)"};
       }},
      {"DemMissing",
       [](const fs::path& dir) {
         fs::remove(dir / "truth/dem.npy");
         return Problem{"truth/dem.npy", "file not found (manifest.json field 'truth.dem.file')"};
       }},
      {"UnknownTruthKey",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["truth"]["rock"] = "truth/rocks.csv"; });
         return Problem{Manifest("truth.rock"),
                        "is not a field of format_version 1; expected in truth only "
                        "points_in_local, dem, navigation, rocks, imaging"};
       }},
      {"TruthNavigationMissing",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["truth"]["navigation"] = "truth/navigation.csv"; });
         return Problem{"truth/navigation.csv",
                        "file not found (manifest.json field 'truth.navigation')"};
       }},
      {"TruthNavigationPathNotAString",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["truth"]["navigation"] = 3; });
         return Problem{Manifest("truth.navigation"),
                        "is a number (3); expected a string: the path of the truth navigation "
                        "table, relative to the dataset folder"};
       }},
      {"TruthNavigationTimeNotIncreasing",
       [](const fs::path& dir) {
         AddTruthNavigation(dir);
         SetCsvValue(dir / "truth/navigation.csv", 20, "time_s", "0.34");  // line 19 holds 0.34
         return Problem{"truth/navigation.csv:20",
                        "time_s 0.34 is not after the previous truth navigation time 0.34 s "
                        "(line 19); times must strictly increase"};
       }},
      {"TruthNavigationQuaternionNotUnit",
       [](const fs::path& dir) {
         AddTruthNavigation(dir);
         const fs::path path = dir / "truth/navigation.csv";
         SetCsvValue(path, 30, "qw", "0");
         SetCsvValue(path, 30, "qx", "0");
         SetCsvValue(path, 30, "qy", "0");
         SetCsvValue(path, 30, "qz", "0.5");
         return Problem{"truth/navigation.csv:30",
                        "quaternion (qw, qx, qy, qz) = (0, 0, 0, 0.5) has norm 0.5; expected a "
                        "unit quaternion (| |q| - 1 | <= 1e-6)"};
       }},
      {"TruthNavigationPartialOptionalColumns",
       [](const fs::path& dir) {
         AddTruthNavigation(dir);
         EditCsvLines(dir / "truth/navigation.csv", [](size_t, std::vector<std::string>* fields) {
           fields->erase(fields->begin() + 10);  // vz_mps
         });
         return Problem{"truth/navigation.csv:1",
                        "optional columns vx_mps, vy_mps, vz_mps must all be present or all "
                        "absent; missing vz_mps"};
       }},
      {"FrameOutsideTruthNavigationSpan",
       [](const fs::path& dir) {
         AddTruthNavigation(dir);
         KeepLines(dir / "truth/navigation.csv", 1 + 121);  // samples 0 .. 2.4 s
         return Problem{"frames.csv:7", "time_s 2.5 is outside the truth navigation span [0, 2.4] "
                                        "s of truth/navigation.csv"};
       }},
      {"TruthRocksMissing",
       [](const fs::path& dir) {
         EditManifest(dir, [](json& m) { m["truth"]["rocks"] = "truth/rocks.csv"; });
         return Problem{"truth/rocks.csv", "file not found (manifest.json field 'truth.rocks')"};
       }},
      {"TruthRocksMissingColumn",
       [](const fs::path& dir) {
         AddTruthRocks(dir);
         EditCsvLines(dir / "truth/rocks.csv",
                      [](size_t, std::vector<std::string>* fields) { fields->pop_back(); });
         return Problem{"truth/rocks.csv:1",
                        "missing column 'height_above_ground_m'; expected columns x_m, y_m, z_m, "
                        "diameter_m, height_above_ground_m"};
       }},
      {"TruthRockNegativeDiameter",
       [](const fs::path& dir) {
         AddTruthRocks(dir);
         SetCsvValue(dir / "truth/rocks.csv", 3, "diameter_m", "-2");
         return Problem{"truth/rocks.csv:3", "column 'diameter_m': value -2 is not positive; "
                                             "expected a rock diameter > 0 m"};
       }},
      {"TruthRockZeroHeight",
       [](const fs::path& dir) {
         AddTruthRocks(dir);
         SetCsvValue(dir / "truth/rocks.csv", 2, "height_above_ground_m", "0");
         return Problem{"truth/rocks.csv:2",
                        "column 'height_above_ground_m': value 0 is not positive; expected a "
                        "height above the ground > 0 m"};
       }},
      {"TruthRockHigherThanItsDiameter",
       [](const fs::path& dir) {
         AddTruthRocks(dir);
         SetCsvValue(dir / "truth/rocks.csv", 4, "height_above_ground_m", "0.75");
         return Problem{"truth/rocks.csv:4",
                        "column 'height_above_ground_m': value 0.75 is larger than diameter_m "
                        "0.5; expected a height above the ground <= the rock's diameter"};
       }},
      {"TruthRockNanCentre",
       [](const fs::path& dir) {
         AddTruthRocks(dir);
         SetCsvValue(dir / "truth/rocks.csv", 2, "y_m", "nan");
         return Problem{"truth/rocks.csv:2",
                        "column 'y_m': value 'nan' is not finite; expected a finite number"};
       }},
  };
}

class LoadDatasetBadInput : public ::testing::TestWithParam<Defect> {};

TEST_P(LoadDatasetBadInput, ReportsExactlyTheExpectedProblem) {
  const std::uint64_t seed = CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  const fs::path root = FreshTestDir();
  const fs::path dir = WriteSmallExample(root / "dataset", seed);
  ASSERT_TRUE(LoadDataset(dir.string()).Ok()) << "the example must be valid before the defect";
  const Problem expected = GetParam().apply(dir);

  const DatasetLoadResult result = LoadDataset(dir.string());
  EXPECT_FALSE(result.dataset.has_value());
  ASSERT_EQ(result.problems.size(), 1U) << [&] {
    std::string all;
    for (const Problem& p : result.problems) all += "\n  " + p.ToString();
    return all;
  }();
  EXPECT_EQ(result.problems[0].where, expected.where);
  EXPECT_EQ(result.problems[0].message, expected.message);

  const testing_support::CommandResult run =
      testing_support::RunHdabench({"dataset", "check", dir.string()}, root);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.out, "");
  EXPECT_EQ(run.err, "1 problem(s) in " + dir.string() + ":\n" + expected.ToString() + "\n");
}

INSTANTIATE_TEST_SUITE_P(Catalogue, LoadDatasetBadInput, ::testing::ValuesIn(Catalogue()),
                         [](const ::testing::TestParamInfo<Defect>& param_info) {
                           return param_info.param.name;
                         });

TEST(LoadDataset, ReportsEveryProblemOfADatasetWithSeveralDefects) {
  const fs::path root = FreshTestDir();
  const fs::path dir = WriteSmallExample(root / "dataset", CurrentTestSeed());
  const std::vector<Defect> catalogue = Catalogue();
  // Defects in different files, none hiding another.
  const std::vector<std::string> names = {"ZeroGravity",      "NanInNavigation", "NegativeLrfRange",
                                          "DuplicateImage",   "ImageTruncated",  "TruthWrongDtype",
                                          "UnknownLensModel", "FrameIndexNotWhole"};
  std::vector<Problem> expected;
  for (const std::string& name : names) {
    for (const Defect& defect : catalogue) {
      if (defect.name == name) expected.push_back(defect.apply(dir));
    }
  }
  ASSERT_EQ(expected.size(), names.size());
  const DatasetLoadResult result = LoadDataset(dir.string());
  EXPECT_EQ(result.Summary(), std::to_string(names.size()) + " problems");
  EXPECT_EQ(result.problems.size(), expected.size());
  for (const Problem& problem : expected) {
    EXPECT_NE(std::find(result.problems.begin(), result.problems.end(), problem),
              result.problems.end())
        << "missing: " << problem.ToString();
  }
  const testing_support::CommandResult run =
      testing_support::RunHdabench({"dataset", "check", dir.string()}, root);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind(std::to_string(names.size()) + " problem(s) in " + dir.string() + ":\n", 0),
            0U);
  for (const Problem& problem : expected) {
    EXPECT_NE(run.err.find(problem.ToString() + "\n"), std::string::npos) << problem.ToString();
  }
}

// The base of the truth navigation and rocks defects is itself valid.
TEST(LoadDataset, AcceptsTheTruthNavigationAndRocksOfTheCatalogue) {
  const fs::path root = FreshTestDir();
  const fs::path dir = WriteSmallExample(root / "dataset", CurrentTestSeed());
  AddTruthNavigation(dir);
  AddTruthRocks(dir);
  const DatasetLoadResult result = LoadDataset(dir.string());
  ASSERT_TRUE(result.Ok()) << result.problems[0].ToString();
  EXPECT_EQ(result.dataset->truth.navigation_file, "truth/navigation.csv");
  EXPECT_EQ(result.dataset->truth.navigation.size(), result.dataset->nav.size());
  EXPECT_EQ(result.dataset->truth.rocks_file, "truth/rocks.csv");
  ASSERT_EQ(result.dataset->truth.rocks.size(), 3U);
  EXPECT_EQ(result.dataset->truth.rocks[1].center_in_local_m, Eigen::Vector3d(-40.0, 220.0, 0.9));
  EXPECT_EQ(result.dataset->truth.rocks[1].diameter_m, 2.0);
  EXPECT_EQ(result.dataset->truth.rocks[1].height_above_ground_m, 1.1);
  // A scene without rocks: a header-only table.
  AddTruthRocks(dir, "x_m,y_m,z_m,diameter_m,height_above_ground_m\n");
  const DatasetLoadResult no_rocks = LoadDataset(dir.string());
  ASSERT_TRUE(no_rocks.Ok()) << no_rocks.problems[0].ToString();
  EXPECT_EQ(no_rocks.dataset->truth.rocks_file, "truth/rocks.csv");
  EXPECT_TRUE(no_rocks.dataset->truth.rocks.empty());
  const testing_support::CommandResult run =
      testing_support::RunHdabench({"dataset", "check", dir.string()}, root);
  EXPECT_EQ(run.exit_code, 0) << run.err;
}

TEST(LoadDataset, MissingFolderIsAProblemNotACrash) {
  const fs::path root = FreshTestDir();
  const DatasetLoadResult result = LoadDataset((root / "nowhere").string());
  ASSERT_EQ(result.problems.size(), 1U);
  EXPECT_EQ(result.problems[0].where, (root / "nowhere").string());
  EXPECT_EQ(result.problems[0].message, "dataset folder not found");
}

// Random damage (byte flips, truncation, garbage) to every file of a dataset:
// the loader must answer with problems or a dataset, never crash or throw.
// Run under the sanitizer build too.
TEST(LoadDataset, SurvivesRandomDamageToAnyFile) {
  const std::uint64_t seed = CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  const fs::path root = FreshTestDir();
  const fs::path dir = WriteSmallExample(root / "dataset", seed);
  std::vector<fs::path> files;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  std::mt19937_64 rng(seed);
  int damaged = 0;
  for (int iteration = 0; iteration < 300; ++iteration) {
    const fs::path& path = files[rng() % files.size()];
    const std::string original = ReadText(path);
    std::string bytes = original;
    switch (rng() % 4) {
      case 0:  // flip bytes
        for (int k = 0; k < 4 && !bytes.empty(); ++k) {
          bytes[rng() % bytes.size()] ^= static_cast<char>(1 + rng() % 255);
        }
        break;
      case 1:  // truncate
        bytes.resize(bytes.empty() ? 0 : rng() % bytes.size());
        break;
      case 2:  // insert garbage
        bytes.insert(bytes.empty() ? 0 : rng() % bytes.size(), std::string(1 + rng() % 16, '\x80'));
        break;
      default:  // replace by random bytes
        for (char& c : bytes) c = static_cast<char>(rng() & 0xffU);
        break;
    }
    WriteText(path, bytes);
    DatasetLoadResult result;
    EXPECT_NO_THROW(result = LoadDataset(dir.string())) << path << " iteration " << iteration;
    if (!result.Ok()) ++damaged;
    for (const Problem& problem : result.problems) {
      EXPECT_FALSE(problem.where.empty());
      EXPECT_FALSE(problem.message.empty());
    }
    WriteText(path, original);
  }
  EXPECT_GT(damaged, 200);  // most damage is detected (a flipped digit may stay valid)
  EXPECT_TRUE(LoadDataset(dir.string()).Ok());
}

}  // namespace
}  // namespace hdabench::datasets
