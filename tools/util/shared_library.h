// Shared libraries loaded when a command first needs them rather than at the
// start of every process. Debian's libopencv_imgcodecs (and libmrgingham,
// which needs it) bring some 140 shared libraries that cost about 75 ms to
// load and bind, which every process linking them pays, whether it reads an
// image or not (tools/images/codecs.h).
#pragma once

#include <string>

namespace hdabench::util {

// Loads the library `soname` (a second call returns the same handle; a
// library is never unloaded). Throws ExternalError naming `purpose`, the
// library and the loader's reason when it cannot be loaded.
void* LoadSharedLibrary(const std::string& soname, const std::string& purpose);

// The address of the (mangled) `symbol` in `library`, loaded from `soname`.
// Throws ExternalError naming `what` and the library when it is missing.
void* SharedLibrarySymbol(void* library, const std::string& soname, const std::string& symbol,
                          const std::string& what);

// SharedLibrarySymbol as a function pointer of type Fn, which must match the
// declaration the symbol was mangled from. (POSIX guarantees that a function's
// address from dlsym converts to a function pointer.)
template <typename Fn>
Fn SharedLibraryFunction(void* library, const std::string& soname, const std::string& symbol,
                         const std::string& what) {
  return reinterpret_cast<Fn>(SharedLibrarySymbol(library, soname, symbol, what));
}

// Whether this process has loaded `soname`, by any means.
bool SharedLibraryLoaded(const std::string& soname);

}  // namespace hdabench::util
