#include "reference/colmap/colmap_model.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tools/util/error.h"
#include "tools/util/process.h"
#include "tests/support/test_support.h"

namespace hdabench::reference {

namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::ReplaceLine;
using testing_support::WriteText;

// A small model with every kind of record: two cameras, two images (one with
// a 2D point not in any track), two 3D points.
ColmapModel SmallModel() {
  ColmapModel model;
  model.cameras.push_back({1, "PINHOLE", 640, 480, {500.25, 501.5, 320.5, 240.5}});
  model.cameras.push_back({7,
                           "FULL_OPENCV",
                           1024,
                           1024,
                           {1900, 1901, 512, 512, -0.1, 0.01, 1e-4, -2e-4, 1.2e-7, 0, 0, 0}});
  ColmapImage a;
  a.id = 3;
  a.qvec = {0.5, 0.5, -0.5, 0.5};
  a.tvec = {1.0, -2.0, 0.125};
  a.camera_id = 1;
  a.name = "frame_000.png";
  a.points2D = {{Eigen::Vector2d(10.5, 20.25), 11},
                {Eigen::Vector2d(0.1, 0.2), -1},
                {Eigen::Vector2d(100.0 / 3.0, 7.0), 12}};
  ColmapImage b;
  b.id = 4;
  b.qvec = {1.0, 0.0, 0.0, 0.0};
  b.tvec = {-31.2, 0.0, 0.0};
  b.camera_id = 7;
  b.name = "frame_001.png";
  b.points2D = {{Eigen::Vector2d(11.5, 21.25), 11}, {Eigen::Vector2d(35.0, 8.0), 12}};
  model.images = {a, b};
  ColmapPoint3D p;
  p.id = 11;
  p.xyz = Eigen::Vector3d(1.0 / 3.0, -2.5, 565.75);
  p.rgb = {255, 0, 17};
  p.error = 0.3;
  p.track = {{3, 0}, {4, 0}};
  ColmapPoint3D q;
  q.id = 12;
  q.xyz = Eigen::Vector3d(-4.0, 8.0, 570.0);
  q.rgb = {1, 2, 3};
  q.error = 0.125;
  q.track = {{3, 2}, {4, 1}};
  model.points3D = {p, q};
  return model;
}

void ExpectSameModel(const ColmapModel& a, const ColmapModel& b) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (size_t i = 0; i < a.cameras.size(); ++i) {
    EXPECT_EQ(a.cameras[i].id, b.cameras[i].id);
    EXPECT_EQ(a.cameras[i].model, b.cameras[i].model);
    EXPECT_EQ(a.cameras[i].width, b.cameras[i].width);
    EXPECT_EQ(a.cameras[i].height, b.cameras[i].height);
    EXPECT_EQ(a.cameras[i].params, b.cameras[i].params);  // bit-identical
  }
  ASSERT_EQ(a.images.size(), b.images.size());
  for (size_t i = 0; i < a.images.size(); ++i) {
    EXPECT_EQ(a.images[i].id, b.images[i].id);
    EXPECT_EQ(a.images[i].qvec, b.images[i].qvec);
    EXPECT_EQ(a.images[i].tvec, b.images[i].tvec);
    EXPECT_EQ(a.images[i].camera_id, b.images[i].camera_id);
    EXPECT_EQ(a.images[i].name, b.images[i].name);
    ASSERT_EQ(a.images[i].points2D.size(), b.images[i].points2D.size());
    for (size_t k = 0; k < a.images[i].points2D.size(); ++k) {
      EXPECT_EQ(a.images[i].points2D[k].xy, b.images[i].points2D[k].xy);
      EXPECT_EQ(a.images[i].points2D[k].point3D_id, b.images[i].points2D[k].point3D_id);
    }
  }
  ASSERT_EQ(a.points3D.size(), b.points3D.size());
  for (size_t i = 0; i < a.points3D.size(); ++i) {
    EXPECT_EQ(a.points3D[i].id, b.points3D[i].id);
    EXPECT_EQ(a.points3D[i].xyz, b.points3D[i].xyz);
    EXPECT_EQ(a.points3D[i].rgb, b.points3D[i].rgb);
    EXPECT_EQ(a.points3D[i].error, b.points3D[i].error);
    ASSERT_EQ(a.points3D[i].track.size(), b.points3D[i].track.size());
    for (size_t k = 0; k < a.points3D[i].track.size(); ++k) {
      EXPECT_EQ(a.points3D[i].track[k].image_id, b.points3D[i].track[k].image_id);
      EXPECT_EQ(a.points3D[i].track[k].point2D_idx, b.points3D[i].track[k].point2D_idx);
    }
  }
}

