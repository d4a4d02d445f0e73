// A field log (docs/field-ingest.md) whose log.json, navigation, LRF or
// camera model file is the fuzz input (its first byte picks which; the others
// are the built-in example written as a field log): IngestFieldLog gives a
// dataset or an InputError, never a crash.
#include <cstdint>
#include <string>

#include "datasets/example.h"
#include "datasets/field_log.h"
#include "tests/fuzz/fuzz_support.h"
#include "tools/util/error.h"

namespace {

hdabench::fuzz::DamagedFolder* folder = nullptr;

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  folder =
      hdabench::fuzz::NewDamagedFolder("fuzz-field-log", {"log.json", "nav.csv", "lrf.csv", "camera.cameramodel"});
  hdabench::datasets::ExampleDatasetOptions options;
  // Small, so that the parser runs often: 2 frames of 32 px, navigation and LRF at 5 Hz.
  options.image_size_px = 32;
  options.num_frames = 2;
  options.nav_rate_hz = 5.0;
  options.lrf_rate_hz = 5.0;
  hdabench::datasets::Geodetic origin;
  origin.lat_deg = 32.38;
  origin.lon_deg = -106.48;
  origin.height_m = 1200.0;
  hdabench::datasets::WriteFieldLog(hdabench::datasets::MakeExampleDataset(options), folder->path().string(),
                                    origin, 0.03);
  folder->Keep();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string replaced = folder->Replace(data, size);
  try {
    hdabench::datasets::FieldIngestReport report;
    (void)hdabench::datasets::IngestFieldLog((folder->path() / "log.json").string(), &report);
  } catch (const hdabench::InputError&) {
  }
  folder->Restore(replaced);
  return 0;
}
