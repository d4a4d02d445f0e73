// .cameramodel text through the bench's scan and libmrcal behind it
// (calib::CameraModel::Parse): a camera model or an InputError, never a crash.
// A model that parses is also used once: a pixel unprojected and projected.
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "datasets/dataset.h"
#include "datasets/example.h"
#include "tests/fuzz/fuzz_support.h"
#include "tools/util/error.h"

// With HDABENCH_FUZZ_SEEDS naming a folder: a seed there, the built-in example's camera model (the
// repository's own .cameramodel files are seeds too, tools/fuzz.sh).
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* seeds = std::getenv("HDABENCH_FUZZ_SEEDS");
  if (seeds == nullptr || *seeds == '\0') return 0;
  const hdabench::util::TempFolder folder("fuzz-cameramodel");
  hdabench::datasets::ExampleDatasetOptions options;
  options.image_size_px = 32;
  options.num_frames = 2;
  hdabench::datasets::WriteDataset(hdabench::datasets::MakeExampleDataset(options), (folder.path() / "d").string());
  std::filesystem::copy_file(folder.path() / "d" / "camera.cameramodel",
                             std::filesystem::path(seeds) / "example.cameramodel",
                             std::filesystem::copy_options::overwrite_existing);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const hdabench::calib::CameraModel model =
        hdabench::calib::CameraModel::Parse(hdabench::fuzz::Bytes(data, size), "fuzz input");
    const std::vector<Eigen::Vector2d> pixels = {Eigen::Vector2d(0.5 * model.WidthPx(), 0.5 * model.HeightPx())};
    std::vector<Eigen::Vector3d> rays;
    std::vector<unsigned char> valid;
    if (model.Unproject(pixels, &rays, &valid) == 1) {
      std::vector<Eigen::Vector2d> back;
      model.Project(rays, &back, &valid);
    }
  } catch (const hdabench::InputError&) {
  } catch (const hdabench::UnsupportedError&) {
  }
  return 0;
}
