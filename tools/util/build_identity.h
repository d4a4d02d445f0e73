// The identity of the running build, for caches of results that a new build
// must redo (the gate's datasets and entries).
#pragma once

#include <string>

namespace hdabench::util {

// The GNU build ID of the running program ("gnu-build-id:" and its hex
// digits): the linker's hash of the executable's contents, so a rebuild that
// changes any code (the scene generator included) gives another, and an
// unchanged executable the same. Where the program carries none, the FNV-1a
// hash of the executable file ("file-fnv1a:..."); "unknown" when neither can
// be read. Computed once per process.
const std::string& BuildIdentity();

}  // namespace hdabench::util
