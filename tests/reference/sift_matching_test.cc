#include "reference/colmap/sift_matching.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "tools/util/error.h"
#include "tests/support/test_support.h"

namespace hdabench::reference {
namespace {

using Descriptor = std::vector<std::uint8_t>;

// A descriptor with the given (position, value) entries, zero elsewhere.
Descriptor Entries(const std::vector<std::pair<int, int>>& entries) {
  Descriptor d(128, 0);
  for (const auto& [position, value] : entries) {
    d[static_cast<size_t>(position)] = static_cast<std::uint8_t>(value);
  }
  return d;
}

// 255 on positions 4k .. 4k+3: length 510, the blocks are orthogonal, and a
// block with itself has the dot product 4 * 255^2 = 260100, COLMAP's angle
// acos(260100 / 512^2) = 0.1250 rad.
Descriptor Block(int k) {
  return Entries({{4 * k, 255}, {4 * k + 1, 255}, {4 * k + 2, 255}, {4 * k + 3, 255}});
}

// Against Block(0): 3 * 255^2 + 255 * 200 = 246075, angle 0.3520 rad.
Descriptor NearBlock0() { return Entries({{0, 255}, {1, 255}, {2, 255}, {3, 200}}); }
// Against Block(0): 3 * 255^2 = 195075, angle 0.7315 rad.
Descriptor FarFromBlock0() { return Entries({{0, 255}, {1, 255}, {2, 255}, {4, 255}}); }

SiftDescriptors Set(const std::vector<Descriptor>& rows) {
  SiftDescriptors set;
  set.rows = static_cast<int>(rows.size());
  for (const Descriptor& d : rows) set.data.insert(set.data.end(), d.begin(), d.end());
  return set;
}

using Pairs = std::vector<std::pair<int, int>>;

// The matches as (index1, index2) pairs, which GoogleTest prints.
Pairs Match(const SiftDescriptors& one, const SiftDescriptors& two,
            const SiftMatchOptions& options) {
  Pairs pairs;
  for (const SiftMatch& m : MatchSiftExact(one, two, options)) {
    pairs.emplace_back(m.index1, m.index2);
  }
  return pairs;
}

TEST(MatchSiftExact, DistinctDescriptorsMatchTheirCopies) {
  std::vector<Descriptor> one, two;
  for (int k = 0; k < 10; ++k) one.push_back(Block(k));
  for (int k = 9; k >= 0; --k) two.push_back(Block(k));
  Pairs expected;
  for (int i = 0; i < 10; ++i) expected.emplace_back(i, 9 - i);
  EXPECT_EQ(Match(Set(one), Set(two), SiftMatchOptions()), expected);
}

TEST(MatchSiftExact, MaxDistanceBoundsTheBestAngle) {
  // Angle 0.7315 rad: beyond COLMAP's default of 0.7, within 0.75.
  const SiftDescriptors one = Set({Block(0)}), two = Set({FarFromBlock0()});
  SiftMatchOptions options;
  EXPECT_EQ(options.max_distance, 0.7);
  EXPECT_TRUE(Match(one, two, options).empty());
  options.max_distance = 0.75;
  EXPECT_EQ(Match(one, two, options), (Pairs{{0, 0}}));
}

TEST(MatchSiftExact, RatioTestOnTheAngles) {
  // Best 0.1250 rad, second 0.3520 rad: ratio 0.355.
  const SiftDescriptors one = Set({Block(0)}), two = Set({Block(0), NearBlock0()});
  SiftMatchOptions options;
  EXPECT_EQ(Match(one, two, options), (Pairs{{0, 0}}));
  options.max_ratio = 0.36;
  EXPECT_EQ(Match(one, two, options), (Pairs{{0, 0}}));
  options.max_ratio = 0.35;
  EXPECT_TRUE(Match(one, two, options).empty());
  // Without a second candidate its angle is pi/2: 0.1250 < 0.1 * 1.5708.
  options.max_ratio = 0.1;
  EXPECT_EQ(Match(one, Set({Block(0), Block(1)}), options), (Pairs{{0, 0}}));
}

TEST(MatchSiftExact, ATieForTheBestIsNeverAMatch) {
  // Two equal best candidates in image 2, wherever they are: the second best
  // equals the best and fails the ratio test, even at max_ratio 1.
  SiftMatchOptions options;
  options.max_ratio = 1.0;
  for (const std::vector<Descriptor>& two : {std::vector<Descriptor>{Block(1), Block(0), Block(0)},
                                             std::vector<Descriptor>{Block(0), Block(1), Block(0)},
                                             std::vector<Descriptor>{Block(0), Block(0)}}) {
    EXPECT_TRUE(Match(Set({Block(0)}), Set(two), options).empty());
  }
  // The tie the other way (two equal descriptors in image 1) fails image 2's
  // test: it removes the matches through the cross-check only.
  const SiftDescriptors one = Set({Block(0), Block(0)}), two = Set({Block(0)});
  EXPECT_TRUE(Match(one, two, options).empty());
  options.cross_check = false;
  EXPECT_EQ(Match(one, two, options), (Pairs{{0, 0}, {1, 0}}));
}

TEST(MatchSiftExact, CrossCheckKeepsMutualMatchesOnly) {
  // Both descriptors of image 1 pass their tests towards image 2's only one,
  // whose own best is the first (ratio 0.355 against the second).
  const SiftDescriptors one = Set({Block(0), NearBlock0()}), two = Set({Block(0)});
  SiftMatchOptions options;
  EXPECT_TRUE(options.cross_check);
  EXPECT_EQ(Match(one, two, options), (Pairs{{0, 0}}));
  options.cross_check = false;
  EXPECT_EQ(Match(one, two, options), (Pairs{{0, 0}, {1, 0}}));
}

TEST(MatchSiftExact, NoCandidatesNoMatches) {
  const SiftDescriptors zeros = Set({Descriptor(128, 0), Descriptor(128, 0)});
  EXPECT_TRUE(Match(zeros, zeros, SiftMatchOptions()).empty());
  EXPECT_TRUE(Match(Set({Block(0)}), zeros, SiftMatchOptions()).empty());
  EXPECT_TRUE(Match(SiftDescriptors(), Set({Block(0)}), SiftMatchOptions()).empty());
  EXPECT_TRUE(Match(Set({Block(0)}), SiftDescriptors(), SiftMatchOptions()).empty());
}

TEST(MatchSiftExact, MaxNumMatchesKeepsTheFirstInImage1) {
  std::vector<Descriptor> blocks;
  for (int k = 0; k < 10; ++k) blocks.push_back(Block(k));
  SiftMatchOptions options;
  options.max_num_matches = 3;
  EXPECT_EQ(Match(Set(blocks), Set(blocks), options), (Pairs{{0, 0}, {1, 1}, {2, 2}}));
}

// Descriptors as COLMAP makes them: a non-negative vector scaled to length
// 512 and truncated to bytes.
Descriptor Quantised(const std::vector<double>& v) {
  double norm = 0.0;
  for (const double x : v) norm += x * x;
  norm = std::sqrt(norm);
  Descriptor d(128);
  for (size_t k = 0; k < 128; ++k) {
    d[k] = static_cast<std::uint8_t>(std::min(255.0, std::floor(512.0 * v[k] / norm)));
  }
  return d;
}

// Two sets larger than the matcher's blocks of 256 rows: 500 of image 2's
// 650 descriptors are noisy copies of 500 of image 1's first 700, in another
// order, so many pass and many fail the tests. Raw integers from the engine (no
// distribution), so the sets are the same with every standard library.
constexpr double kNoiseMin = 0.02, kNoiseSpan = 1.5;
std::pair<SiftDescriptors, SiftDescriptors> RandomPair(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const auto uniform = [&rng]() { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  std::vector<std::vector<double>> base(700, std::vector<double>(128));
  for (auto& v : base) {
    for (double& x : v) x = std::pow(uniform(), 4.0);  // sparse-ish, as SIFT
  }
  std::vector<Descriptor> one, two;
  for (const auto& v : base) one.push_back(Quantised(v));
  // Near-copies within image 1 compete for the same descriptor of image 2,
  // which the cross-check decides.
  for (int i = 0; i < 100; ++i) {
    std::vector<double> v = base[static_cast<size_t>(3 * i)];
    for (double& x : v) x = std::max(0.0, x + 0.3 * (uniform() - 0.5));
    one.push_back(Quantised(v));
  }
  for (int i = 0; i < 650; ++i) {
    std::vector<double> v(128);
    if (i < 500) {
      v = base[static_cast<size_t>((3 * i) % 700)];
      const double noise = kNoiseMin + kNoiseSpan * uniform();
      for (double& x : v) x = std::max(0.0, x + noise * (uniform() - 0.5));
    } else {
      for (double& x : v) x = std::pow(uniform(), 4.0);
    }
    two.push_back(Quantised(v));
  }
  return {Set(one), Set(two)};
}

// COLMAP's rules written out directly: all dot products one by one, the
// candidates in index order, no blocks, no floats but the angles.
std::vector<int> OneWay(const SiftDescriptors& a, const SiftDescriptors& b, float max_ratio,
                        float max_distance) {
  const auto angle = [](int dot) {
    return std::acos(std::min(static_cast<float>(dot) / (512.0f * 512.0f), 1.0f));
  };
  std::vector<int> match(static_cast<size_t>(a.rows), -1);
  for (int i = 0; i < a.rows; ++i) {
    int best = 0, second = 0, index = -1;
    for (int j = 0; j < b.rows; ++j) {
      int dot = 0;
      for (size_t k = 0; k < 128; ++k) {
        dot += a.data[static_cast<size_t>(i) * 128 + k] * b.data[static_cast<size_t>(j) * 128 + k];
      }
      if (dot > best) {
        second = best;
        best = dot;
        index = j;
      } else if (dot > second) {
        second = dot;
      }
    }
    if (index < 0 || angle(best) > max_distance) continue;
    if (angle(best) >= max_ratio * angle(second)) continue;
    match[static_cast<size_t>(i)] = index;
  }
  return match;
}

TEST(MatchSiftExact, AgreesWithTheRulesComputedOneByOne) {
  const auto [one, two] = RandomPair(testing_support::CurrentTestSeed());
  for (const bool cross_check : {true, false}) {
    SiftMatchOptions options;
    options.cross_check = cross_check;
    const std::vector<int> forward = OneWay(one, two, 0.8f, 0.7f);
    const std::vector<int> backward = OneWay(two, one, 0.8f, 0.7f);
    Pairs expected;
    for (int i = 0; i < one.rows; ++i) {
      const int j = forward[static_cast<size_t>(i)];
      if (j >= 0 && (!cross_check || backward[static_cast<size_t>(j)] == i)) {
        expected.emplace_back(i, j);
      }
    }
    const Pairs matches = Match(one, two, options);
    std::printf("[ matching ] cross_check %d: %zu matches of %d x %d descriptors\n",
                cross_check ? 1 : 0, matches.size(), one.rows, two.rows);
    EXPECT_EQ(matches, expected);
    // Neither trivial nor everything, and the cross-check removes some.
    EXPECT_GT(matches.size(), 100u);
    EXPECT_LT(matches.size(), 600u);
    if (cross_check) {
      SiftMatchOptions one_way = options;
      one_way.cross_check = false;
      EXPECT_LT(matches.size(), Match(one, two, one_way).size());
    }
    // And the same on a second call.
    EXPECT_EQ(Match(one, two, options), matches);
  }
}

// The matches do not depend on the number of threads (each takes a range of
// image 2's descriptors; the best two per descriptor merge exactly), ties
// for the best included.
TEST(MatchSiftExact, TheThreadsDoNotChangeTheMatches) {
  auto [one, two] = RandomPair(testing_support::CurrentTestSeed());
  // Copies of an image-2 descriptor far apart, in different threads' ranges.
  std::copy_n(two.data.begin() + 128 * 3, 128, two.data.begin() + 128 * 600);
  for (const bool cross_check : {true, false}) {
    SiftMatchOptions options;
    options.cross_check = cross_check;
    const Pairs one_thread = Match(one, two, options);
    for (const int threads : {2, 3, 7, 64}) {
      options.threads = threads;
      EXPECT_EQ(Match(one, two, options), one_thread) << threads << " threads";
    }
  }
  SiftMatchOptions bad;
  bad.threads = 0;
  EXPECT_THROW(MatchSiftExact(one, two, bad), InputError);
}

TEST(MatchSiftExact, ReorderingAnImageReordersTheMatchesOnly) {
  const auto [one, two] = RandomPair(testing_support::CurrentTestSeed());
  // Image 2 reversed: descriptor j moves to rows - 1 - j.
  SiftDescriptors reversed = two;
  for (int j = 0; j < two.rows; ++j) {
    std::copy_n(two.data.begin() + 128 * j, 128, reversed.data.begin() + 128 * (two.rows - 1 - j));
  }
  const Pairs matches = Match(one, two, SiftMatchOptions());
  Pairs mapped = Match(one, reversed, SiftMatchOptions());
  for (auto& m : mapped) m.second = two.rows - 1 - m.second;
  EXPECT_FALSE(matches.empty());
  EXPECT_EQ(mapped, matches);
}

// The guided matches as (index1, index2) pairs.
Pairs MatchGuided(const SiftDescriptors& one, const SiftDescriptors& two,
                  const std::vector<std::vector<int>>& candidates, const SiftMatchOptions& options) {
  Pairs pairs;
  for (const SiftMatch& m : MatchSiftGuided(one, two, candidates, options)) {
    pairs.emplace_back(m.index1, m.index2);
  }
  return pairs;
}

TEST(MatchSiftGuided, EveryCandidateIsTheExactMatcher) {
  const auto [one, two] = RandomPair(testing_support::CurrentTestSeed());
  std::vector<int> all(static_cast<size_t>(two.rows));
  for (int j = 0; j < two.rows; ++j) all[static_cast<size_t>(j)] = j;
  const std::vector<std::vector<int>> candidates(static_cast<size_t>(one.rows), all);
  for (const bool cross_check : {true, false}) {
    SiftMatchOptions options;
    options.cross_check = cross_check;
    const Pairs exact = Match(one, two, options);
    EXPECT_GT(exact.size(), 100u);
    EXPECT_EQ(MatchGuided(one, two, candidates, options), exact);
  }
}

TEST(MatchSiftGuided, TheBandDecidesTheRatioTest) {
  // Two equal descriptors in image 2 make every exact match ambiguous; with
  // only one of them a candidate the match is unambiguous.
  const SiftDescriptors one = Set({Block(0), Block(1)});
  const SiftDescriptors two = Set({Block(0), Block(1), Block(0)});
  EXPECT_EQ(Match(one, two, SiftMatchOptions()), (Pairs{{1, 1}}));
  EXPECT_EQ(MatchGuided(one, two, {{2}, {1}}, SiftMatchOptions()), (Pairs{{0, 2}, {1, 1}}));
  EXPECT_EQ(MatchGuided(one, two, {{0}, {1}}, SiftMatchOptions()), (Pairs{{0, 0}, {1, 1}}));
  // Image 2's side of the cross-check sees only the descriptors that list it:
  // both of image 1 listing image 2's first, the better one wins it.
  const SiftDescriptors near = Set({Block(0), NearBlock0()});
  EXPECT_EQ(MatchGuided(near, Set({Block(0)}), {{0}, {0}}, SiftMatchOptions()), (Pairs{{0, 0}}));
  EXPECT_EQ(MatchGuided(near, Set({Block(0)}), {{}, {0}}, SiftMatchOptions()), (Pairs{{1, 0}}));
  // No candidates, no matches.
  EXPECT_TRUE(MatchGuided(one, two, {{}, {}}, SiftMatchOptions()).empty());
}

TEST(MatchSiftGuided, InvalidCandidatesThrow) {
  const SiftDescriptors one = Set({Block(0), Block(1)}), two = Set({Block(0), Block(1)});
  const auto message = [&](const std::vector<std::vector<int>>& candidates) {
    try {
      MatchSiftGuided(one, two, candidates, SiftMatchOptions());
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_NE(message({{0}}).find("1 candidate lists for 2 descriptors"), std::string::npos);
  EXPECT_NE(message({{1, 0}, {}}).find("candidates of descriptor 0"), std::string::npos);
  EXPECT_NE(message({{0}, {2}}).find("candidates of descriptor 1 of image 1: index 2"), std::string::npos);
  EXPECT_NE(message({{0}, {-1}}).find("not increasing"), std::string::npos);
}

// Camera 2 from camera 1 for a camera that moved 30 m along its x axis and
// turned 2 deg about its y axis; ground points about 566 m ahead.
struct TwoViews {
  Eigen::Matrix3d rotation = Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  Eigen::Vector3d translation = -(Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()) *
                                  Eigen::Vector3d(30.0, 0.0, 0.0));
  Eigen::Vector3d InCamera2(const Eigen::Vector3d& p1) const { return rotation * p1 + translation; }
};

TEST(EpipolarCandidates, TrueCorrespondencesInTheBandOthersOut) {
  const TwoViews views;
  std::mt19937_64 rng(testing_support::CurrentTestSeed());
  const auto uniform = [&rng]() { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  std::vector<Eigen::Vector3d> points;
  for (int k = 0; k < 200; ++k) {
    points.emplace_back(300.0 * (uniform() - 0.5), 300.0 * (uniform() - 0.5), 540.0 + 50.0 * uniform());
  }
  std::vector<Eigen::Vector3d> b1, b2;
  for (const Eigen::Vector3d& p : points) {
    b1.push_back(p);  // bearings need not be unit length
    b2.push_back(views.InCamera2(p) * 3.0);
  }
  // A band of 1 px at a focal length of 1000 px.
  const double max_sin = std::sin(std::atan(1.0 / 1000.0));
  const std::vector<std::vector<int>> candidates =
      EpipolarCandidates(b1, b2, views.rotation, views.translation, max_sin);
  ASSERT_EQ(candidates.size(), points.size());
  // The same relation seen from image 2 (camera 1 from camera 2).
  const std::vector<std::vector<int>> reverse = EpipolarCandidates(
      b2, b1, views.rotation.transpose(), -(views.rotation.transpose() * views.translation), max_sin);
  size_t total = 0, total_reverse = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const std::vector<int>& c = candidates[i];
    EXPECT_TRUE(std::is_sorted(c.begin(), c.end()));
    EXPECT_TRUE(std::binary_search(c.begin(), c.end(), static_cast<int>(i))) << "point " << i;
    total += c.size();
    total_reverse += reverse[i].size();
    for (const int j : c) {
      EXPECT_TRUE(std::binary_search(reverse[static_cast<size_t>(j)].begin(),
                                     reverse[static_cast<size_t>(j)].end(), static_cast<int>(i)));
    }
  }
  EXPECT_EQ(total_reverse, total);
  // A band of 2 px out of about 1000 keeps a few per cent of 200 points.
  std::printf("[ epipolar ] %zu candidate pairs of %zu x %zu\n", total, points.size(), points.size());
  EXPECT_LT(total, points.size() * 20);
  // 2 px off the line (across it, at 566 m and f = 1000 px: 1.13 m in y):
  // outside; 0.5 px: inside.
  for (const double offset_px : {2.0, 0.5}) {
    const Eigen::Vector3d p(10.0, 20.0, 566.0);
    const Eigen::Vector3d moved = views.InCamera2(p) + Eigen::Vector3d(0.0, offset_px * 0.566, 0.0);
    const auto c = EpipolarCandidates({p}, {moved}, views.rotation, views.translation, max_sin);
    EXPECT_EQ(c[0].size(), offset_px < 1.0 ? 1u : 0u) << offset_px << " px";
  }
  // Rays on their epipolar planes that meet behind camera 2 (image 2's ray
  // reversed) or behind camera 1 (image 2 sees the mirrored point): no
  // candidate.
  const Eigen::Vector3d p(10.0, 20.0, 566.0);
  EXPECT_TRUE(EpipolarCandidates({p}, {-views.InCamera2(p)}, views.rotation, views.translation, max_sin)[0]
                  .empty());
  EXPECT_TRUE(EpipolarCandidates({p}, {views.InCamera2(-p)}, views.rotation, views.translation, max_sin)[0]
                  .empty());
  // No translation, a zero or non-finite bearing: no candidates.
  EXPECT_TRUE(EpipolarCandidates({p}, {p}, views.rotation, Eigen::Vector3d::Zero(), max_sin)[0].empty());
  EXPECT_TRUE(EpipolarCandidates({Eigen::Vector3d::Zero()}, {views.InCamera2(p)}, views.rotation,
                                 views.translation, max_sin)[0]
                  .empty());
  EXPECT_TRUE(EpipolarCandidates({p}, {Eigen::Vector3d(NAN, 0.0, 1.0)}, views.rotation, views.translation,
                                 max_sin)[0]
                  .empty());
}

// Keypoints of COLMAP 3.8 on 1024 x 1024 images whose descriptors differed
// between two extractions (zeros in one, another vector in the other), and
// keypoints whose descriptors VLFeat computes.
TEST(SiftDescriptorMayBeUnset, KeypointsOnTheLastRowOfTheirOctave) {
  // Octave -1 or 0, on the last row of either.
  EXPECT_TRUE(SiftDescriptorMayBeUnset(24.23, 1023.91, 1.543, 1024, 1024));
  // Scale 6.7 px: octave 1 or 2; on the last row of octave 1 (2 px rows).
  EXPECT_TRUE(SiftDescriptorMayBeUnset(683.62, 1022.37, 6.725, 1024, 1024));
  // Interior, and near the bottom but not on the last row of octaves -1, 0.
  EXPECT_FALSE(SiftDescriptorMayBeUnset(500.0, 500.0, 2.0, 1024, 1024));
  EXPECT_FALSE(SiftDescriptorMayBeUnset(500.0, 1021.0, 1.5, 1024, 1024));
  // The same keypoint with a large scale (octave 2, 4 px rows) is on it.
  EXPECT_TRUE(SiftDescriptorMayBeUnset(500.0, 1021.0, 12.0, 1024, 1024));
  // Without a scale every octave is checked.
  EXPECT_TRUE(SiftDescriptorMayBeUnset(500.0, 1021.0, 0.0, 1024, 1024));
  // The left, top and right edges keep their descriptors (VLFeat's bounds
  // exclude only the last row there).
  EXPECT_FALSE(SiftDescriptorMayBeUnset(0.6, 0.6, 1.5, 1024, 1024));
  EXPECT_FALSE(SiftDescriptorMayBeUnset(1023.9, 500.0, 1.5, 1024, 1024));
}

TEST(MatchSiftExact, InvalidInputThrows) {
  SiftDescriptors bad = Set({Block(0)});
  bad.rows = 2;
  EXPECT_THROW(MatchSiftExact(bad, Set({Block(0)}), SiftMatchOptions()), InputError);
  SiftMatchOptions options;
  options.max_ratio = 1.5;
  options.max_distance = 0.0;
  options.max_num_matches = 0;
  try {
    MatchSiftExact(Set({Block(0)}), Set({Block(0)}), options);
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("max_ratio = 1.5"), std::string::npos) << what;
    EXPECT_NE(what.find("max_distance = 0"), std::string::npos) << what;
    EXPECT_NE(what.find("max_num_matches = 0"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace hdabench::reference
