#include "tools/util/shared_library.h"

#include <dlfcn.h>

#include "tools/util/error.h"

namespace hdabench::util {

void* LoadSharedLibrary(const std::string& soname, const std::string& purpose) {
  void* library = dlopen(soname.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (library == nullptr) {
    const char* reason = dlerror();
    throw ExternalError(purpose + " cannot be loaded: " + (reason != nullptr ? reason : soname) +
                        " (its Debian package is in tools/debian-packages.txt)");
  }
  return library;
}

void* SharedLibrarySymbol(void* library, const std::string& soname, const std::string& symbol,
                          const std::string& what) {
  void* address = dlsym(library, symbol.c_str());
  if (address == nullptr) {
    throw ExternalError(soname + " has no " + what + " (symbol " + symbol +
                        "): it is not the version the bench was built with");
  }
  return address;
}

bool SharedLibraryLoaded(const std::string& soname) {
  void* library = dlopen(soname.c_str(), RTLD_NOW | RTLD_NOLOAD);
  if (library == nullptr) return false;
  dlclose(library);  // the reference RTLD_NOLOAD took
  return true;
}

}  // namespace hdabench::util
