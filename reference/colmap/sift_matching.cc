#include "reference/colmap/sift_matching.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define HDABENCH_SIFT_AVX2 1
#endif

#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/parallel_for.h"

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

  // The best two of both candidate sets, as if every candidate of `other`
  // had been added here.
  void Merge(const BestTwo& other) {
    if (other.best > best) {
      second = std::max(best, other.second);
      best = other.best;
      index = other.index;
    } else {
      second = std::max(second, other.best);
      if (other.best == best && other.best > 0 && other.index < index) index = other.index;
    }
  }
};

#if defined(HDABENCH_SIFT_AVX2)
// Every row of image 1 (d1, n1 rows) against the columns [j0, j1) of image 2
// (d2), j1 - j0 a multiple of 8 and at most kTileColumns, on a processor with
// AVX2 (chosen at run time: the build targets every x86-64): eight columns at
// a time in 256-bit lanes. The same integer dot products and the same
// results as BestTwo::Add in increasing i, then j: a column's best and second
// best are maxima and its index the first row to reach the best (the rows
// come in increasing order); a row is updated, in increasing j, only when one
// of the eight exceeds its second best, which is when Add would change it.
__attribute__((target("avx2"))) void TileAvx2(const std::int16_t* d1, int n1, const std::int16_t* d2, int j0,
                                              int j1, BestTwo* rows, BestTwo* cols) {
  alignas(32) int best[kTileColumns], second[kTileColumns], index[kTileColumns], dots[8];
  const int width = j1 - j0;
  for (int c = 0; c < width; ++c) {
    best[c] = cols[j0 + c].best;
    second[c] = cols[j0 + c].second;
    index[c] = cols[j0 + c].index;
  }
  constexpr int kLanes = kDims / 16;  // 256-bit loads per descriptor
  for (int i = 0; i < n1; ++i) {
    const auto* x = reinterpret_cast<const __m256i*>(d1 + static_cast<size_t>(i) * kDims);
    const __m256i row_index = _mm256_set1_epi32(i);
    BestTwo& row = rows[i];
    for (int c0 = 0; c0 < width; c0 += 8) {
      const auto* y = reinterpret_cast<const __m256i*>(d2 + static_cast<size_t>(j0 + c0) * kDims);
      __m256i acc[8];
      for (__m256i& v : acc) v = _mm256_setzero_si256();
      for (int k = 0; k < kLanes; ++k) {
        const __m256i u = _mm256_loadu_si256(x + k);
        for (int c = 0; c < 8; ++c) {
          acc[c] = _mm256_add_epi32(acc[c], _mm256_madd_epi16(u, _mm256_loadu_si256(y + c * kLanes + k)));
        }
      }
      // The eight sums into one vector, column c in lane c.
      const __m256i t0 = _mm256_hadd_epi32(acc[0], acc[1]), t1 = _mm256_hadd_epi32(acc[2], acc[3]);
      const __m256i t2 = _mm256_hadd_epi32(acc[4], acc[5]), t3 = _mm256_hadd_epi32(acc[6], acc[7]);
      const __m256i u0 = _mm256_hadd_epi32(t0, t1), u1 = _mm256_hadd_epi32(t2, t3);
      const __m256i dot = _mm256_add_epi32(_mm256_permute2x128_si256(u0, u1, 0x20),
                                           _mm256_permute2x128_si256(u0, u1, 0x31));
      // The columns: a larger dot product takes the best (and this row), the
      // old best or the product becomes the second.
      auto* best_c = reinterpret_cast<__m256i*>(best + c0);
      auto* second_c = reinterpret_cast<__m256i*>(second + c0);
      auto* index_c = reinterpret_cast<__m256i*>(index + c0);
      const __m256i b = _mm256_load_si256(best_c);
      const __m256i greater = _mm256_cmpgt_epi32(dot, b);
      _mm256_store_si256(second_c, _mm256_max_epi32(_mm256_load_si256(second_c), _mm256_min_epi32(b, dot)));
      _mm256_store_si256(best_c, _mm256_max_epi32(b, dot));
      _mm256_store_si256(index_c, _mm256_blendv_epi8(_mm256_load_si256(index_c), row_index, greater));
      // The row, when any of the eight beats its second best.
      __m128i m = _mm_max_epi32(_mm256_castsi256_si128(dot), _mm256_extracti128_si256(dot, 1));
      m = _mm_max_epi32(m, _mm_shuffle_epi32(m, 0x4E));
      m = _mm_max_epi32(m, _mm_shuffle_epi32(m, 0xB1));
      if (_mm_cvtsi128_si32(m) > row.second) {
        _mm256_store_si256(reinterpret_cast<__m256i*>(dots), dot);
        for (int c = 0; c < 8; ++c) row.Add(dots[c], j0 + c0 + c);
      }
    }
  }
  for (int c = 0; c < width; ++c) {
    cols[j0 + c].best = best[c];
    cols[j0 + c].second = second[c];
    cols[j0 + c].index = index[c];
  }
}
#endif

