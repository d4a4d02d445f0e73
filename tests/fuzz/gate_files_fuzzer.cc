// Gate suite and threshold files (reference/gate/gate.h) whose text is the
// fuzz input (its first byte picks which; the other is the repository's CI
// suite or thresholds): ReadGateSuite and ReadGateThresholds give their
// content or an InputError naming the field, never a crash.
#include <cstdint>
#include <string>

#include "reference/gate/gate.h"
#include "tests/fuzz/fuzz_support.h"
#include "tools/util/error.h"

namespace {

hdabench::fuzz::DamagedFolder* folder = nullptr;

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  folder = hdabench::fuzz::NewDamagedFolder("fuzz-gate", {"suite.json", "thresholds.json"});
  const std::filesystem::path gate = std::filesystem::path(HDABENCH_SOURCE_DIR) / "gate";
  std::filesystem::copy_file(gate / "suite-ci.json", folder->path() / "suite.json");
  std::filesystem::copy_file(gate / "thresholds-ci.json", folder->path() / "thresholds.json");
  folder->Keep();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string replaced = folder->Replace(data, size);
  try {
    (void)hdabench::reference::ReadGateSuite((folder->path() / "suite.json").string());
  } catch (const hdabench::InputError&) {
  }
  try {
    (void)hdabench::reference::ReadGateThresholds((folder->path() / "thresholds.json").string());
  } catch (const hdabench::InputError&) {
  }
  folder->Restore(replaced);
  return 0;
}