// Little-endian binary writer following the layout in colmap_model.h.
class Bytes {
 public:
  template <typename T>
  Bytes& Put(T value) {
    char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    data_.append(raw, sizeof(T));
    return *this;
  }
  Bytes& Name(const std::string& name) {
    data_ += name;
    data_.push_back('\0');
    return *this;
  }
  const std::string& Data() const { return data_; }

 private:
  std::string data_;
};

void WriteBinaryModel(const ColmapModel& model, const fs::path& dir) {
  Bytes cameras;
  cameras.Put<std::uint64_t>(model.cameras.size());
  for (const ColmapCamera& c : model.cameras) {
    cameras.Put<std::uint32_t>(c.id).Put<std::int32_t>(ColmapCameraModelId(c.model));
    cameras.Put<std::uint64_t>(c.width).Put<std::uint64_t>(c.height);
    for (double p : c.params) cameras.Put<double>(p);
  }
  Bytes images;
  images.Put<std::uint64_t>(model.images.size());
  for (const ColmapImage& im : model.images) {
    images.Put<std::uint32_t>(im.id);
    for (double q : im.qvec) images.Put<double>(q);
    for (double t : im.tvec) images.Put<double>(t);
    images.Put<std::uint32_t>(im.camera_id).Name(im.name);
    images.Put<std::uint64_t>(im.points2D.size());
    for (const ColmapPoint2D& p : im.points2D) {
      images.Put<double>(p.xy.x()).Put<double>(p.xy.y());
      images.Put<std::uint64_t>(p.point3D_id < 0 ? ~std::uint64_t{0}
                                                 : static_cast<std::uint64_t>(p.point3D_id));
    }
  }
  Bytes points;
  points.Put<std::uint64_t>(model.points3D.size());
  for (const ColmapPoint3D& p : model.points3D) {
    points.Put<std::uint64_t>(p.id);
    for (int k = 0; k < 3; ++k) points.Put<double>(p.xyz[k]);
    for (std::uint8_t c : p.rgb) points.Put<std::uint8_t>(c);
    points.Put<double>(p.error).Put<std::uint64_t>(p.track.size());
    for (const ColmapTrackElement& e : p.track) {
      points.Put<std::uint32_t>(e.image_id).Put<std::uint32_t>(e.point2D_idx);
    }
  }
  WriteText(dir / "cameras.bin", cameras.Data());
  WriteText(dir / "images.bin", images.Data());
  WriteText(dir / "points3D.bin", points.Data());
}

