#include "reference/colmap/sift_matching.h"

#include <algorithm>
#include <cmath>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "tools/util/error.h"
#include "tools/util/options_check.h"

namespace hdabench::reference {
namespace {

constexpr int kDims = 128;
// Columns (descriptors of image 2) taken at once: 64 x 256 bytes stay in the
// first-level cache while every row of image 1 passes over them.
constexpr int kTileColumns = 64;

// The descriptors as 16-bit integers, row after row: SSE2 multiplies and
// pairwise adds 16-bit lanes into 32-bit sums (pmaddwd). 255 * 255 * 2 and
// the whole dot product, at most 128 * 255^2 < 2^24, fit the 32-bit lanes.
std::vector<std::int16_t> ToInt16(const SiftDescriptors& d) {
  return std::vector<std::int16_t>(d.data.begin(), d.data.end());
}

int Dot(const std::int16_t* x, const std::int16_t* y) {
  int sum = 0;
  for (int k = 0; k < kDims; ++k) sum += x[k] * y[k];
  return sum;
}

#if defined(__SSE2__)
int HorizontalSum(__m128i v) {
  v = _mm_add_epi32(v, _mm_shuffle_epi32(v, 0x4E));
  v = _mm_add_epi32(v, _mm_shuffle_epi32(v, 0xB1));
  return _mm_cvtsi128_si32(v);
}
#endif

// The dot products of rows x0 and x1 with the 4 consecutive rows from y:
// out[r][c] = x_r . y_c.
void Dots2x4(const std::int16_t* x0, const std::int16_t* x1, const std::int16_t* y, int out[2][4]) {
#if defined(__SSE2__)
  const auto* a0 = reinterpret_cast<const __m128i*>(x0);
  const auto* a1 = reinterpret_cast<const __m128i*>(x1);
  const auto* b = reinterpret_cast<const __m128i*>(y);
  constexpr int kLanes = kDims / 8;  // 128-bit loads per row
  __m128i sum[2][4];
  for (auto& row : sum) {
    for (__m128i& v : row) v = _mm_setzero_si128();
  }
  for (int k = 0; k < kLanes; ++k) {
    const __m128i u0 = _mm_loadu_si128(a0 + k), u1 = _mm_loadu_si128(a1 + k);
    for (int c = 0; c < 4; ++c) {
      const __m128i v = _mm_loadu_si128(b + c * kLanes + k);
      sum[0][c] = _mm_add_epi32(sum[0][c], _mm_madd_epi16(u0, v));
      sum[1][c] = _mm_add_epi32(sum[1][c], _mm_madd_epi16(u1, v));
    }
  }
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 4; ++c) out[r][c] = HorizontalSum(sum[r][c]);
  }
#else
  for (int c = 0; c < 4; ++c) {
    out[0][c] = Dot(x0, y + c * kDims);
    out[1][c] = Dot(x1, y + c * kDims);
  }
#endif
}

void CheckDescriptors(const SiftDescriptors& d, const char* which) {
  if (d.rows < 0 || d.data.size() != static_cast<size_t>(std::max(d.rows, 0)) * kDims) {
    throw InputError(std::string("MatchSiftExact: descriptors of ") + which + ": " +
                     std::to_string(d.data.size()) + " bytes for " + std::to_string(d.rows) +
                     " rows: expected rows * 128");
  }
}

// The two largest dot products of one descriptor against the other image and
// the index of the largest (lowest index among equals); -1: no positive one.
struct BestTwo {
  int best = 0;
  int second = 0;
  int index = -1;

  void Add(int dot, int j) {
    if (dot > best) {
      second = best;
      best = dot;
      index = j;
    } else {
      if (dot > second) second = dot;
      // Visited in increasing j this never fires; it makes the lowest index
      // the rule rather than a consequence of the visiting order.
      if (dot == best && dot > 0 && j < index) index = j;
    }
  }
};

// COLMAP's angle of a dot product of two descriptors of length 512, float.
float Angle(int dot) {
  constexpr float kNorm = 1.0f / (512.0f * 512.0f);
  return std::acos(std::min(kNorm * static_cast<float>(dot), 1.0f));
}

// The match of one descriptor under the distance and ratio tests, or -1.
int Accept(const BestTwo& b, float max_ratio, float max_distance) {
  if (b.index < 0) return -1;
  const float best = Angle(b.best);
  if (best > max_distance) return -1;
  // >=: a second best equal to the best is rejected.
  if (best >= max_ratio * Angle(b.second)) return -1;
  return b.index;
}

}  // namespace

