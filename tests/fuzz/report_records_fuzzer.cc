// The records `hdabench report` reads (reference/report/report.h), whose
// text is the fuzz input: a run folder's result.json or timings.json, or a
// compare folder's compare.json, compare_timings.json or flight/timings.json
// (its first byte picks which; the others stay the valid examples in
// tests/fuzz/report/). CheckReportFolder on both folders builds the page
// from them or throws an InputError naming the file and the place, never a
// crash.
#include <cstdint>
#include <filesystem>
#include <string>

#include "reference/report/report.h"
#include "tests/fuzz/fuzz_support.h"
#include "tools/util/error.h"

namespace {

namespace fs = std::filesystem;

hdabench::fuzz::DamagedFolder* folder = nullptr;

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  folder = hdabench::fuzz::NewDamagedFolder(
      "fuzz-report", {"run/result.json", "run/timings.json", "compare/compare.json", "compare/compare_timings.json",
                      "compare/flight/timings.json"});
  const fs::path examples = fs::path(HDABENCH_SOURCE_DIR) / "tests" / "fuzz" / "report";
  fs::create_directories(folder->path() / "run");
  fs::create_directories(folder->path() / "compare" / "flight");
  fs::copy_file(examples / "result.json", folder->path() / "run" / "result.json");
  fs::copy_file(examples / "timings.json", folder->path() / "run" / "timings.json");
  fs::copy_file(examples / "compare.json", folder->path() / "compare" / "compare.json");
  fs::copy_file(examples / "compare_timings.json", folder->path() / "compare" / "compare_timings.json");
  fs::copy_file(examples / "flight-timings.json", folder->path() / "compare" / "flight" / "timings.json");
  folder->Keep();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string replaced = folder->Replace(data, size);
  for (const char* kind : {"run", "compare"}) {
    try {
      (void)hdabench::reference::CheckReportFolder((folder->path() / kind).string());
    } catch (const hdabench::InputError&) {
    }
  }
  folder->Restore(replaced);
  return 0;
}
