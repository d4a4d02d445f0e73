#include "datasets/map_preview.h"

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "datasets/dataset.h"
#include "datasets/synth/truth.h"
#include "tests/support/test_support.h"
#include "tools/images/codecs.h"
#include "tools/util/files.h"

namespace hdabench::datasets {
namespace {

namespace fs = std::filesystem;

std::string Encode(const cv::Mat& image) {
  std::vector<unsigned char> bytes;
  EXPECT_TRUE(hdabench::images::Encode(".png", image, &bytes));
  return std::string(bytes.begin(), bytes.end());
}

cv::Mat Textured(int rows, int cols) {
  cv::Mat image(rows, cols, CV_8UC3);
  cv::randu(image, 0, 256);
  for (int r = 0; r < rows; ++r) image.row(r) += cv::Scalar(r % 7, r % 11, r % 13);
  return image;
}

// A report makes the preview from the map's PNG bytes, synth from the image it
// encodes: the same bytes.
TEST(MapPreview, FromThePngBytesItIsThePreviewOfTheImage) {
  const cv::Mat map = Textured(1100, 1530);
  const std::string from_image = PreviewPng(map, kMapPreviewSidePx);
  ASSERT_FALSE(from_image.empty());
  EXPECT_EQ(PreviewPngOfBytes(Encode(map), kMapPreviewSidePx), from_image);
  int width = 0, height = 0;
  ASSERT_TRUE(PngSizeOf(from_image, &width, &height));
  EXPECT_EQ(cv::Size(width, height), PreviewSize(1530, 1100, kMapPreviewSidePx));
  EXPECT_EQ(cv::Size(width, height), cv::Size(1024, 736));
  ASSERT_TRUE(PngSizeOf(Encode(map), &width, &height));
  EXPECT_EQ(cv::Size(width, height), cv::Size(1530, 1100));
  // No preview of a map no larger than one, nor of what is not an image.
  EXPECT_TRUE(PreviewPng(Textured(600, 1024), kMapPreviewSidePx).empty());
  EXPECT_TRUE(PreviewPngOfBytes("not a png", kMapPreviewSidePx).empty());
  EXPECT_TRUE(PreviewPngOfBytes("", kMapPreviewSidePx).empty());
  EXPECT_FALSE(PngSizeOf("\x89PNG\r\n", &width, &height));
  EXPECT_TRUE(IsPng(from_image));
  EXPECT_FALSE(IsPng(std::string("\x89PNG\r\n\x1a\n")));  // the signature alone
  EXPECT_FALSE(IsPng("GIF89a and more"));
}

// WriteTruthMaps writes each map and, beside it, its preview.
TEST(MapPreview, TruthMapsAreWrittenWithTheirPreviews) {
  const fs::path dir = testing_support::FreshTestDir();
  Dataset dataset(calib::CameraModel("LENSMODEL_PINHOLE", {500.0, 500.0, 127.5, 127.5}, 256, 256));
  TruthDem dem;
  dem.spacing_m = 0.1;
  dem.height_in_local_m = cv::Mat(1050, 1300, CV_32FC1);
  for (int r = 0; r < dem.height_in_local_m.rows; ++r) {
    for (int c = 0; c < dem.height_in_local_m.cols; ++c) {
      dem.height_in_local_m.at<float>(r, c) = static_cast<float>(std::sin(r * 0.01) + 0.3 * std::cos(c * 0.03));
    }
  }
  dataset.truth.dem = dem;
  synth::WriteTruthMaps(dataset, (dir / "maps").string());
  for (const char* name : {"elevation.png", "slope.png", "hazards.png"}) {
    std::string map, preview, error;
    ASSERT_TRUE(util::ReadFileBytes(dir / "maps" / name, &map, &error)) << error;
    ASSERT_TRUE(util::ReadFileBytes(dir / "maps" / kMapPreviewFolder / name, &preview, &error)) << error;
    EXPECT_EQ(preview, PreviewPngOfBytes(map, kMapPreviewSidePx)) << name;
  }
}

}  // namespace
}  // namespace hdabench::datasets
