#include "tools/images/huge_pages.h"

#include <sys/mman.h>

#include <cstddef>
#include <cstdint>
#include <new>

namespace hdabench::images {

namespace {

constexpr size_t kHugePageBytes = size_t{2} << 20;

size_t RoundUp(size_t bytes, size_t multiple) {
  return (bytes + multiple - 1) / multiple * multiple;
}

// Maps each matrix on its own, 2 MiB aligned and a whole number of 2 MiB long
// (the kernel backs only whole aligned 2 MiB ranges with a huge page), and
// unmaps it when OpenCV frees it. Stateless, so thread-safe.
class HugePageAllocator : public cv::MatAllocator {
 public:
  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data, size_t* step,
                         cv::AccessFlag flags, cv::UMatUsageFlags usage) const override {
    if (data != nullptr) {  // memory of the caller's: OpenCV's own allocator keeps it
      return cv::Mat::getStdAllocator()->allocate(dims, sizes, type, data, step, flags, usage);
    }
    // The steps of a continuous matrix.
    size_t total = CV_ELEM_SIZE(type);
    for (int i = dims - 1; i >= 0; --i) {
      if (step != nullptr) step[i] = total;
      total *= static_cast<size_t>(sizes[i]);
    }
    auto* u = new cv::UMatData(this);
    u->size = total;
    const size_t length = RoundUp(total > 0 ? total : 1, kHugePageBytes);
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
    // ordinary pages and the matrix as good.
    madvise(reinterpret_cast<void*>(aligned), length, MADV_HUGEPAGE);
    u->data = u->origdata = reinterpret_cast<uchar*>(aligned);
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
      munmap(u->origdata, RoundUp(u->size > 0 ? u->size : 1, kHugePageBytes));
    }
    delete u;
  }
};

}  // namespace

cv::Mat MatOnHugePages(int rows, int cols, int type) {
  // Never destroyed: a matrix may outlive any static object.
  static HugePageAllocator* const allocator = new HugePageAllocator();
  cv::Mat mat;
  const double bytes = static_cast<double>(rows) * cols * CV_ELEM_SIZE(type);
  if (bytes >= static_cast<double>(kHugePageBytes)) mat.allocator = allocator;
  mat.create(rows, cols, type);
  return mat;
}

}  // namespace hdabench::images
