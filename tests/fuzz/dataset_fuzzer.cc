// A dataset folder whose manifest, camera model, frames, navigation or LRF
// table is the fuzz input (its first byte picks which; the other files are
// the built-in example's): LoadDataset reports problems or loads it, never
// crashes. Images and truth values are checked as files only (their parsers
// have harnesses of their own).
#include <cstdint>
#include <string>

#include "datasets/dataset.h"
#include "datasets/example.h"
#include "tests/fuzz/fuzz_support.h"
#include "tools/util/error.h"

namespace {

hdabench::fuzz::DamagedFolder* folder = nullptr;

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  folder = hdabench::fuzz::NewDamagedFolder(
      "fuzz-dataset", {"manifest.json", "camera.cameramodel", "frames.csv", "nav.csv", "lrf.csv"});
  hdabench::datasets::ExampleDatasetOptions options;
  // Small, so that the parser runs often: 2 frames of 32 px, navigation and LRF at 5 Hz.
  options.image_size_px = 32;
  options.num_frames = 2;
  options.nav_rate_hz = 5.0;
  options.lrf_rate_hz = 5.0;
  hdabench::datasets::WriteDataset(hdabench::datasets::MakeExampleDataset(options),
                                   (folder->path() / "example").string());
  // The example's files at the top of the scratch folder.
  for (const auto& entry : std::filesystem::directory_iterator(folder->path() / "example")) {
    std::filesystem::rename(entry.path(), folder->path() / entry.path().filename());
  }
  std::filesystem::remove(folder->path() / "example");
  folder->Keep();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string replaced = folder->Replace(data, size);
  hdabench::datasets::LoadOptions load;
  load.decode_images = false;
  load.check_truth_values = false;
  try {
    const hdabench::datasets::DatasetLoadResult result = hdabench::datasets::LoadDataset(folder->path().string(), load);
    if (result.dataset.has_value() == !result.problems.empty()) __builtin_trap();
  } catch (const hdabench::InputError&) {
  }
  folder->Restore(replaced);
  return 0;
}
