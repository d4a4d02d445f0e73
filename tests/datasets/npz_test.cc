// .npz archives (datasets/npz.h): numpy's own files, stored and deflated,
// float32 and float64, a zip64 local header; damaged archives refused with
// the member named; the StereoLunar frames' cameras from their .npz.
#include "datasets/npz.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "datasets/stereolunar.h"
#include "tools/util/error.h"
#include "tests/support/test_support.h"

namespace hdabench::datasets {
namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::WriteText;

const fs::path kFixtures = fs::path(HDABENCH_SOURCE_DIR) / "tests" / "data" / "npz";
const fs::path kStereoLunar = fs::path(HDABENCH_SOURCE_DIR) / "tests" / "data" / "stereolunar-nadir";

using testing_support::InputErrorOf;

TEST(Npz, StoredFloat32AndDeflatedFloat64ReadTheSame) {
  for (const char* name : {"stored-f4.npz", "deflate-f8.npz"}) {
    SCOPED_TRACE(name);
    const std::map<std::string, NpyDoubles> arrays = ReadNpzArrays((kFixtures / name).string());
    ASSERT_EQ(arrays.size(), 2u);
    const NpyDoubles& k = arrays.at("intrinsics");
    EXPECT_EQ(k.shape, (std::vector<std::int64_t>{3, 3}));
    EXPECT_NEAR(k.values[0], 618.0387, 1e-4);  // float32 holds 618.0387 to 3e-5
    EXPECT_EQ(k.values[2], 256.0);
    EXPECT_EQ(k.values[8], 1.0);
    const NpyDoubles& m = arrays.at("cam2world");
    EXPECT_EQ(m.shape, (std::vector<std::int64_t>{4, 4}));
    EXPECT_EQ(m.values[3], 1.0e6);
    EXPECT_EQ(m.values[7], 2.0e5);
    EXPECT_EQ(m.values[11], -1.7e6);
  }
  const std::map<std::string, NpyDoubles> f8 = ReadNpzArrays((kFixtures / "deflate-f8.npz").string());
  EXPECT_EQ(f8.at("intrinsics").values[0], 618.0387);  // float64: exact
}

TEST(Npz, Zip64LocalHeader) {
  const std::map<std::string, NpyDoubles> arrays = ReadNpzArrays((kFixtures / "zip64-local.npz").string());
  ASSERT_EQ(arrays.count("intrinsics"), 1u);
  EXPECT_EQ(arrays.at("intrinsics").values, (std::vector<double>{500, 0, 100, 0, 500, 80, 0, 0, 1}));
}

TEST(Npz, DamagedArchivesNameTheProblem) {
  const std::string good = ReadText(kFixtures / "deflate-f8.npz");
  std::map<std::string, std::string> members;
  std::string error;
  ASSERT_TRUE(ParseZipMembers(good, &members, &error)) << error;
  // Every truncation fails cleanly, never reads past the end.
  for (size_t length = 0; length < good.size(); length += 7) {
    EXPECT_FALSE(ParseZipMembers(good.substr(0, length), &members, &error)) << length;
    EXPECT_FALSE(error.empty());
  }
  // A flipped byte in the first member's data: the CRC or deflate check.
  const auto u16 = [&](size_t at) {
    return static_cast<size_t>(static_cast<unsigned char>(good[at])) |
           (static_cast<size_t>(static_cast<unsigned char>(good[at + 1])) << 8);
  };
  std::string flipped = good;
  flipped[30 + u16(26) + u16(28) + 10] ^= 0x55;
  EXPECT_FALSE(ParseZipMembers(flipped, &members, &error));
  EXPECT_NE(error.find("member 'intrinsics.npy'"), std::string::npos) << error;
  // An unknown compression method (bzip2, 12) in the central directory.
  std::string method = good;
  const size_t central = method.find(std::string("PK\x01\x02", 4));
  ASSERT_NE(central, std::string::npos);
  method[central + 10] = 12;
  EXPECT_FALSE(ParseZipMembers(method, &members, &error));
  EXPECT_NE(error.find("compression method 12"), std::string::npos) << error;
  // The members together within the budget: 200 + 256 bytes here.
  EXPECT_TRUE(ParseZipMembers(good, &members, &error, 456)) << error;
  EXPECT_FALSE(ParseZipMembers(good, &members, &error, 455));
  EXPECT_NE(error.find("at most 455 are read from an archive"), std::string::npos) << error;
  EXPECT_FALSE(ParseZipMembers("not a zip archive at all, just text", &members, &error));
  EXPECT_NE(error.find("not a zip archive"), std::string::npos) << error;

  const fs::path dir = FreshTestDir();
  WriteText(dir / "bad.npz", flipped);
  const std::string message = InputErrorOf([&] { ReadNpzArrays((dir / "bad.npz").string()); });
  EXPECT_NE(message.find((dir / "bad.npz").string() + ": member 'intrinsics.npy'"), std::string::npos)
      << message;
  EXPECT_NE(InputErrorOf([&] { ReadNpzArrays((dir / "none.npz").string()); }).find("cannot be read"),
            std::string::npos);
}

// The dataset's own .npz give the cameras cameras.txt gives (the text holds
// the same float32 values).
TEST(Npz, StereoLunarCamerasFromTheFramesArchives) {
  const std::vector<StereoLunarCamera> text = ReadStereoLunarCameras((kStereoLunar / "cameras.txt").string());
  for (const char* stem : {"im_00594", "im_00595"}) {
    SCOPED_TRACE(stem);
    const StereoLunarCamera npz = ReadStereoLunarNpzCamera(
        (kStereoLunar / "paire1" / (std::string(stem) + ".npz")).string(), std::string("paire1/") + stem);
    const StereoLunarCamera* line = nullptr;
    for (const StereoLunarCamera& c : text) {
      if (c.key == npz.key || c.key == stem) line = &c;
    }
    ASSERT_NE(line, nullptr);
    EXPECT_LT((npz.k - line->k).cwiseAbs().maxCoeff(), 1e-3);
    EXPECT_LT((npz.cam2world.topLeftCorner<3, 3>() - line->cam2world.topLeftCorner<3, 3>()).cwiseAbs().maxCoeff(),
              1e-6);
    // Moon-centred metres at float32: 0.125 m steps near 1.7e6 m.
    EXPECT_LT((npz.cam2world.col(3) - line->cam2world.col(3)).cwiseAbs().maxCoeff(), 0.2);
  }
  // A wrong shape is named.
  const std::string message =
      InputErrorOf([&] { ReadStereoLunarNpzCamera((kFixtures / "zip64-local.npz").string(), "x/im_1"); });
  EXPECT_NE(message.find("no array 'cam2world'"), std::string::npos) << message;
}

}  // namespace
}  // namespace hdabench::datasets