// Whether this processor runs TileAvx2.
bool HasAvx2() {
#if defined(HDABENCH_SIFT_AVX2)
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

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

// The matches from every descriptor's two best candidates, in increasing
// index in image 1, under the distance, ratio and cross-check rules.
std::vector<SiftMatch> SelectMatches(const std::vector<BestTwo>& rows, const std::vector<BestTwo>& cols,
                                     const SiftMatchOptions& options) {
  std::vector<SiftMatch> matches;
  // COLMAP passes its options to the tests as float.
  const float max_ratio = static_cast<float>(options.max_ratio);
  const float max_distance = static_cast<float>(options.max_distance);
  const int n1 = static_cast<int>(rows.size());
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

}  // namespace

std::vector<std::string> SiftMatchOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(max_ratio > 0 && max_ratio <= 1, "max_ratio", max_ratio, "in (0, 1]", &errors);
  RequireOption(max_distance > 0, "max_distance", max_distance, "> 0", &errors);
  RequireOption(max_num_matches >= 1, "max_num_matches", max_num_matches, ">= 1", &errors);
  RequireOption(threads >= 1, "threads", threads, ">= 1", &errors);
  return errors;
}

std::vector<SiftMatch> MatchSiftExact(const SiftDescriptors& image1, const SiftDescriptors& image2,
                                      const SiftMatchOptions& options) {
  ThrowIfInvalid("MatchSiftExact: invalid SiftMatchOptions: ", options.Validate());
  CheckDescriptors(image1, "image 1");
  CheckDescriptors(image2, "image 2");
  const int n1 = image1.rows, n2 = image2.rows;
  if (n1 == 0 || n2 == 0) return {};

  const std::vector<std::int16_t> d1 = ToInt16(image1), d2 = ToInt16(image2);
  const auto row1 = [&d1](int i) { return d1.data() + static_cast<size_t>(i) * kDims; };
  const auto row2 = [&d2](int j) { return d2.data() + static_cast<size_t>(j) * kDims; };
  std::vector<BestTwo> cols(static_cast<size_t>(n2));
  // Each part of the work: a range of image 2's tiles of columns, its own
  // best two per row of image 1, and the columns of its range (which no
  // other part touches).
  const int num_tiles = (n2 + kTileColumns - 1) / kTileColumns;
  const int num_parts = std::min(options.threads, num_tiles);
  std::vector<std::vector<BestTwo>> part_rows(static_cast<size_t>(num_parts));
  const bool avx2 = HasAvx2();
  util::ParallelFor("exact SIFT matching", num_parts, num_parts, [&](int part) {
    std::vector<BestTwo>& rows = part_rows[static_cast<size_t>(part)];
    rows.resize(static_cast<size_t>(n1));
    const auto add = [&rows, &cols](int i, int j, int dot) {
      rows[static_cast<size_t>(i)].Add(dot, j);
      cols[static_cast<size_t>(j)].Add(dot, i);
    };
    const int tile_begin = static_cast<int>(static_cast<std::int64_t>(num_tiles) * part / num_parts);
    const int tile_end = static_cast<int>(static_cast<std::int64_t>(num_tiles) * (part + 1) / num_parts);
    // Every (i, j) of the range once: tiles of columns, in each all rows (the
    // columns of a tile in increasing j for every row).
    for (int tile = tile_begin; tile < tile_end; ++tile) {
      int j0 = tile * kTileColumns;
      const int j1 = std::min(n2, j0 + kTileColumns);
#if defined(HDABENCH_SIFT_AVX2)
      if (avx2 && j1 - j0 >= 8) {
        const int j8 = j0 + (j1 - j0) / 8 * 8;
        TileAvx2(d1.data(), n1, d2.data(), j0, j8, rows.data(), cols.data());
        j0 = j8;
      }
#endif
      if (j0 == j1) continue;
      // Two rows by four columns at a time, the remainders one by one.
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
  });
  std::vector<BestTwo> rows = std::move(part_rows[0]);
  for (size_t part = 1; part < part_rows.size(); ++part) {
    for (size_t i = 0; i < rows.size(); ++i) rows[i].Merge(part_rows[part][i]);
  }

  return SelectMatches(rows, cols, options);
}

std::vector<SiftMatch> MatchSiftGuided(const SiftDescriptors& image1, const SiftDescriptors& image2,
                                       const std::vector<std::vector<int>>& candidates,
                                       const SiftMatchOptions& options) {
  ThrowIfInvalid("MatchSiftGuided: invalid SiftMatchOptions: ", options.Validate());
  CheckDescriptors(image1, "image 1");
  CheckDescriptors(image2, "image 2");
  const int n1 = image1.rows, n2 = image2.rows;
  if (candidates.size() != static_cast<size_t>(n1)) {
    throw InputError("MatchSiftGuided: " + std::to_string(candidates.size()) +
                     " candidate lists for " + std::to_string(n1) + " descriptors of image 1");
  }
  std::vector<BestTwo> rows(static_cast<size_t>(n1)), cols(static_cast<size_t>(n2));
  const std::vector<std::int16_t> d1 = ToInt16(image1), d2 = ToInt16(image2);
  for (int i = 0; i < n1; ++i) {
    int previous = -1;
    for (const int j : candidates[static_cast<size_t>(i)]) {
      if (j <= previous || j >= n2) {
        throw InputError("MatchSiftGuided: candidates of descriptor " + std::to_string(i) +
                         " of image 1: index " + std::to_string(j) +
                         " is not increasing or not below " + std::to_string(n2));
      }
      previous = j;
      const int dot = Dot(d1.data() + static_cast<size_t>(i) * kDims,
                          d2.data() + static_cast<size_t>(j) * kDims);
      rows[static_cast<size_t>(i)].Add(dot, j);
      cols[static_cast<size_t>(j)].Add(dot, i);
    }
  }
  return SelectMatches(rows, cols, options);
}

std::vector<std::vector<int>> EpipolarCandidates(const std::vector<Eigen::Vector3d>& bearings1,
                                                 const std::vector<Eigen::Vector3d>& bearings2,
                                                 const Eigen::Matrix3d& rotation,
                                                 const Eigen::Vector3d& translation,
                                                 double max_sin) {
  std::vector<std::vector<int>> candidates(bearings1.size());
  if (!(translation.norm() > 0) || !(max_sin > 0)) return candidates;
  const Eigen::Vector3d t = translation.normalized();
  Eigen::Matrix3d cross_t;
  cross_t << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  const Eigen::Matrix3d essential = cross_t * rotation;
  // A zero vector marks a bearing that cannot be used.
  const auto unit = [](const Eigen::Vector3d& v) {
    const double n = v.norm();
    return n > 0 && std::isfinite(n) ? Eigen::Vector3d(v / n) : Eigen::Vector3d::Zero();
  };
  // Per image-2 bearing: the unit normal of its epipolar plane in camera 1.
  std::vector<Eigen::Vector3d> f2(bearings2.size()), plane1(bearings2.size());
  for (size_t j = 0; j < bearings2.size(); ++j) {
    f2[j] = unit(bearings2[j]);
    plane1[j] = unit(essential.transpose() * f2[j]);
  }
  for (size_t i = 0; i < bearings1.size(); ++i) {
    const Eigen::Vector3d f1 = unit(bearings1[i]);
    const Eigen::Vector3d r1 = rotation * f1;       // f1 in camera 2
    const Eigen::Vector3d plane2 = unit(t.cross(r1));  // its epipolar plane in camera 2
    if (plane2.isZero()) continue;
    for (size_t j = 0; j < f2.size(); ++j) {
      if (std::abs(plane2.dot(f2[j])) > max_sin || plane1[j].isZero() ||
          std::abs(plane1[j].dot(f1)) > max_sin) {
        continue;
      }
      // In front of both cameras: d1 R f1 + t = d2 f2 with d1, d2 > 0.
      const Eigen::Vector3d r1_x_f2 = r1.cross(f2[j]);
      if (t.cross(f2[j]).dot(r1_x_f2) >= 0 || t.cross(r1).dot(-r1_x_f2) <= 0) continue;
      candidates[i].push_back(static_cast<int>(j));
    }
  }
  return candidates;
}

bool SiftDescriptorMayBeUnset(double x, double y, double scale, int width, int height,
                              const SiftOctaves& octaves) {
  // VLFeat's filter as COLMAP 3.8 sets it up.
  const int first_octave = octaves.first_octave;
  const int last_octave = octaves.first_octave + std::max(octaves.num_octaves, 1) - 1;
  const double levels = std::max(octaves.octave_resolution, 1);
  const double sigma0 = 1.6 * std::pow(2.0, 1.0 / levels);
  int first = first_octave, last = last_octave;
  if (scale > 0 && std::isfinite(scale)) {
    const double log_scale = std::log2(scale / sigma0);
    first = std::max(first, static_cast<int>(std::ceil(log_scale - (levels + 0.5) / levels)));
    last = std::min(last, static_cast<int>(std::floor(log_scale + 1.5 / levels)));
    if (first > last) {
      first = first_octave;
      last = last_octave;
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
