// Large matrices whose memory the kernel may back with 2 MiB pages
// (transparent huge pages, asked for with madvise). Filling a fresh matrix
// costs a page fault per page first touched: 3072 of them for a 12 MiB truth
// raster on 4 KiB pages, 6 on 2 MiB ones. Where faults are dear (a virtual
// machine's, 10-15 microseconds each) that is most of the time taken to read
// such a raster from a file already in the page cache. The matrices are
// ordinary cv::Mat, continuous, freed when their last reference goes.
#pragma once

#include <opencv2/core/mat.hpp>

namespace hdabench::images {

// A continuous rows x cols matrix of `type`, values unset. One of at least
// 2 MiB is on memory of its own, aligned to 2 MiB, that the kernel is asked to
// back with huge pages; where the kernel declines (huge pages disabled or none
// free) it is on ordinary pages, and where memory cannot be mapped, on
// OpenCV's allocator. A smaller one is OpenCV's, as a huge page would be
// mostly unused. Throws what cv::Mat::create throws.
cv::Mat MatOnHugePages(int rows, int cols, int type);

}  // namespace hdabench::images