// The message of the InputError `read` throws, or "" when it does not throw.
template <typename F>
std::string ErrorOf(F read) {
  try {
    read();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ColmapModel, TextRoundTripIsExact) {
  const fs::path dir = FreshTestDir();
  const ColmapModel model = SmallModel();
  WriteColmapTextModel(model, dir.string());
  EXPECT_EQ(DetectColmapModelFormat(dir.string()), ColmapModelFormat::kText);
  const ColmapModel back = ReadColmapModel(dir.string());
  ExpectSameModel(model, back);
  // COLMAP's header comments are there and skipped.
  EXPECT_EQ(ReadText(dir / "images.txt").rfind("# Image list", 0), 0u);
  ASSERT_NE(back.FindImageByName("frame_001.png"), nullptr);
  EXPECT_EQ(back.FindImageByName("frame_001.png")->id, 4u);
  EXPECT_EQ(back.FindCamera(7)->model, "FULL_OPENCV");
  EXPECT_EQ(back.FindImage(99), nullptr);
}

TEST(ColmapModel, TextImageWithoutPointsKeepsItsEmptyLine) {
  const fs::path dir = FreshTestDir();
  ColmapModel model = SmallModel();
  model.points3D.clear();
  for (ColmapImage& image : model.images) image.points2D.clear();
  WriteColmapTextModel(model, dir.string());
  const ColmapModel back = ReadColmapTextModel(dir.string());
  ExpectSameModel(model, back);
}

TEST(ColmapModel, HandWrittenBinaryModelReadsBack) {
  const fs::path dir = FreshTestDir();
  const ColmapModel model = SmallModel();
  WriteBinaryModel(model, dir);
  EXPECT_EQ(DetectColmapModelFormat(dir.string()), ColmapModelFormat::kBinary);
  ExpectSameModel(model, ReadColmapModel(dir.string()));
  // With both forms present, binary wins.
  WriteColmapTextModel(model, dir.string());
  EXPECT_EQ(DetectColmapModelFormat(dir.string()), ColmapModelFormat::kBinary);
}

TEST(ColmapModel, MalformedTextNamesFileAndLine) {
  const fs::path dir = FreshTestDir();
  WriteColmapTextModel(SmallModel(), dir.string());
  const std::string cameras = (dir / "cameras.txt").string();
  const std::string images = (dir / "images.txt").string();
  const std::string points = (dir / "points3D.txt").string();
  const auto read = [&] { ReadColmapTextModel(dir.string()); };

  // cameras.txt: 3 comment lines, then camera 1 on line 4.
  ReplaceLine(cameras, 4, "1 PINHOLE 640 480 500 501 320");
  EXPECT_EQ(ErrorOf(read), cameras + ":4: camera model PINHOLE takes 4 parameters, got 3");
  ReplaceLine(cameras, 4, "1 FISHEYE_X 640 480 500 501 320 240");
  EXPECT_EQ(ErrorOf(read), cameras + ":4: unknown camera model 'FISHEYE_X'");
  ReplaceLine(cameras, 4, "1 PINHOLE 640 480 500 abc 320 240");
  EXPECT_EQ(ErrorOf(read), cameras + ":4: PARAMS 'abc' is not a finite number");
  ReplaceLine(cameras, 4, "7 PINHOLE 640 480 500 501 320 240");
  EXPECT_EQ(ErrorOf(read), cameras + ":5: camera 7 appears twice");
  ReplaceLine(cameras, 4, "1 PINHOLE 640 480 500 501 320 240");

  // images.txt: 4 comment lines, image 3 on lines 5-6, image 4 on lines 7-8.
  ReplaceLine(images, 5, "3 0.5 0.5 -0.5 0.5 1 -2 0.125 1");
  EXPECT_NE(ErrorOf(read).find(
                images + ":5: expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, got 9 fields"),
            std::string::npos)
      << ErrorOf(read);
  ReplaceLine(images, 5, "3 0.5 0.5 -0.5 0.5 1 -2 0.125 1 frame_000.png");
  ReplaceLine(images, 6, "10.5 20.25 11 0.1 0.2");
  EXPECT_EQ(ErrorOf(read),
            images + ":6: image 3: POINTS2D holds 5 values, expected triples X Y POINT3D_ID");
  ReplaceLine(images, 6, "10.5 20.25 11 0.1 0.2 -2 33.3 7 12");
  EXPECT_EQ(ErrorOf(read),
            images + ":6: POINT3D_ID '-2' is not an integer in [-1, 9223372036854775807]");
  ReplaceLine(images, 6, "10.5 20.25 11 0.1 0.2 -1 33.3 7 99");
  EXPECT_EQ(ErrorOf(read),
            images + ": image 3, 2D point 2 refers to 3D point 99, which points3D.txt lacks");
  ReplaceLine(images, 6, "10.5 20.25 11 0.1 0.2 -1 33.3 7 12");
  ReplaceLine(images, 7, "4 1 0 0 0 -31.2 0 0 5 frame_001.png");
  EXPECT_EQ(ErrorOf(read), images + ": image 4 uses camera 5, which cameras.txt lacks");
  // Truncated: the last image lacks its POINTS2D line.
  {
    std::vector<std::string> lines = testing_support::SplitLines(ReadText(images));
    lines.pop_back();
    lines[6] = "4 1 0 0 0 -31.2 0 0 7 frame_001.png";
    WriteText(images, testing_support::JoinLines(lines));
  }
  EXPECT_EQ(ErrorOf(read), images + ":7: image 4: missing the POINTS2D line after it (file ends)");
  WriteColmapTextModel(SmallModel(), dir.string());

  // points3D.txt: 3 comment lines, point 11 on line 4.
  ReplaceLine(points, 4, "11 0.3 -2.5 565.75 255 0 17 0.3 3 0 4");
  EXPECT_NE(ErrorOf(read).find(points + ":4: expected POINT3D_ID X Y Z R G B ERROR TRACK[]"),
            std::string::npos)
      << ErrorOf(read);
  ReplaceLine(points, 4, "11 0.3 -2.5 565.75 256 0 17 0.3 3 0 4 0");
  EXPECT_EQ(ErrorOf(read), points + ":4: colour '256' is not an integer in [0, 255]");
  ReplaceLine(points, 4, "11 0.3 -2.5 nan 255 0 17 0.3 3 0 4 0");
  EXPECT_EQ(ErrorOf(read), points + ":4: coordinate 'nan' is not a finite number");
  ReplaceLine(points, 4, "11 0.3 -2.5 565.75 255 0 17 0.3 3 0 4 5");
  EXPECT_EQ(ErrorOf(read), points + ": point 11 refers to 2D point 5 of image 4, which has 2");
  ReplaceLine(points, 4, "11 0.3 -2.5 565.75 255 0 17 0.3 3 0 8 0");
  EXPECT_EQ(ErrorOf(read), points + ": point 11 is seen in image 8, which images.txt lacks");

  fs::remove(dir / "points3D.txt");
  EXPECT_EQ(ErrorOf(read), points + ": cannot open: No such file or directory");
  EXPECT_NE(ErrorOf([&] {
              ReadColmapModel(dir.string());
            }).find(dir.string() + ": no COLMAP model: expected cameras, images and points3D"),
            std::string::npos);
  EXPECT_EQ(ErrorOf([&] { ReadColmapModel((dir / "missing").string()); }),
            (dir / "missing").string() + ": COLMAP model folder does not exist");
}

TEST(ColmapModel, TruncatedOrGarbledBinaryNamesFileAndByteOffset) {
  const fs::path dir = FreshTestDir();
  WriteBinaryModel(SmallModel(), dir);
  const std::string cameras = (dir / "cameras.bin").string();
  const std::string images = (dir / "images.bin").string();
  const std::string points = (dir / "points3D.bin").string();
  const std::string good_cameras = ReadText(cameras);
  const std::string good_images = ReadText(images);
  const std::string good_points = ReadText(points);
  const auto read = [&] { ReadColmapBinaryModel(dir.string()); };

  // cameras.bin: count (8), camera 1: id (4) model (4) w (8) h (8) 4 params (32) = 56 bytes,
  // camera 7 starts at byte 64; its params at 64 + 24 = 88.
  WriteText(cameras, good_cameras.substr(0, 100));
  EXPECT_EQ(ErrorOf(read),
            cameras + ": byte 96: truncated: camera parameter needs 8 bytes, 4 left");
  std::string garbled = good_cameras;
  garbled[64 + 4] = 42;  // model id of camera 7
  WriteText(cameras, garbled);
  EXPECT_EQ(ErrorOf(read), cameras + ": byte 68: unknown camera model id 42");
  WriteText(cameras, good_cameras + "xyz");
  EXPECT_EQ(ErrorOf(read), cameras + ": byte " + std::to_string(good_cameras.size()) +
                               ": 3 unexpected bytes after the last record");
  garbled = good_cameras;
  garbled[0] = 100;  // 100 cameras cannot fit
  WriteText(cameras, garbled);
  EXPECT_EQ(ErrorOf(read), cameras +
                               ": byte 0: truncated or garbled: number of cameras 100 "
                               "needs at least 24 bytes each, " +
                               std::to_string(good_cameras.size() - 8) + " left");
  WriteText(cameras, good_cameras);

  // images.bin: image 3 starts at byte 8: id (4), qvec (32), tvec (24), camera (4),
  // name "frame_000.png\0" (14) -> number of 2D points at byte 86.
  WriteText(images, good_images.substr(0, 80));
  EXPECT_EQ(ErrorOf(read), images +
                               ": byte 0: truncated or garbled: number of images 2 needs "
                               "at least 73 bytes each, 72 left");
  // One image declared, its name running to the end of the file.
  WriteText(images, std::string("\x01\0\0\0\0\0\0\0", 8) + good_images.substr(8, 72) +
                        std::string(80, 'x'));
  EXPECT_EQ(ErrorOf(read), images + ": byte 72: truncated: image name without its terminating NUL");
  garbled = good_images;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::memcpy(&garbled[8 + 4 + 8], &nan, sizeof(nan));  // qx of image 3
  WriteText(images, garbled);
  EXPECT_EQ(ErrorOf(read), images + ": byte 20: quaternion is not finite");
  WriteText(images, good_images.substr(0, good_images.size() - 1));
  EXPECT_EQ(ErrorOf(read), images +
                               ": byte 244: truncated or garbled: number of 2D points 2 "
                               "needs at least 24 bytes each, 47 left");
  garbled = good_images;
  garbled.back() = static_cast<char>(0x80);  // point3D_id of the last 2D point beyond int64
  WriteText(images, garbled);
  EXPECT_EQ(ErrorOf(read), images + ": byte " + std::to_string(good_images.size() - 8) +
                               ": point3D_id " + std::to_string(0x8000000000000000ULL + 12) +
                               " out of range");
  WriteText(images, good_images);

  // points3D.bin: point 11 at byte 8: id (8) xyz (24) rgb (3) error (8) track length at 51.
  garbled = good_points;
  garbled[51] = 3;  // track of 3 elements: eats into point 12 and runs out
  WriteText(points, garbled);
  EXPECT_NE(ErrorOf(read).find(points + ": byte "), std::string::npos) << ErrorOf(read);
  WriteText(points, good_points.substr(0, 30));
  EXPECT_EQ(ErrorOf(read), points +
                               ": byte 0: truncated or garbled: number of points 2 needs at "
                               "least 51 bytes each, 22 left");
  std::string one_point = good_points.substr(0, 8 + 51);  // point 11 without its track
  one_point[0] = 1;
  WriteText(points, one_point);
  EXPECT_EQ(ErrorOf(read), points +
                               ": byte 51: truncated or garbled: track length 2 needs at "
                               "least 8 bytes each, 0 left");
  WriteText(points, one_point.substr(0, 8 + 20));
  EXPECT_EQ(ErrorOf(read), points +
                               ": byte 0: truncated or garbled: number of points 1 needs at "
                               "least 51 bytes each, 20 left");
  WriteText(points, "");
  EXPECT_EQ(ErrorOf(read), points + ": byte 0: truncated: number of points needs 8 bytes, 0 left");
  WriteText(points, good_points);
  EXPECT_EQ(ErrorOf(read), "");
}

// Writes a text model, converts it to binary with the real colmap and reads
// that back: the reader follows the layout colmap writes.
TEST(ColmapModel, ReadsABinaryModelWrittenByColmap) {
  const std::string colmap = util::FindExecutable("colmap");
  if (colmap.empty()) GTEST_SKIP() << "colmap is not installed";
  const fs::path dir = FreshTestDir();
  fs::create_directories(dir / "text");
  fs::create_directories(dir / "bin");
  ColmapModel model = SmallModel();
  model.cameras[1].params[8] = 0.0;  // keep FULL_OPENCV's values simple for COLMAP's checks
  WriteColmapTextModel(model, (dir / "text").string());
  util::ProcessOptions options;
  options.log_file = (dir / "model_converter.log").string();
  options.timeout_s = 60.0;
  const util::ProcessResult run =
      util::RunProcess({colmap, "model_converter", "--input_path", (dir / "text").string(),
                  "--output_path", (dir / "bin").string(), "--output_type", "BIN"},
                 options);
  ASSERT_TRUE(run.Ok()) << run.error << "\n" << ReadText(dir / "model_converter.log");
  EXPECT_EQ(DetectColmapModelFormat((dir / "bin").string()), ColmapModelFormat::kBinary);
  const ColmapModel back = ReadColmapModel((dir / "bin").string());
  // COLMAP keeps its own order (ids); compare by id.
  ASSERT_EQ(back.cameras.size(), model.cameras.size());
  for (const ColmapCamera& c : model.cameras) {
    const ColmapCamera* b = back.FindCamera(c.id);
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(b->model, c.model);
    EXPECT_EQ(b->width, c.width);
    EXPECT_EQ(b->params, c.params);
  }
  ASSERT_EQ(back.images.size(), model.images.size());
  for (const ColmapImage& im : model.images) {
    const ColmapImage* b = back.FindImage(im.id);
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(b->name, im.name);
    EXPECT_EQ(b->camera_id, im.camera_id);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(b->qvec[k], im.qvec[k], 1e-15);
    EXPECT_EQ(b->tvec, im.tvec);
    ASSERT_EQ(b->points2D.size(), im.points2D.size());
    for (size_t k = 0; k < im.points2D.size(); ++k) {
      EXPECT_EQ(b->points2D[k].xy, im.points2D[k].xy);
      EXPECT_EQ(b->points2D[k].point3D_id, im.points2D[k].point3D_id);
    }
  }
  ASSERT_EQ(back.points3D.size(), model.points3D.size());
  for (const ColmapPoint3D& p : model.points3D) {
    const auto it = std::find_if(back.points3D.begin(), back.points3D.end(),
                                 [&](const ColmapPoint3D& b) { return b.id == p.id; });
    ASSERT_NE(it, back.points3D.end());
    EXPECT_EQ(it->xyz, p.xyz);
    EXPECT_EQ(it->rgb, p.rgb);
    EXPECT_EQ(it->track.size(), p.track.size());
  }
}

TEST(ColmapModel, WriterRefusesWhatTextCannotHold) {
  const fs::path dir = FreshTestDir();
  ColmapModel model = SmallModel();
  model.images[0].name = "two words.png";
  EXPECT_NE(ErrorOf([&] {
              WriteColmapTextModel(model, dir.string());
            }).find("name 'two words.png' is empty or contains whitespace"),
            std::string::npos);
  model = SmallModel();
  model.cameras[0].params.pop_back();
  EXPECT_NE(ErrorOf([&] {
              WriteColmapTextModel(model, dir.string());
            }).find("model 'PINHOLE' with 3 parameters cannot be written"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              WriteColmapTextModel(SmallModel(), (dir / "nope").string());
            }).find("not a folder"),
            std::string::npos);
  EXPECT_EQ(ColmapCameraParamCount("OPENCV"), 8);
  EXPECT_EQ(ColmapCameraModelId("FULL_OPENCV"), 6);
  EXPECT_EQ(ColmapCameraModelName(1), "PINHOLE");
  EXPECT_EQ(ColmapCameraModelName(11), "");
}

}  // namespace
}  // namespace hdabench::reference
