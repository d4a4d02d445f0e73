#include "tools/util/shared_library.h"

#include <string>

#include <gtest/gtest.h>

#include "tools/util/error.h"

namespace hdabench {
namespace {

TEST(SharedLibrary, AMissingLibraryOrSymbolIsAnExternalErrorNamingIt) {
  try {
    util::LoadSharedLibrary("libhdabench-no-such-library.so.1", "the test's library");
    FAIL() << "loaded a library that does not exist";
  } catch (const ExternalError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("the test's library cannot be loaded"), std::string::npos) << what;
    EXPECT_NE(what.find("libhdabench-no-such-library.so.1"), std::string::npos) << what;
  }
  EXPECT_FALSE(util::SharedLibraryLoaded("libhdabench-no-such-library.so.1"));

  void* libz = util::LoadSharedLibrary("libz.so.1", "zlib");
  EXPECT_TRUE(util::SharedLibraryLoaded("libz.so.1"));
  EXPECT_NE(util::SharedLibrarySymbol(libz, "libz.so.1", "crc32", "crc32"), nullptr);
  try {
    util::SharedLibrarySymbol(libz, "libz.so.1", "no_such_function", "zlib's no_such_function");
    FAIL() << "found a symbol that does not exist";
  } catch (const ExternalError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("libz.so.1 has no zlib's no_such_function (symbol no_such_function)"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace hdabench
