#include "tools/images/huge_pages.h"

#include <sys/mman.h>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <new>

// Under AddressSanitizer the slack after a matrix, up to its whole 2 MiB, is
// poisoned while the matrix lives, so that a read or write past its end is
// reported as OpenCV's allocator's would be.
#if defined(__SANITIZE_ADDRESS__)
#define HDABENCH_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define HDABENCH_ADDRESS_SANITIZER 1
#endif
#endif
#ifdef HDABENCH_ADDRESS_SANITIZER
#include <sanitizer/asan_interface.h>
#endif

namespace hdabench::images {

namespace {

constexpr size_t kHugePageBytes = size_t{2} << 20;

size_t RoundUp(size_t bytes, size_t multiple) {
  return (bytes + multiple - 1) / multiple * multiple;
}

// Maps each matrix of at least 2 MiB on its own, 2 MiB aligned and a whole
// number of 2 MiB long (the kernel backs only whole aligned 2 MiB ranges with
// a huge page), and unmaps it when OpenCV frees it. A smaller matrix, or one
// on memory of the caller's, is OpenCV's own allocator's. The matrix keeps
// this allocator: a later create() of a new size (as an OpenCV function's
// output, say) comes here again. Stateless, so thread-safe.
class HugePageAllocator : public cv::MatAllocator {
 public:
  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data, size_t* step,
                         cv::AccessFlag flags, cv::UMatUsageFlags usage) const override {
    if (data != nullptr) {
      return cv::Mat::getStdAllocator()->allocate(dims, sizes, type, data, step, flags, usage);
    }
    // The steps of a continuous matrix, and its size. OpenCV's allocator
    // writes the steps again for a matrix handed to it below.
    size_t total = CV_ELEM_SIZE(type);
    for (int i = dims - 1; i >= 0; --i) {
      if (step != nullptr) step[i] = total;
      total *= static_cast<size_t>(sizes[i]);
    }
    // Under 2 MiB a huge page would be mostly unused; over SIZE_MAX - 4 MiB
    // the rounding below would wrap.
    if (total < kHugePageBytes || total > std::numeric_limits<size_t>::max() - 2 * kHugePageBytes) {
      return cv::Mat::getStdAllocator()->allocate(dims, sizes, type, data, step, flags, usage);
    }
    auto* u = new cv::UMatData(this);
    u->size = total;
    const size_t length = RoundUp(total, kHugePageBytes);
    // Map a huge page more than needed, then give back what lies outside the
    // aligned range.
    void* mapped = mmap(nullptr, length + kHugePageBytes, PROT_READ | PROT_WRITE,
                        MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mapped == MAP_FAILED) {
      delete u;
      throw std::bad_alloc();  // cv::Mat::create then uses OpenCV's allocator
    }
    const auto start = reinterpret_cast<std::uintptr_t>(mapped);
    const std::uintptr_t aligned = RoundUp(start, kHugePageBytes);
    if (aligned > start) munmap(mapped, aligned - start);
    const std::uintptr_t end = start + length + kHugePageBytes;
    if (end > aligned + length) {
      munmap(reinterpret_cast<void*>(aligned + length), end - aligned - length);
    }
    // Advice only: where the kernel has no huge pages to give, the memory is
    // ordinary pages and the values the same.
    madvise(reinterpret_cast<void*>(aligned), length, MADV_HUGEPAGE);
    u->data = u->origdata = reinterpret_cast<uchar*>(aligned);
#ifdef HDABENCH_ADDRESS_SANITIZER
    ASAN_POISON_MEMORY_REGION(u->data + total, length - total);
#endif
    return u;
  }

  bool allocate(cv::UMatData* u, cv::AccessFlag /*flags*/,
                cv::UMatUsageFlags /*usage*/) const override {
    return u != nullptr;
  }

  void deallocate(cv::UMatData* u) const override {
    if (u == nullptr) return;
    CV_Assert(u->urefcount == 0 && u->refcount == 0);
    if (u->origdata != nullptr) {
      const size_t length = RoundUp(u->size, kHugePageBytes);
#ifdef HDABENCH_ADDRESS_SANITIZER
      // Memory mapped here later must not find the slack poisoned.
      ASAN_UNPOISON_MEMORY_REGION(u->origdata, length);
#endif
      munmap(u->origdata, length);
    }
    delete u;
  }
};

}  // namespace

cv::Mat MatOnHugePages(int rows, int cols, int type) {
  // Never destroyed: a matrix may outlive any static object.
  static HugePageAllocator* const allocator = new HugePageAllocator();
  cv::Mat mat;
  mat.allocator = allocator;
  mat.create(rows, cols, type);
  return mat;
}

}  // namespace hdabench::images
