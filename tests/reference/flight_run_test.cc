// The flight method's inputs from a dataset (reference/flight/flight_run.h):
// the slant range at image 1 from the LRF, from the navigation when the LRF
// has none, and a clear error when neither exists.
#include "reference/flight/flight_run.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "datasets/example.h"
#include "tools/util/error.h"
#include "tests/support/test_support.h"

namespace hdabench::reference {
namespace {

using testing_support::InputErrorOf;

constexpr int kFrame1 = 0;
constexpr int kFrame2 = 5;

// The example: 400 m above the plane z = 0 through the ILS, looking 45 deg off nadir toward it, the
// LRF along the optical axis.
datasets::Dataset Example() { return datasets::MakeExampleDataset(1); }

TEST(MakeHdaInput, WithoutTheLrfTheRangeComesFromTheNavigationAlongTheOpticalAxis) {
  const datasets::Dataset with_lrf = Example();
  const hda::HdaInput lrf_input = MakeHdaInput(with_lrf, kFrame1, kFrame2);
  datasets::Dataset without_lrf = Example();
  without_lrf.lrf.clear();
  const hda::HdaInput nav_input = MakeHdaInput(without_lrf, kFrame1, kFrame2);
  EXPECT_EQ(nav_input.lrf_beam_in_cam1, Eigen::Vector3d::UnitZ());
  EXPECT_EQ(nav_input.lrf_origin_in_cam1_m, Eigen::Vector3d::Zero());
  // The ground is the level plane through the ILS: the two ranges agree but for the wobble and the
  // LRF's offset from the camera.
  EXPECT_NEAR(nav_input.lrf_range_m, lrf_input.lrf_range_m, 0.01 * lrf_input.lrf_range_m);
  // The pair and the truth are as with the LRF; the run says where its range came from.
  EXPECT_EQ(DefaultFramePair(without_lrf), DefaultFramePair(with_lrf));
  hda::HdaOptions options;
  options.compute_budget_s = 1e9;
  EXPECT_EQ(RunFlight(without_lrf, kFrame1, kFrame2, options).range_source, RangeSource::kNavigation);
  EXPECT_EQ(RunFlight(with_lrf, kFrame1, kFrame2, options).range_source, RangeSource::kLrf);
}

TEST(MakeHdaInput, WithoutTheLrfOrAGroundBelowTheAxisItIsAnInputErrorSayingWhy) {
  datasets::Dataset dataset = Example();
  dataset.lrf.clear();
  dataset.ils_in_local_m.z() = 1000.0;  // the ILS above the camera
  const std::string message = InputErrorOf([&] { MakeHdaInput(dataset, kFrame1, kFrame2); });
  EXPECT_NE(message.find("no LRF range at frame 0 (LRF has no samples), and camera 0's optical axis does not "
                         "meet the level ground through the ILS from above"),
            std::string::npos)
      << message;
  // A frame time outside the navigation is an InputError too, not an exception of another kind.
  datasets::Dataset late = Example();
  late.frames[kFrame2].time_s += 100.0;
  EXPECT_NE(InputErrorOf([&] { MakeHdaInput(late, kFrame1, kFrame2); }).find("no navigation for frames 0,5"),
            std::string::npos);
}

}  // namespace
}  // namespace hdabench::reference
