// Large rasters on huge pages: ordinary continuous matrices, on memory aligned
// to 2 MiB that the kernel was asked to back with huge pages, given back to
// the kernel when the last reference goes.
#include "tools/images/huge_pages.h"

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#if defined(__SANITIZE_ADDRESS__)
#define HDABENCH_TEST_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define HDABENCH_TEST_ADDRESS_SANITIZER 1
#endif
#endif
#ifdef HDABENCH_TEST_ADDRESS_SANITIZER
#include <sanitizer/asan_interface.h>
#endif

namespace hdabench::images {
namespace {

constexpr std::uintptr_t kHugePageBytes = std::uintptr_t{2} << 20;

// The mapping of /proc/self/smaps that holds the address `at`: its lines up
// to the next mapping, or "" when none holds it. (The kernel may have merged
// the matrix's mapping with a neighbour of the same flags.)
std::string MappingHolding(std::uintptr_t at) {
  std::ifstream smaps("/proc/self/smaps");
  std::string line;
  std::string mapping;
  bool inside = false;
  while (std::getline(smaps, line)) {
    // A mapping's first line starts "start-end perms ..."; its other lines
    // "Key: value".
    const std::string first = line.substr(0, line.find(' '));
    if (first.find(':') == std::string::npos) {
      if (inside) break;
      std::uintptr_t begin = 0;
      std::uintptr_t end = 0;
      char dash = 0;
      std::istringstream(first) >> std::hex >> begin >> dash >> end;
      inside = begin <= at && at < end;
    }
    if (inside) mapping += line + "\n";
  }
  return mapping;
}

// Whether every page of [start, start + bytes) is mapped (mincore fails with
// ENOMEM on a range with a page that is not). `pages` has a byte per page.
bool Mapped(std::uintptr_t start, std::uintptr_t bytes, std::vector<unsigned char>* pages) {
  return mincore(reinterpret_cast<void*>(start), bytes, pages->data()) == 0;
}

// The number of pages of [start, start + bytes) that are still mapped.
size_t PagesMapped(std::uintptr_t start, std::uintptr_t bytes) {
  const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  size_t mapped = 0;
  unsigned char residency = 0;
  for (std::uintptr_t at = start; at < start + bytes; at += page) {
    if (mincore(reinterpret_cast<void*>(at), page, &residency) == 0) ++mapped;
  }
  return mapped;
}

// Whether this kernel has transparent huge pages, so that madvise
// (MADV_HUGEPAGE) marks a mapping "hg" whatever its setting.
bool KernelHasTransparentHugePages() {
  return std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled").good();
}

TEST(MatOnHugePages, IsAContinuousMatrixOnAlignedAdvisedMemoryGivenBackWhenReleased) {
  // A truth raster's shape, and one whose size is not a whole number of pages
  // (2 MiB and 4 bytes).
  for (const auto& [rows, cols, type] :
       {std::tuple{1024, 1024, CV_32FC3}, std::tuple{3, 174763, CV_32FC1}}) {
    cv::Mat mat = MatOnHugePages(rows, cols, type);
    ASSERT_EQ(mat.rows, rows);
    ASSERT_EQ(mat.cols, cols);
    ASSERT_EQ(mat.type(), type);
    EXPECT_TRUE(mat.isContinuous());
    EXPECT_EQ(mat.step[0], static_cast<size_t>(cols) * mat.elemSize());
    const auto start = reinterpret_cast<std::uintptr_t>(mat.data);
    EXPECT_EQ(start % kHugePageBytes, 0U) << "data at " << std::hex << start;

    // Mapped a whole number of 2 MiB long, advised for huge pages ("hg").
    const std::uintptr_t bytes = static_cast<std::uintptr_t>(rows) * cols * mat.elemSize();
    const std::uintptr_t length = (bytes + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
    std::vector<unsigned char> pages(length / static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE)));
    EXPECT_TRUE(Mapped(start, length, &pages));
    const std::string mapping = MappingHolding(start);
    ASSERT_FALSE(mapping.empty()) << "no mapping holds the matrix's data";
    if (KernelHasTransparentHugePages()) {
      const size_t flags = mapping.find("VmFlags:");
      ASSERT_NE(flags, std::string::npos) << mapping;
      EXPECT_NE(mapping.find(" hg", flags), std::string::npos) << mapping;
    }

    // Written and read as any matrix; a copy shares it, a clone does not.
    cv::randu(mat, 0, 1000);
    const cv::Mat clone = mat.clone();
    cv::Mat shared = mat;
    mat.release();
    EXPECT_EQ(shared.data, reinterpret_cast<uchar*>(start));
    EXPECT_TRUE(Mapped(start, length, &pages)) << "unmapped while a copy still refers to it";
    EXPECT_EQ(cv::norm(shared, clone, cv::NORM_INF), 0.0);
    shared.release();
    EXPECT_EQ(PagesMapped(start, length), 0U) << "pages still mapped after the last reference went";
  }
}

TEST(MatOnHugePages, ReallocatesOnItsOwnAllocatorAndLeavesClonesAndSmallMatricesToOpenCVs) {
  cv::Mat mat = MatOnHugePages(1024, 1024, CV_16UC1);  // exactly a huge page
  const cv::MatAllocator* const own = mat.u->currAllocator;
  EXPECT_NE(own, cv::Mat::getStdAllocator());
  mat.create(2048, 2048, CV_16UC1);  // a new shape: new memory, from the same allocator
  EXPECT_EQ(mat.u->currAllocator, own);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(mat.data) % kHugePageBytes, 0U);
  const cv::Mat clone = mat.clone();
  EXPECT_EQ(clone.u->currAllocator, cv::Mat::getStdAllocator());
  // A byte under a huge page: OpenCV's; re-created at a huge page, its own.
  cv::Mat small = MatOnHugePages(1, (1 << 21) - 1, CV_8UC1);
  EXPECT_EQ(small.u->currAllocator, cv::Mat::getStdAllocator());
  EXPECT_TRUE(small.isContinuous());
  small.create(1, 1 << 21, CV_8UC1);
  EXPECT_EQ(small.u->currAllocator, own);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(small.data) % kHugePageBytes, 0U);
}

#ifdef HDABENCH_TEST_ADDRESS_SANITIZER
TEST(MatOnHugePages, UnderAddressSanitizerTheSlackAfterTheMatrixIsPoisonedWhileItLives) {
  cv::Mat mat = MatOnHugePages(3, 174763, CV_32FC1);  // 2 MiB and 4 bytes: 4 MiB mapped
  const uchar* end = mat.data + mat.total() * mat.elemSize();
  EXPECT_FALSE(__asan_address_is_poisoned(end - 1));
  EXPECT_TRUE(__asan_address_is_poisoned(end));
  EXPECT_TRUE(__asan_address_is_poisoned(mat.data + 2 * kHugePageBytes - 1));
}
#endif

}  // namespace
}  // namespace hdabench::images
