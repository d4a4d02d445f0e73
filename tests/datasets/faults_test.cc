// Sensor faults applied in memory (datasets/faults.h): each changes what it
// says and nothing else (never the truth), by the amount it says; bad
// magnitudes are named; the noise is the same for a seed.
#include "datasets/faults.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "datasets/example.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tests/support/test_support.h"

namespace hdabench::datasets {
namespace {

using testing_support::InputErrorOf;

constexpr int kFrame1 = 0;
constexpr int kFrame2 = 5;

// The example dataset, made once; a copy shares its pixels, which a fault must not change.
const Dataset& Example() {
  static const Dataset* const example = new Dataset(MakeExampleDataset(1));
  return *example;
}

Dataset Faulted(FaultKind kind, double magnitude, std::uint64_t seed = 1) {
  Dataset dataset = Example();
  ApplyFault({kind, magnitude}, kFrame1, kFrame2, seed, &dataset);
  return dataset;
}

bool SameMat(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

// The truth and whatever the fault does not touch stay as they were.
void ExpectTruthUntouched(const Dataset& faulted, const Dataset& clean) {
  ASSERT_EQ(faulted.truth.points.size(), clean.truth.points.size());
  for (size_t i = 0; i < clean.truth.points.size(); ++i) {
    EXPECT_TRUE(SameMat(faulted.truth.points[i].points_in_local_m, clean.truth.points[i].points_in_local_m));
  }
  ASSERT_EQ(faulted.truth.navigation.size(), clean.truth.navigation.size());
  for (size_t i = 0; i < clean.truth.navigation.size(); ++i) {
    EXPECT_EQ(faulted.truth.navigation[i].local_from_body.translation,
              clean.truth.navigation[i].local_from_body.translation);
  }
}

// Angle of a rotation, degrees.
double AngleDeg(const Eigen::Quaterniond& q) {
  return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w())) * util::kRadToDeg;
}

TEST(ApplyFault, EveryFaultLeavesTheTruthAsItWas) {
  const Dataset clean = Example();
  for (const FaultInfo& info : FaultCatalogue()) {
    SCOPED_TRACE(info.name);
    if (info.kind == FaultKind::kFrameDropped) continue;  // its truth follows the frames (its own test)
    // The example's LRF log starts 0.1 s before image 1.
    const double magnitude = info.kind == FaultKind::kLrfStuck ? 0.05 : info.sweep.front();
    ExpectTruthUntouched(Faulted(info.kind, magnitude), clean);
  }
}

TEST(ApplyFault, LrfFaultsChangeTheRangesByWhatTheySay) {
  const Dataset clean = Example();
  EXPECT_TRUE(Faulted(FaultKind::kLrfAbsent, 1).lrf.empty());
  const Dataset scaled = Faulted(FaultKind::kLrfScale, 0.05);
  const Dataset offset = Faulted(FaultKind::kLrfOffset, -20);
  const Dataset rock = Faulted(FaultKind::kLrfRock, 2);
  ASSERT_EQ(scaled.lrf.size(), clean.lrf.size());
  for (size_t i = 0; i < clean.lrf.size(); ++i) {
    EXPECT_DOUBLE_EQ(scaled.lrf[i].range_m, clean.lrf[i].range_m * 1.05);
    EXPECT_DOUBLE_EQ(offset.lrf[i].range_m, clean.lrf[i].range_m - 20);
    // The example's beam is 45 deg off nadir: a 2 m rock shortens it by 2 / cos(45 deg), give or take
    // the wobble.
    EXPECT_NEAR(clean.lrf[i].range_m - rock.lrf[i].range_m, 2.0 * std::sqrt(2.0), 0.02);
  }
  // Stuck 0.05 s before image 1: every later sample repeats the range then; the earlier ones are as measured.
  const Dataset stuck = Faulted(FaultKind::kLrfStuck, 0.05);
  const double t1 = clean.frames[kFrame1].time_s;
  const double stuck_range = clean.LrfRangeAt(t1 - 0.05);
  for (size_t i = 0; i < clean.lrf.size(); ++i) {
    EXPECT_DOUBLE_EQ(stuck.lrf[i].range_m, clean.lrf[i].time_s >= t1 - 0.05 ? stuck_range : clean.lrf[i].range_m);
  }
  // Noise: the same seed the same ranges, another seed others, of about the sigma asked.
  const Dataset noisy = Faulted(FaultKind::kLrfNoise, 5, 7);
  const Dataset again = Faulted(FaultKind::kLrfNoise, 5, 7);
  const Dataset other = Faulted(FaultKind::kLrfNoise, 5, 8);
  double sum_squares = 0.0;
  int differ = 0;
  for (size_t i = 0; i < clean.lrf.size(); ++i) {
    EXPECT_EQ(noisy.lrf[i].range_m, again.lrf[i].range_m);
    differ += noisy.lrf[i].range_m != other.lrf[i].range_m;
    sum_squares += std::pow(noisy.lrf[i].range_m - clean.lrf[i].range_m, 2);
  }
  EXPECT_EQ(differ, static_cast<int>(clean.lrf.size()));
  const double rms = std::sqrt(sum_squares / static_cast<double>(clean.lrf.size()));
  EXPECT_GT(rms, 3.0);
  EXPECT_LT(rms, 7.0);
}

TEST(ApplyFault, NavigationFaultsMoveThePosesByWhatTheySay) {
  const Dataset clean = Example();
  const double dt = clean.frames[kFrame2].time_s - clean.frames[kFrame1].time_s;
  // A bias of every position: each camera moves 5 m, the relative pose does not.
  const Dataset biased = Faulted(FaultKind::kNavPositionBias, 5);
  EXPECT_NEAR((biased.CameraCenterInLocal(kFrame1) - clean.CameraCenterInLocal(kFrame1)).norm(), 5.0, 1e-9);
  EXPECT_NEAR(biased.BaselineM(kFrame1, kFrame2), clean.BaselineM(kFrame1, kFrame2), 1e-9);
  // A drift along the motion: the baseline grows by rate * time between the images.
  const Dataset drifting = Faulted(FaultKind::kNavDrift, 0.5);
  EXPECT_NEAR(drifting.BaselineM(kFrame1, kFrame2) - clean.BaselineM(kFrame1, kFrame2), 0.5 * dt, 0.01);
  // An attitude bias turns camera 1's gravity by the bias and leaves the relative rotation within a
  // small fraction of it.
  const Dataset tilted = Faulted(FaultKind::kAttitudeBias, 0.5);
  const Eigen::Vector3d down_clean = clean.CamFromLocal(kFrame1).rotation * Eigen::Vector3d(0, 0, -1);
  const Eigen::Vector3d down_tilted = tilted.CamFromLocal(kFrame1).rotation * Eigen::Vector3d(0, 0, -1);
  EXPECT_NEAR(std::acos(std::clamp(down_clean.dot(down_tilted), -1.0, 1.0)) * util::kRadToDeg, 0.5, 1e-6);
  const Eigen::Quaterniond relative_change = tilted.Cam2FromCam1(kFrame1, kFrame2).rotation *
                                             clean.Cam2FromCam1(kFrame1, kFrame2).rotation.conjugate();
  EXPECT_LT(AngleDeg(relative_change), 0.01);
  // A jump between the images changes the relative rotation by the jump.
  const Dataset jumped = Faulted(FaultKind::kAttitudeJump, 0.2);
  const Eigen::Quaterniond jump_change = jumped.Cam2FromCam1(kFrame1, kFrame2).rotation *
                                         clean.Cam2FromCam1(kFrame1, kFrame2).rotation.conjugate();
  EXPECT_NEAR(AngleDeg(jump_change), 0.2, 1e-6);
  // A clock offset moves every frame's time stamp.
  const Dataset late = Faulted(FaultKind::kClockOffset, 0.05);
  for (size_t i = 0; i < clean.frames.size(); ++i) {
    EXPECT_DOUBLE_EQ(late.frames[i].time_s, clean.frames[i].time_s + 0.05);
  }
}

TEST(ApplyFault, ImageFaultsChangeThePairsImagesOnly) {
  const Dataset clean = Example();
  const cv::Mat& image1 = clean.frames[kFrame1].image;
  const Dataset blurred = Faulted(FaultKind::kImageBlur, 2);
  EXPECT_FALSE(SameMat(blurred.frames[kFrame1].image, image1));
  EXPECT_NEAR(cv::mean(blurred.frames[kFrame1].image)[0], cv::mean(image1)[0], 1.0);
  EXPECT_TRUE(SameMat(blurred.frames[1].image, clean.frames[1].image));  // not of the pair
  // The example's pixels, shared by every copy, are not changed through it.
  EXPECT_TRUE(SameMat(clean.frames[kFrame1].image, MakeExampleDataset(1).frames[kFrame1].image));
  const Dataset saturated = Faulted(FaultKind::kImageSaturated, 4);
  const Dataset dark = Faulted(FaultKind::kImageDark, 4);
  for (int row = 0; row < image1.rows; row += 17) {
    for (int col = 0; col < image1.cols; col += 13) {
      const int v = image1.at<unsigned char>(row, col);
      EXPECT_EQ(saturated.frames[kFrame1].image.at<unsigned char>(row, col), std::min(255, 4 * v));
      EXPECT_EQ(dark.frames[kFrame1].image.at<unsigned char>(row, col), cv::saturate_cast<unsigned char>(v / 4.0));
    }
  }
  const Dataset repeated = Faulted(FaultKind::kFrameRepeated, 1);
  EXPECT_TRUE(SameMat(repeated.frames[kFrame2].image, image1));
}

TEST(ApplyFault, ADroppedImageTwoIsTakenByTheNextFrameWithItsTimeAndTruth) {
  const Dataset clean = Example();
  constexpr int kDropped = 3;  // image 2 of this pair; the example's last frame has none after it
  Dataset dropped = Example();
  ApplyFault({FaultKind::kFrameDropped, 1}, kFrame1, kDropped, 1, &dropped);
  ASSERT_EQ(dropped.frames.size(), clean.frames.size() - 1);
  for (size_t i = 0; i < dropped.frames.size(); ++i) {
    const size_t from = i < static_cast<size_t>(kDropped) ? i : i + 1;
    EXPECT_EQ(dropped.frames[i].index, static_cast<int>(i));
    EXPECT_EQ(dropped.frames[i].time_s, clean.frames[from].time_s);
    EXPECT_EQ(dropped.frames[i].image_path, clean.frames[from].image_path);
    EXPECT_TRUE(SameMat(dropped.frames[i].image, clean.frames[from].image));
  }
  // Each frame keeps its own truth points, under its new number; the dropped frame's are gone.
  size_t clean_count_without_dropped = 0;
  for (const TruthPoints& p : clean.truth.points) {
    if (p.frame == kDropped) continue;
    ++clean_count_without_dropped;
    const int now = p.frame < kDropped ? p.frame : p.frame - 1;
    bool found = false;
    for (const TruthPoints& q : dropped.truth.points) {
      if (q.frame != now) continue;
      found = true;
      EXPECT_EQ(q.file, p.file);
      EXPECT_TRUE(SameMat(q.points_in_local_m, p.points_in_local_m));
    }
    EXPECT_TRUE(found) << "frame " << p.frame;
  }
  EXPECT_EQ(dropped.truth.points.size(), clean_count_without_dropped);
  EXPECT_EQ(dropped.nav.size(), clean.nav.size());
  EXPECT_EQ(dropped.lrf.size(), clean.lrf.size());
  // Refused with no frame after image 2, or image 2 not after image 1; the dataset is left as it was.
  Dataset dataset = Example();
  const int last = static_cast<int>(dataset.frames.size()) - 1;
  EXPECT_EQ(InputErrorOf([&] { ApplyFault({FaultKind::kFrameDropped, 1}, kFrame1, last, 1, &dataset); }),
            "fault frame-dropped: frame " + std::to_string(last) +
                " is the last: no frame after it takes its place");
  EXPECT_EQ(InputErrorOf([&] { ApplyFault({FaultKind::kFrameDropped, 1}, kDropped, kFrame1, 1, &dataset); }),
            "fault frame-dropped: image 2 (frame 0) must come after image 1");
  EXPECT_EQ(dataset.frames.size(), clean.frames.size());
}

TEST(ApplyFault, MagnitudesOutsideTheirDomainAreNamed) {
  Dataset dataset = Example();
  EXPECT_EQ(InputErrorOf([&] { ApplyFault({FaultKind::kLrfScale, -1.0}, kFrame1, kFrame2, 1, &dataset); }),
            "fault lrf-scale=-1: expected a fraction > -1 (a range stays > 0) and at most 100");
  EXPECT_EQ(InputErrorOf([&] { ApplyFault({FaultKind::kImageDark, 0.5}, kFrame1, kFrame2, 1, &dataset); }),
            "fault image-dark=0.5: expected a factor > 1 and at most 1e6");
  // Finite but beyond what a sensor could be off by (nav-drift=1e308 failed
  // inside the flight method, naming an internal function).
  EXPECT_EQ(InputErrorOf([&] { ApplyFault({FaultKind::kNavDrift, 1e308}, kFrame1, kFrame2, 1, &dataset); }),
            "fault nav-drift=1e+308: expected at most 1e4 m/s either way");
  EXPECT_EQ(InputErrorOf([&] { ApplyFault({FaultKind::kAttitudeBias, -200.0}, kFrame1, kFrame2, 1, &dataset); }),
            "fault attitude-bias=-200: expected at most 180 degrees either way");
  EXPECT_EQ(InputErrorOf([&] { ApplyFault({FaultKind::kLrfOffset, 2e7}, kFrame1, kFrame2, 1, &dataset); }),
            "fault lrf-offset=2e+07: expected at most 1e7 metres either way");
  EXPECT_EQ(InputErrorOf([&] { ApplyFault({FaultKind::kImageBlur, std::nan("")}, kFrame1, kFrame2, 1, &dataset); }),
            "fault image-blur=nan: the magnitude is not finite");
  EXPECT_NE(InputErrorOf([&] { ApplyFault({FaultKind::kClockOffset, 100.0}, kFrame1, kFrame2, 1, &dataset); })
                .find("outside the navigation"),
            std::string::npos);
  // A refused fault leaves the dataset as it was.
  for (size_t i = 0; i < dataset.frames.size(); ++i) EXPECT_EQ(dataset.frames[i].time_s, Example().frames[i].time_s);
  EXPECT_NE(InputErrorOf([&] { ApplyFault({FaultKind::kLrfStuck, 100.0}, kFrame1, kFrame2, 1, &dataset); })
                .find("the LRF log does not reach back"),
            std::string::npos);
  EXPECT_NE(InputErrorOf([&] { ApplyFault({FaultKind::kLrfScale, 0.1}, kFrame1, 99, 1, &dataset); })
                .find("frame 99 is not in the dataset"),
            std::string::npos);
  Dataset without_images = Example();
  without_images.frames[kFrame2].image = cv::Mat();
  EXPECT_EQ(InputErrorOf([&] { ApplyFault({FaultKind::kImageBlur, 1.0}, kFrame1, kFrame2, 1, &without_images); }),
            "fault image-blur=1: the image of frame 5 is not loaded");
}

TEST(FaultCatalogue, NamesParseBackAndUnknownOnesListTheKnown) {
  for (const FaultInfo& info : FaultCatalogue()) {
    EXPECT_EQ(ParseFaultKind(info.name), info.kind);
    EXPECT_EQ(&InfoOf(info.kind), &info);
    EXPECT_FALSE(info.sweep.empty());
  }
  const std::string message = InputErrorOf([] { ParseFaultKind("lrf-gone"); });
  EXPECT_NE(message.find("unknown fault 'lrf-gone': expected one of lrf-absent, lrf-stuck"), std::string::npos);
  EXPECT_EQ(FaultLabel({FaultKind::kLrfAbsent, 1}), "lrf-absent");
  EXPECT_EQ(FaultLabel({FaultKind::kLrfScale, 0.05}), "lrf-scale=0.05");
}

TEST(ParseFaults, ANameGivesItsSweepAndMagnitudesGiveTheirCases) {
  const std::vector<Fault> sweep = ParseFaults("lrf-scale");
  ASSERT_EQ(sweep.size(), InfoOf(FaultKind::kLrfScale).sweep.size());
  for (size_t i = 0; i < sweep.size(); ++i) EXPECT_EQ(sweep[i].magnitude, InfoOf(FaultKind::kLrfScale).sweep[i]);
  const std::vector<Fault> given = ParseFaults("attitude-bias=0.1,-0.25");
  ASSERT_EQ(given.size(), 2u);
  EXPECT_EQ(given[0].kind, FaultKind::kAttitudeBias);
  EXPECT_EQ(given[0].magnitude, 0.1);
  EXPECT_EQ(given[1].magnitude, -0.25);
  ASSERT_EQ(ParseFaults("frame-dropped").size(), 1u);
  EXPECT_EQ(FaultLabel(ParseFaults("clock-offset=0.050").front()), "clock-offset=0.05");
  EXPECT_EQ(InputErrorOf([] { ParseFaults("lrf-absent=1"); }), "'lrf-absent=1': lrf-absent takes no magnitude");
  EXPECT_EQ(InputErrorOf([] { ParseFaults("lrf-scale=0.1,"); }), "'lrf-scale=0.1,': '' is not a finite number (fraction)");
  EXPECT_EQ(InputErrorOf([] { ParseFaults("lrf-scale=nan"); }), "'lrf-scale=nan': 'nan' is not a finite number (fraction)");
  EXPECT_NE(InputErrorOf([] { ParseFaults("lrf"); }).find("unknown fault 'lrf'"), std::string::npos);
  // One fault: a magnitude, or a fault without one; a sweep is refused.
  EXPECT_EQ(ParseOneFault("lrf-scale=0.05").magnitude, 0.05);
  EXPECT_EQ(ParseOneFault("frame-dropped").kind, FaultKind::kFrameDropped);
  EXPECT_EQ(InputErrorOf([] { ParseOneFault("lrf-scale"); }), "'lrf-scale' is a sweep of 8 magnitudes: give one, NAME=M");
  EXPECT_EQ(InputErrorOf([] { ParseOneFault("lrf-scale=0.1,0.2"); }),
            "'lrf-scale=0.1,0.2' is a sweep of 2 magnitudes: give one, NAME=M");
}

}  // namespace
}  // namespace hdabench::datasets
