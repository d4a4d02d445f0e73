// A two-frame dataset whose relative pose is known by construction, for the
// tests of the pose queries (Cam2FromCam1, TrueCam2FromCam1): draw the mount,
// cam1_from_local and cam2_from_cam1, then give the navigation at the two
// frame times the local_from_body that yields them,
// local_from_body(t_i) = inverse(cam_i_from_local) * cam_from_body.
#pragma once

#include <random>
#include <vector>

#include "calib/camera_model.h"
#include "calib/rigid3.h"
#include "datasets/dataset.h"
#include "tests/support/test_support.h"

namespace hdabench::testing_support {

struct ConstructedPair {
  Rigid3d cam_from_body;
  Rigid3d cam1_from_local;   // translations of about 600 m
  Rigid3d cam2_from_cam1;    // translations of about 40 m
  double t1_s = 1.25;        // frame 0
  double t2_s = 3.5;         // frame 1
  // The navigation samples at 0 s and 4 s around the frames: random poses.
  Rigid3d local_from_body_before;
  Rigid3d local_from_body_after;

  Rigid3d LocalFromBodyAtFrame1() const { return cam1_from_local.Inverse() * cam_from_body; }
  Rigid3d LocalFromBodyAtFrame2() const {
    return (cam2_from_cam1 * cam1_from_local).Inverse() * cam_from_body;
  }
  // 0 s, t1, t2, 4 s: the navigation that gives the constructed poses.
  std::vector<datasets::NavSample> Navigation() const {
    return {Sample(0.0, local_from_body_before), Sample(t1_s, LocalFromBodyAtFrame1()),
            Sample(t2_s, LocalFromBodyAtFrame2()), Sample(4.0, local_from_body_after)};
  }
  static datasets::NavSample Sample(double time_s, const Rigid3d& local_from_body) {
    datasets::NavSample sample;
    sample.time_s = time_s;
    sample.local_from_body = local_from_body;
    return sample;
  }
};

inline ConstructedPair DrawConstructedPair(std::mt19937_64* rng) {
  const auto pose = [&](double scale) {
    const Eigen::Vector3d translation = RandomVector(rng, scale);  // drawn first (tools/util/random_vectors.h)
    return Rigid3d(RandomRotation(rng), translation);
  };
  ConstructedPair pair;
  pair.cam_from_body = pose(1.0);
  pair.cam1_from_local = pose(600.0);
  pair.cam2_from_cam1 = pose(40.0);
  pair.local_from_body_before = pose(600.0);
  pair.local_from_body_after = pose(600.0);
  return pair;
}

// A dataset with a 256 x 256 pinhole camera, the pair's mount and its two
// frames (indices 0 and 1 at t1 and t2); no navigation yet.
inline datasets::Dataset TwoFrameDataset(const ConstructedPair& pair) {
  datasets::Dataset dataset(
      calib::CameraModel("LENSMODEL_PINHOLE", {500.0, 500.0, 127.5, 127.5}, 256, 256));
  dataset.cam_from_body = pair.cam_from_body;
  datasets::FrameRecord frame1;
  frame1.index = 0;
  frame1.time_s = pair.t1_s;
  datasets::FrameRecord frame2 = frame1;
  frame2.index = 1;
  frame2.time_s = pair.t2_s;
  dataset.frames = {frame1, frame2};
  return dataset;
}

}  // namespace hdabench::testing_support
