// .npy arrays (float32 whole and header only, float32 or float64 as doubles)
// and .npz (zip) archives from arbitrary bytes: each parser returns false with
// a reason or a well-formed array, never crashes.
#include <cstdint>
#include <map>
#include <string>

#include "datasets/npy.h"
#include "datasets/npz.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace hdabench::datasets;
  const std::string bytes = hdabench::fuzz::Bytes(data, size);
  std::string error;
  NpyFloat32 floats;
  ParseNpyFloat32(bytes, &floats, &error);
  NpyFloat32 header;
  ParseNpyFloat32Header(bytes, &header, &error);
  NpyDoubles doubles;
  ParseNpyAsDoubles(bytes, &doubles, &error);
  std::map<std::string, std::string> members;
  if (ParseZipMembers(bytes, &members, &error, std::size_t{1} << 20)) {
    for (const auto& member : members) ParseNpyAsDoubles(member.second, &doubles, &error);
  }
  return 0;
}