std::vector<std::string> SiftMatchOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(max_ratio > 0 && max_ratio <= 1, "max_ratio", max_ratio, "in (0, 1]", &errors);
  RequireOption(max_distance > 0, "max_distance", max_distance, "> 0", &errors);
  RequireOption(max_num_matches >= 1, "max_num_matches", max_num_matches, ">= 1", &errors);
  return errors;
}

std::vector<SiftMatch> MatchSiftExact(const SiftDescriptors& image1, const SiftDescriptors& image2,
                                      const SiftMatchOptions& options) {
  ThrowIfInvalid("MatchSiftExact: invalid SiftMatchOptions: ", options.Validate());
  CheckDescriptors(image1, "image 1");
  CheckDescriptors(image2, "image 2");
  std::vector<SiftMatch> matches;
  const int n1 = image1.rows, n2 = image2.rows;
  if (n1 == 0 || n2 == 0) return matches;

  const std::vector<std::int16_t> d1 = ToInt16(image1), d2 = ToInt16(image2);
  const auto row1 = [&d1](int i) { return d1.data() + static_cast<size_t>(i) * kDims; };
  const auto row2 = [&d2](int j) { return d2.data() + static_cast<size_t>(j) * kDims; };
  std::vector<BestTwo> rows(static_cast<size_t>(n1)), cols(static_cast<size_t>(n2));
  const auto add = [&rows, &cols](int i, int j, int dot) {
    rows[static_cast<size_t>(i)].Add(dot, j);
    cols[static_cast<size_t>(j)].Add(dot, i);
  };
  // Every (i, j) once: tiles of columns, in each all rows, two rows by four
  // columns at a time, the remainders one by one.
  for (int j0 = 0; j0 < n2; j0 += kTileColumns) {
    const int j1 = std::min(n2, j0 + kTileColumns);
    int i = 0;
    for (; i + 2 <= n1; i += 2) {
      int j = j0;
      for (; j + 4 <= j1; j += 4) {
        int dots[2][4];
        Dots2x4(row1(i), row1(i + 1), row2(j), dots);
        for (int r = 0; r < 2; ++r) {
          for (int c = 0; c < 4; ++c) add(i + r, j + c, dots[r][c]);
        }
      }
      for (; j < j1; ++j) {
        add(i, j, Dot(row1(i), row2(j)));
        add(i + 1, j, Dot(row1(i + 1), row2(j)));
      }
    }
    for (; i < n1; ++i) {
      for (int j = j0; j < j1; ++j) add(i, j, Dot(row1(i), row2(j)));
    }
  }

  // COLMAP passes its options to the tests as float.
  const float max_ratio = static_cast<float>(options.max_ratio);
  const float max_distance = static_cast<float>(options.max_distance);
  for (int i = 0; i < n1 && static_cast<int>(matches.size()) < options.max_num_matches; ++i) {
    const int j = Accept(rows[static_cast<size_t>(i)], max_ratio, max_distance);
    if (j < 0) continue;
    if (options.cross_check && Accept(cols[static_cast<size_t>(j)], max_ratio, max_distance) != i) {
      continue;
    }
    matches.push_back({i, j});
  }
  return matches;
}

bool SiftDescriptorMayBeUnset(double x, double y, double scale, int width, int height) {
  // VLFeat's filter as COLMAP 3.8 sets it up.
  constexpr int kFirstOctave = -1, kLastOctave = 2, kLevels = 3;
  const double sigma0 = 1.6 * std::cbrt(2.0);
  int first = kFirstOctave, last = kLastOctave;
  if (scale > 0 && std::isfinite(scale)) {
    const double octaves = std::log2(scale / sigma0);
    first = std::max(first, static_cast<int>(std::ceil(octaves - 3.5 / kLevels)));
    last = std::min(last, static_cast<int>(std::floor(octaves + 1.5 / kLevels)));
    if (first > last) {
      first = kFirstOctave;
      last = kLastOctave;
    }
  }
  // VLFeat's pixel centres are integers: COLMAP adds 0.5.
  const double xv = x - 0.5, yv = y - 0.5;
  for (int o = first; o <= last; ++o) {
    const double step = std::ldexp(1.0, o);
    const int w = o < 0 ? width << -o : width >> o;
    const int h = o < 0 ? height << -o : height >> o;
    // Rounded as VLFeat does it (truncation of x + 0.5), and its bounds.
    const int xi = static_cast<int>(xv / step + 0.5);
    const int yi = static_cast<int>(yv / step + 0.5);
    if (xi < 0 || xi >= w || yi < 0 || yi >= h - 1) return true;
  }
  return false;
}

}  // namespace hdabench::reference
