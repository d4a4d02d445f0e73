// The external method's output (docs/external-method.md) from arbitrary
// bytes: ParseExternalOutput gives one ROI per id, or an InputError naming
// the record, never a crash. Its seed (HDABENCH_FUZZ_SEEDS) is a valid output
// for the ids below, with every field.
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "reference/compare/compare.h"
#include "tests/fuzz/fuzz_support.h"
#include "tools/util/error.h"
#include "tools/util/files.h"

namespace {

const std::vector<int> kRoiIds = {1, 2, 3, 7};

constexpr char kValidOutput[] =
    R"({"format": "hdabench-external-output", "format_version": 1, "note": "a valid output",
 "rois": [{"id": 1, "status": "ok", "normal_in_local": [0.1, -0.05, 1], "roughness_rms_m": 0.02,
           "roughness_max_m": 0.05, "num_points": 3, "reason": "3 points",
           "points_in_local_m": [[0, 0, 0], [1, 0, 0.1], [0, 1, 0]]},
          {"id": 2, "status": "too few points", "reason": "2 points"},
          {"id": 7, "status": "degenerate"}]})";

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* seeds = std::getenv("HDABENCH_FUZZ_SEEDS");
  if (seeds != nullptr && *seeds != '\0') {
    hdabench::util::WriteFileAtomically(std::filesystem::path(seeds) / "valid-output.json", kValidOutput);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<hdabench::reference::MethodRoi> rois;
  std::string note;
  try {
    hdabench::reference::ParseExternalOutput(hdabench::fuzz::Bytes(data, size), "output.json", kRoiIds,
                                             Eigen::Vector3d(0.0, 0.0, -1.62), nullptr, &rois, &note);
  } catch (const hdabench::InputError&) {
  }
  return 0;
}
