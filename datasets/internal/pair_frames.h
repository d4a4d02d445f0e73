// Frames of a two-image dataset made from outside data (StereoLunar, a planar
// target): frame i at time i seconds, image images/frame_00000i.png, body =
// camera.
#pragma once

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "calib/rigid3.h"
#include "datasets/dataset.h"

namespace hdabench::datasets::internal {

// Seconds between the frames of such a dataset (a convention: the data hold no times).
constexpr double kPairFrameStepS = 1.0;

// Adds frame i at i * kPairFrameStepS: its record (the image kept in memory
// for WriteDataset), its navigation sample (local_from_cam, body = camera)
// and its LRF sample (range along the unit `beam_in_cam` from the camera's
// centre). Returns the navigation sample.
NavSample AddPairFrame(int i, const cv::Mat& image, const Rigid3d& local_from_cam, double range_m,
                       const Eigen::Vector3d& beam_in_cam, Dataset* dataset);

}  // namespace hdabench::datasets::internal
