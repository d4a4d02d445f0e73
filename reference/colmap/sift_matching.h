// Exact SIFT descriptor matching for the COLMAP references
// (reference/colmap/colmap_runner.h), in place of COLMAP 3.8's CPU matcher.
//
// COLMAP 3.8 matches on the CPU with FLANN's randomised kd-trees: an
// approximate two-nearest-neighbour search seeded from the C library's global
// rand(), so every run keeps a slightly different match set. This is the same
// matching done exactly: every descriptor of image 1 against every one of
// image 2, with COLMAP's acceptance rules, so the result depends on the
// descriptors and the options alone.
//
// COLMAP's rules, as this implements them:
//  * Descriptors are 128 bytes, SIFT vectors L2-normalised to length 512 and
//    truncated to 0..255. Their similarity is the integer dot product, read as
//    an angle: acos(min(dot / 512^2, 1)), in single precision (float), as
//    COLMAP computes it. A dot product of 0 is no candidate at all.
//  * For a descriptor, best and second best are the largest and second
//    largest dot products over the other image (the second may equal the
//    best). It is matched to the best when angle(best) <= max_distance and
//    angle(best) < max_ratio * angle(second); with no second candidate the
//    second angle is that of a dot product of 0, pi/2. A tie for the best
//    therefore never passes the ratio test.
//  * Cross-check: a pair (i, j) is kept only when i's match is j and j's
//    match (the same rules, from image 2 to image 1) is i.
//  * The matches come in increasing index in image 1.
// Candidates are ranked by the dot product over all descriptors of the other
// image, as COLMAP 3.8's brute-force CPU matcher (MatchSiftFeaturesCPUBruteForce,
// not the default) and its GPU matcher do. Its default FLANN matcher takes
// the two nearest neighbours in L2 (approximately) and then applies the same
// rules to their dot products; for vectors of length 512 the two orders
// agree, for the truncated bytes nearly. Among equal best dot products the
// lowest index is taken; as said, such a tie is rejected anyway.
//
// Dot products: integers, computed in full for every pair of descriptors
// (AVX2's 16-bit multiply-adds, eight descriptors of image 2 at a time, where
// the processor has it, chosen at run time; SSE2's where the compiler
// targets it; plain loops elsewhere); a dot product is at most
// 128 * 255^2 < 2^24, so nothing overflows or rounds, and the candidates'
// order only decides ties, by the rule above. The result is the same on every
// machine and run, and with any number of threads (SiftMatchOptions::threads).
// On this bench's machine (BM_MatchSiftExact): 23000 x 23000 descriptors (a
// 1024 x 1024 pair at the first octave -1) 4.8 s on one core, 2.5 s on two;
// 50000 x 50000 (first octave -2) 18.9 s and 8.5 s.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace hdabench::reference {

// COLMAP 3.8's --SiftMatching defaults where not said otherwise.
struct SiftMatchOptions {
  double max_ratio = 0.8;     // Lowe ratio test on the angles, in (0, 1]
  double max_distance = 0.7;  // largest angle of a match, radians, > 0
  bool cross_check = true;    // keep mutual matches only
  // Most matches kept per pair, >= 1: the first ones by index in image 1.
  // COLMAP's CPU matcher does not apply it; the COLMAP references set it to
  // ColmapOptions::sift_max_num_features, which bounds the matches anyway.
  int max_num_matches = 32768;
  // Threads of the exact matcher, >= 1. The matches do not depend on it: each
  // thread takes a range of image 2's descriptors, and the best and second
  // best of a descriptor are the same whatever order its candidates come in
  // (the lowest index wins a tie for the best).
  int threads = 1;

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

// The SIFT descriptors of one image, COLMAP's database layout: `rows`
// descriptors of 128 bytes each, row after row.
struct SiftDescriptors {
  int rows = 0;
  std::vector<std::uint8_t> data;  // rows * 128 bytes
};

struct SiftMatch {
  int index1 = 0;  // descriptor (and keypoint) index in image 1
  int index2 = 0;  // in image 2
  bool operator==(const SiftMatch& other) const {
    return index1 == other.index1 && index2 == other.index2;
  }
};

// The matches between two images under the rules above. Throws InputError
// for invalid options or descriptors whose data is not rows * 128 bytes.
std::vector<SiftMatch> MatchSiftExact(const SiftDescriptors& image1, const SiftDescriptors& image2,
                                      const SiftMatchOptions& options);

// Guided matching: the rules above, with each descriptor of image 1 compared
// only with its candidates in image 2 (candidates[i]: indices into image 2,
// increasing; one list per descriptor of image 1), and each descriptor of
// image 2 only with the descriptors of image 1 that list it. Best and second
// best are taken over those, as COLMAP's guided matching takes them over the
// features its estimated two-view geometry allows. Throws InputError for
// invalid options or descriptors, a list count other than image1.rows, or an
// index not increasing or out of range.
std::vector<SiftMatch> MatchSiftGuided(const SiftDescriptors& image1, const SiftDescriptors& image2,
                                       const std::vector<std::vector<int>>& candidates,
                                       const SiftMatchOptions& options);

// The candidates of guided matching under a known relative pose (camera 2
// from camera 1: x2 = rotation * x1 + translation, any scale): image-2
// bearing j is a candidate of image-1 bearing i when each lies within an
// angle of asin(max_sin) of the other's epipolar plane (the band is the same
// seen from either image, so the relation is symmetric) and the two rays
// meet in front of both cameras. Bearings need not be unit length; a zero or
// non-finite one has no candidates. No translation: no candidates at all.
// Every pair is tested: about 1 s for 23000 x 23000 bearings.
std::vector<std::vector<int>> EpipolarCandidates(const std::vector<Eigen::Vector3d>& bearings1,
                                                 const std::vector<Eigen::Vector3d>& bearings2,
                                                 const Eigen::Matrix3d& rotation,
                                                 const Eigen::Vector3d& translation,
                                                 double max_sin);

// COLMAP's scale space (--SiftExtraction options of the same names).
struct SiftOctaves {
  int first_octave = -1;      // -1: the image upsampled twice first
  int num_octaves = 4;
  int octave_resolution = 3;  // levels per octave
};

// Keypoints whose stored descriptor COLMAP 3.8 may never have computed.
// Its CPU SIFT (VLFeat, with COLMAP's scale space: by default first octave
// -1, 4 octaves, 3 levels per octave) keeps a keypoint refined onto the last
// pixel row of its octave, but VLFeat's descriptor function returns without
// writing for such a keypoint (it needs the row below), and COLMAP then
// stores what its buffer held: zeros in one run, an unrelated descriptor in
// the next. Measured on 1024 x 1024 images: about one keypoint in 10000, all
// at the bottom edge, the only descriptors that differed between two
// extractions.
// True when, for any octave the keypoint's scale allows, it rounds onto a
// pixel VLFeat leaves without a descriptor. x, y: COLMAP's keypoint position
// (the top-left pixel's corner at 0, 0) and scale (pixels), in the image as
// SIFT saw it, of width x height px. The octave follows from the scale,
// sigma0 2^(octave + level / S) with S the octave resolution, sigma0 =
// 1.6 * 2^(1/S) and the refined level within 1.5 of a detection level
// 0..S-1; where two octaves are possible both are checked. A scale <= 0 or
// not finite checks every octave.
bool SiftDescriptorMayBeUnset(double x, double y, double scale, int width, int height,
                              const SiftOctaves& octaves = SiftOctaves());

}  // namespace hdabench::reference
