// `hdabench imagery pair` and `hdabench imagery edge` as a user meets them:
// the files and figures they give, their verdicts and their errors.
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/test_support.h"
#include "tests/tools/small_dataset.h"

namespace {

namespace fs = std::filesystem;

using hdabench::testing_support::CommandResult;
using hdabench::testing_support::FreshTestDir;
using hdabench::testing_support::ReadText;
using hdabench::testing_support::SplitLines;

using hdabench::testing_support::RunInOwnFolder;
using hdabench::testing_support::SmallSyntheticDataset;

TEST(ImageryCommand, PairWritesItsTablesAndTheSameBytesTwice) {
  const fs::path dir = FreshTestDir();
  const CommandResult first =
      RunInOwnFolder({"imagery", "pair", SmallSyntheticDataset().string(), "--out", (dir / "a").string(), "--max-ratio", "100"});
  ASSERT_EQ(first.exit_code, 0) << first.out << first.err;
  EXPECT_NE(first.out.find("Photometric residual at true correspondences, frames 0,6"), std::string::npos)
      << first.out;
  EXPECT_NE(first.out.find("PASS"), std::string::npos) << first.out;
  const nlohmann::json summary = nlohmann::json::parse(ReadText(dir / "a" / "imagery.json"));
  EXPECT_GT(summary["rois_checked"].get<int>(), 5);
  // The sensor noise of the default camera (40 e-/DN, 0.5 DN read noise,
  // about 100 DN) over two images: about 2 DN.
  EXPECT_GT(summary["explained_mean_dn"].get<double>(), 1.0);
  EXPECT_LT(summary["explained_mean_dn"].get<double>(), 4.0);
  EXPECT_GT(summary["residual_mean_dn"].get<double>(), summary["explained_mean_dn"].get<double>() * 0.5);
  // The camera model's images let the flight method match to a few
  // hundredths of a pixel (0.03 px on the full-size scenes).
  EXPECT_LT(summary["match_robust_sigma_x_px"].get<double>(), 0.06);
  EXPECT_LT(summary["match_robust_sigma_y_px"].get<double>(), 0.06);
  EXPECT_GT(summary["matches_compared"].get<int>(), summary["matches"].get<int>() * 9 / 10);
  const std::vector<std::string> csv = SplitLines(ReadText(dir / "a" / "imagery.csv"));
  ASSERT_GE(csv.size(), 2u);
  EXPECT_EQ(csv[0].rfind("id,x,y,w,h,pixels,hidden,spread_dn,", 0), 0u) << csv[0];

  const CommandResult second =
      RunInOwnFolder({"imagery", "pair", SmallSyntheticDataset().string(), "--out", (dir / "b").string(), "--max-ratio", "100"});
  ASSERT_EQ(second.exit_code, 0) << second.err;
  EXPECT_EQ(ReadText(dir / "a" / "imagery.csv"), ReadText(dir / "b" / "imagery.csv"));
  EXPECT_EQ(ReadText(dir / "a" / "imagery.json"), ReadText(dir / "b" / "imagery.json"));

  // A limit below what is measured fails, with exit code 1.
  const CommandResult strict =
      RunInOwnFolder({"imagery", "pair", SmallSyntheticDataset().string(), "--out", (dir / "c").string(), "--max-ratio", "0.5"});
  EXPECT_EQ(strict.exit_code, 1) << strict.err;
  EXPECT_NE(strict.out.find("FAIL"), std::string::npos) << strict.out;
}

TEST(ImageryCommand, PairRefusesADatasetWithoutImagingTruth) {
  const fs::path dir = FreshTestDir();
  const CommandResult create = RunInOwnFolder({"dataset", "create", (dir / "example").string()});
  ASSERT_EQ(create.exit_code, 0) << create.err;
  const CommandResult r = RunInOwnFolder({"imagery", "pair", (dir / "example").string(), "--out", (dir / "out").string()});
  EXPECT_EQ(r.exit_code, 3) << r.out << r.err;
  EXPECT_NE(r.err.find("hdabench imagery pair: "), std::string::npos) << r.err;
}

TEST(ImageryCommand, EdgePassesForTheCameraModelAndFailsForPointSampling) {
  const CommandResult camera = RunInOwnFolder({"imagery", "edge"});
  EXPECT_EQ(camera.exit_code, 0) << camera.out << camera.err;
  EXPECT_NE(camera.out.find("PASS"), std::string::npos) << camera.out;
  const CommandResult blurred = RunInOwnFolder({"imagery", "edge", "--set", "render.defocus_sigma_px=1.2"});
  EXPECT_EQ(blurred.exit_code, 0) << blurred.out << blurred.err;
  const CommandResult point = RunInOwnFolder({"imagery", "edge", "--set", "render.anti_aliasing=quincunx"});
  EXPECT_EQ(point.exit_code, 1) << point.out << point.err;
  EXPECT_NE(point.out.find("FAIL"), std::string::npos) << point.out;
  // A profile wider than the check's window, or an imager that records
  // nothing, fails as not measurable (it printed nan and PASS).
  for (const char* set : {"render.defocus_sigma_px=5", "render.fill_factor=1e-300"}) {
    const CommandResult unmeasurable = RunInOwnFolder({"imagery", "edge", "--set", set});
    EXPECT_EQ(unmeasurable.exit_code, 1) << set << ": " << unmeasurable.out << unmeasurable.err;
    EXPECT_NE(unmeasurable.out.find("not measurable"), std::string::npos) << unmeasurable.out;
    EXPECT_EQ(unmeasurable.out.find("PASS"), std::string::npos) << unmeasurable.out;
  }
  const CommandResult other = RunInOwnFolder({"imagery", "edge", "--set", "sun_elevation_deg=3"});
  EXPECT_EQ(other.exit_code, 2) << other.err;
  EXPECT_NE(other.err.find("render.key=value"), std::string::npos) << other.err;
  const CommandResult bad = RunInOwnFolder({"imagery", "edge", "--set", "render.fill_factor=2"});
  EXPECT_EQ(bad.exit_code, 2) << bad.err;
  EXPECT_NE(bad.err.find("fill_factor: 2; expected in (0, 1]"), std::string::npos) << bad.err;
  // A limit the check can fail: finite and positive.
  for (const std::string limit : {"inf", "nan", "-1", "0"}) {
    const CommandResult edge = RunInOwnFolder({"imagery", "edge", "--max-error", limit});
    EXPECT_EQ(edge.exit_code, 2) << limit << ": " << edge.out << edge.err;
    EXPECT_NE(edge.err.find("--max-error"), std::string::npos) << edge.err;
    const CommandResult pair = RunInOwnFolder(
        {"imagery", "pair", SmallSyntheticDataset().string(), "--out", "limits", "--max-ratio", limit});
    EXPECT_EQ(pair.exit_code, 2) << limit << ": " << pair.out << pair.err;
    EXPECT_NE(pair.err.find("--max-ratio"), std::string::npos) << pair.err;
  }
}

}  // namespace
