#include "datasets/internal/pair_frames.h"

#include <string>

namespace hdabench::datasets::internal {

NavSample AddPairFrame(int i, const cv::Mat& image, const Rigid3d& local_from_cam, double range_m,
                       const Eigen::Vector3d& beam_in_cam, Dataset* dataset) {
  const double time_s = i * kPairFrameStepS;
  FrameRecord frame;
  frame.index = i;
  frame.time_s = time_s;
  frame.image_path = "images/frame_00000" + std::to_string(i) + ".png";
  frame.image = image;
  dataset->frames.push_back(frame);

  NavSample nav;
  nav.time_s = time_s;
  nav.local_from_body = local_from_cam;  // body = camera
  dataset->nav.push_back(nav);

  LrfSample lrf;
  lrf.time_s = time_s;
  lrf.range_m = range_m;
  lrf.boresight_in_body = beam_in_cam;
  dataset->lrf.push_back(lrf);
  return nav;
}

}  // namespace hdabench::datasets::internal
