// What the libFuzzer harnesses share: the input as bytes, and a scratch
// folder holding a valid example of the files a harness damages one at a
// time (the fuzz input replaces one of them; the others stay valid, so the
// parser gets past them to the file under test).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "tools/util/files.h"

namespace hdabench::fuzz {

inline std::string Bytes(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// A folder of valid files, each of which an input may replace: the input's
// first byte picks the file (modulo their number), the rest is its content.
// Replace() writes it; Restore() puts the valid file back.
class DamagedFolder {
 public:
  DamagedFolder(const std::string& purpose, const std::vector<std::string>& damageable)
      : folder_(purpose), damageable_(damageable) {}

  const std::filesystem::path& path() const { return folder_.path(); }

  // Remembers the valid contents of the damageable files (call once they are
  // written). With HDABENCH_FUZZ_SEEDS naming a folder, also writes there one
  // seed input per file (its index byte, then its valid content): the seed
  // corpus tools/fuzz.sh starts from.
  void Keep() {
    const char* seeds = std::getenv("HDABENCH_FUZZ_SEEDS");
    for (std::size_t i = 0; i < damageable_.size(); ++i) {
      const std::string& name = damageable_[i];
      std::string bytes, error;
      util::ReadFileBytes(folder_.path() / name, &bytes, &error);
      valid_[name] = bytes;
      if (seeds != nullptr && *seeds != '\0') {
        std::string seed(1, static_cast<char>(i));
        seed += bytes;
        std::string file = "valid-" + name;
        for (char& c : file) c = c == '/' ? '-' : c;
        util::WriteFileAtomically(std::filesystem::path(seeds) / file, seed);
      }
    }
  }

  // Writes the input into the file its first byte picks; returns that file's
  // name (empty for an empty input, when nothing is replaced).
  std::string Replace(const std::uint8_t* data, std::size_t size) {
    if (size == 0 || damageable_.empty()) return "";
    const std::string& name = damageable_[data[0] % damageable_.size()];
    Write(folder_.path() / name, Bytes(data + 1, size - 1));
    return name;
  }

  void Restore(const std::string& name) {
    if (!name.empty()) Write(folder_.path() / name, valid_[name]);
  }

 private:
  // A plain write: a scratch file needs no fsync, and the harness runs
  // thousands of times a second.
  static void Write(const std::filesystem::path& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }

  util::TempFolder folder_;
  std::vector<std::string> damageable_;
  std::map<std::string, std::string> valid_;
};

// The harness's DamagedFolder, made in LLVMFuzzerInitialize and removed
// when the process exits normally: libFuzzer ends a run of -runs or
// -max_total_time with exit(), which runs the handler registered here. After a
// crash the folder stays (the input that caused it is kept in the artifact).
// A second call replaces the first folder.
inline DamagedFolder* NewDamagedFolder(const std::string& purpose, const std::vector<std::string>& damageable) {
  static DamagedFolder* made = nullptr;
  static const bool removed_at_exit = std::atexit([] {
                                        delete made;
                                        made = nullptr;
                                      }) == 0;
  (void)removed_at_exit;
  delete made;
  made = new DamagedFolder(purpose, damageable);
  return made;
}

}  // namespace hdabench::fuzz
