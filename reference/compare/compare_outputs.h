// The outputs of `hdabench compare`: compare.json (deterministic, versioned),
// compare_timings.json (wall times), compare.csv (one row per ROI and
// method), compare.md (the paper-style table, one column per method, and the
// per-method summary), and the flight method's own outputs in flight/. The
// formats are specified in docs/compare-results.md (format_version 1).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "reference/compare/compare.h"

namespace hdabench::reference {

inline constexpr char kCompareResultFormatName[] = "hdabench-compare-result";
inline constexpr char kCompareTimingsFormatName[] = "hdabench-compare-timings";
inline constexpr int kCompareResultFormatVersion = 1;

// compare.json: run, methods with their summaries, ROIs with each method's
// values. No wall times: the same inputs give the same bytes.
std::string CompareResultJson(const CompareRun& run);
// compare_timings.json: each method's seconds, its ratio to the flight
// method, and per-ROI seconds of the per-ROI methods.
std::string CompareTimingsJson(const CompareRun& run);
// compare.csv: a header and one row per (ROI, method), ROIs in id order and
// methods in table order; empty cells where a value does not apply.
std::string CompareRoisCsv(const CompareRun& run);
// compare.md: the run line, the per-ROI table
//   ROI | truth slope | <method> slope (# points) ... 
// ("-" where a method has no fit; its status instead for a method with no
// confident slope), the per-method summary table (errors against truth and
// against colmap-nav, point accuracy, pose errors, time and ratio to the flight
// method), and the failed methods with their reasons.
std::string CompareMarkdown(const CompareRun& run);

// Writes compare.json, compare_timings.json, compare.csv and compare.md into
// dir (created if missing), each atomically; and the flight method's outputs
// (WriteFlightOutputs) into dir/flight. compare.json, the mark of a whole
// comparison, is removed first and written last. Returns the paths written,
// relative to dir, compare.json first. Throws InputError naming a path that
// cannot be written. `threads` draw the flight method's figures (0: every core
// this process may use); the files do not depend on it.
std::vector<std::string> WriteCompareOutputs(const CompareRun& run, const cv::Mat& image1,
                                             const cv::Mat& image2, const std::string& dir,
                                             bool figures, int threads = 0);

}  // namespace hdabench::reference
