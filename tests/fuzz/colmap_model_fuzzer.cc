// COLMAP models, text and binary, whose cameras, images or points3D file is
// the fuzz input (its first byte picks which; the others are a valid
// one-camera, one-image model): ReadColmapTextModel and ReadColmapBinaryModel
// give a model or an InputError, never a crash.
#include <cstdint>
#include <string>

#include "reference/colmap/colmap_model.h"
#include "tests/fuzz/fuzz_support.h"
#include "tools/util/error.h"

namespace {

hdabench::fuzz::DamagedFolder* folder = nullptr;

std::string Uint64(std::uint64_t value) { return std::string(reinterpret_cast<const char*>(&value), 8); }

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  folder = hdabench::fuzz::NewDamagedFolder(
      "fuzz-colmap", {"text/cameras.txt", "text/images.txt", "text/points3D.txt", "binary/cameras.bin",
                      "binary/images.bin", "binary/points3D.bin"});
  const std::filesystem::path& dir = folder->path();
  hdabench::util::WriteFileAtomically(dir / "text/cameras.txt", "# one camera\n1 PINHOLE 100 80 120 120 49.5 39.5\n");
  hdabench::util::WriteFileAtomically(dir / "text/images.txt",
                                      "1 1 0 0 0 0 0 0 1 frame_0.png\n10 20 -1 30.5 40.5 -1\n");
  hdabench::util::WriteFileAtomically(dir / "text/points3D.txt", "# none\n");
  // Binary: a count of 0 in each file (the text model above is the one with content).
  for (const char* name : {"binary/cameras.bin", "binary/images.bin", "binary/points3D.bin"}) {
    hdabench::util::WriteFileAtomically(dir / name, Uint64(0));
  }
  folder->Keep();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string replaced = folder->Replace(data, size);
  for (const char* kind : {"text", "binary"}) {
    try {
      const std::string dir = (folder->path() / kind).string();
      const hdabench::reference::ColmapModel model = std::string(kind) == "text"
                                                         ? hdabench::reference::ReadColmapTextModel(dir)
                                                         : hdabench::reference::ReadColmapBinaryModel(dir);
      (void)model;
    } catch (const hdabench::InputError&) {
    }
  }
  folder->Restore(replaced);
  return 0;
}
