// Uses the installed hdabench libraries: exits 0 when a model projects and
// unprojects consistently and the flight options validate.
#include <calib/camera_model.h>
#include <hda/hda_options.h>

#include <cstdio>

int main() {
  const hdabench::calib::CameraModel model("LENSMODEL_PINHOLE", {1000, 1000, 511.5, 511.5}, 1024, 1024);
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  model.Unproject({{100.0, 200.0}}, &bearings, &valid);
  std::vector<Eigen::Vector2d> pixels;
  model.Project(bearings, &pixels, &valid);
  const bool ok = valid[0] && (pixels[0] - Eigen::Vector2d(100.0, 200.0)).norm() < 1e-9 &&
                  hdabench::hda::HdaOptions().Validate().empty();
  std::printf("consumer: %s\n", ok ? "ok" : "FAILED");
  return ok ? 0 : 1;
}
