// `hdabench imagery pair` and `hdabench imagery edge`: whether synthetic
// imagery behaves like a camera's (datasets/synth/imagery_check.h,
// docs/synthetic-scenes.md "Checking the imagery").
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>

#include "datasets/synth/imagery_check.h"
#include "datasets/synth/synth.h"
#include "hda/hda_options.h"
#include "reference/flight/flight_run.h"
#include "tools/cli/command_line.h"
#include "tools/cli/command_support.h"
#include "tools/cli/exit_codes.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/util/options_check.h"
#include "tools/util/statistics.h"
#include "tools/util/text.h"

namespace hdabench::tools {

namespace {

namespace synth = datasets::synth;
using Json = nlohmann::ordered_json;

struct ImageryPairArgs {
  std::string dataset_dir;
  std::string frames_text;
  std::string out_dir;
  double max_ratio = 1.5;
  bool quiet = false;
};

std::string Cell(double value, int decimals) { return util::FixedCell(value, decimals); }

// The per-ROI table, the match errors and the verdict.
int RunImageryPair(const ImageryPairArgs& args, std::ostream& out, std::ostream& err) {
  const auto progress = [&](const std::string& line) {
    if (!args.quiet) err << "hdabench imagery pair: " << line << "\n";
  };
  // A limit the check can fail: finite (inf would pass anything, and write
  // null into imagery.json).
  if (!(args.max_ratio > 0.0 && std::isfinite(args.max_ratio))) {
    err << "hdabench imagery pair: --max-ratio " << util::ShortestText(args.max_ratio)
        << ": expected a finite number > 0\n";
    return kExitUsage;
  }
  const std::string out_dir = args.out_dir.empty() ? std::string() : args.out_dir;
  const NewFolders made_here(out_dir);  // removed again when the pair turns out unusable
  const PairLoad pair = LoadDatasetPair(args.dataset_dir, ParseFramesFlag(args.frames_text), out_dir,
                                        "imagery pair", err, progress, /*read_dem=*/true,
                                        "imagery.json");
  if (pair.exit_code != kExitOk) return pair.exit_code;
  const datasets::Dataset& dataset = *pair.dataset;
  const auto [frame1, frame2] = pair.frames;
  progress("flight method on frames " + std::to_string(frame1) + "," + std::to_string(frame2) +
           " (its ROIs and matches)");
  cv::setNumThreads(1);
  const reference::FlightRun run = reference::RunFlight(dataset, frame1, frame2, hda::HdaOptions());
  std::vector<std::pair<int, cv::Rect>> boxes;
  std::vector<Eigen::Vector2d> points1, points2;
  for (const hda::RoiResult& roi : run.result.rois) {
    boxes.emplace_back(roi.id, roi.box1_px);
    for (size_t k = 0; k < roi.points1_px.size(); ++k) {
      points1.emplace_back(roi.points1_px[k].x, roi.points1_px[k].y);
      points2.emplace_back(roi.points2_px[k].x, roi.points2_px[k].y);
    }
  }
  progress("photometric residual of " + std::to_string(boxes.size()) + " ROIs");
  std::vector<synth::PhotometricRoi> rois;
  synth::MatchErrors matches;
  try {
    rois = synth::PhotometricResidual(dataset, frame1, frame2, boxes);
    matches = synth::MatchErrorsAgainstTruth(dataset, frame1, frame2, points1, points2);
  } catch (const InputError& e) {
    err << "hdabench imagery pair: " << e.what() << "\n";
    made_here.Remove();
    return kExitInput;
  }

  std::vector<std::vector<std::string>> table = {
      {"roi", "pixels", "spread", "residual", "noise", "view", "ratio", "note"}};
  std::vector<double> ratios, residuals, explained;
  std::ostringstream csv;
  csv << "id,x,y,w,h,pixels,hidden,spread_dn,gain,offset_dn,residual_rms_dn,noise_rms_dn,view_rms_dn,"
         "explained_rms_dn,ratio,why\n";
  for (const synth::PhotometricRoi& roi : rois) {
    csv << roi.id << "," << roi.box.x << "," << roi.box.y << "," << roi.box.width << "," << roi.box.height << ","
        << roi.pixels << "," << roi.hidden;
    for (const double v : {roi.spread_dn, roi.gain, roi.offset_dn, roi.residual_rms_dn, roi.noise_rms_dn,
                           roi.view_rms_dn, roi.explained_rms_dn, roi.ratio}) {
      csv << "," << (roi.why.empty() ? util::CsvNumber(v) : std::string());
    }
    csv << "," << roi.why << "\n";
    if (!roi.why.empty()) {
      table.push_back({std::to_string(roi.id), std::to_string(roi.pixels), "-", "-", "-", "-", "-", roi.why});
      continue;
    }
    ratios.push_back(roi.ratio);
    residuals.push_back(roi.residual_rms_dn);
    explained.push_back(roi.explained_rms_dn);
    table.push_back({std::to_string(roi.id), std::to_string(roi.pixels), Cell(roi.spread_dn, 1),
                     Cell(roi.residual_rms_dn, 2), Cell(roi.noise_rms_dn, 2), Cell(roi.view_rms_dn, 2),
                     Cell(roi.ratio, 2), ""});
  }
  out << "Photometric residual at true correspondences, frames " << frame1 << "," << frame2 << " of '"
      << dataset.name << "' (DN; ratio = residual / hypot(noise, view)):\n";
  out << util::FormatTextTable(table, {false, false, false, false, false, false, false, true});
  const auto mean = [](const std::vector<double>& v) {
    double s = 0.0;
    for (const double x : v) s += x;
    return v.empty() ? 0.0 : s / static_cast<double>(v.size());
  };
  std::sort(ratios.begin(), ratios.end());
  const double median_ratio = ratios.empty() ? 0.0 : util::Quantile(ratios, 0.5);
  const double worst_ratio = ratios.empty() ? 0.0 : *std::max_element(ratios.begin(), ratios.end());
  out << "ROIs checked: " << ratios.size() << " of " << rois.size() << "; residual mean "
      << util::FixedText(mean(residuals), 2) << " DN, explained mean " << util::FixedText(mean(explained), 2)
      << " DN; ratio median " << util::FixedText(median_ratio, 2) << ", worst " << util::FixedText(worst_ratio, 2)
      << " (limit " << util::FixedText(args.max_ratio, 2) << " on the median)\n";
  out << "Flight-method matches against truth: " << matches.compared << " of " << matches.matches
      << " with a truth correspondence; robust sigma x " << util::FixedText(matches.robust_sigma_x_px, 4)
      << " px, y " << util::FixedText(matches.robust_sigma_y_px, 4) << " px\n";
  const bool passed = !ratios.empty() && median_ratio <= args.max_ratio;

  if (!out_dir.empty()) {
    Json summary;
    summary["dataset"] = dataset.name;
    summary["frames"] = {frame1, frame2};
    summary["rois"] = rois.size();
    summary["rois_checked"] = ratios.size();
    summary["residual_mean_dn"] = mean(residuals);
    summary["explained_mean_dn"] = mean(explained);
    summary["ratio_median"] = median_ratio;
    summary["ratio_worst"] = worst_ratio;
    summary["max_ratio"] = args.max_ratio;
    summary["matches"] = matches.matches;
    summary["matches_compared"] = matches.compared;
    summary["match_robust_sigma_x_px"] = matches.robust_sigma_x_px;
    summary["match_robust_sigma_y_px"] = matches.robust_sigma_y_px;
    summary["passed"] = passed;
    try {
      util::WriteFileAtomically(std::filesystem::path(out_dir) / "imagery.csv", csv.str());
      util::WriteFileAtomically(std::filesystem::path(out_dir) / "imagery.json", summary.dump(2) + "\n");
    } catch (const std::exception& e) {
      err << "hdabench imagery pair: " << e.what() << "\n";
      return kExitInput;
    }
    out << "wrote imagery.csv and imagery.json to " << out_dir << "\n";
  }
  out << (passed ? "PASS" : "FAIL") << ": the two views agree "
      << (passed ? "within " : "beyond ") << util::FixedText(args.max_ratio, 2)
      << " times what noise and the photometric model explain (median over the ROIs)\n";
  return passed ? kExitOk : kExitCheckFailed;
}

struct ImageryEdgeArgs {
  std::vector<std::string> overrides;
  double max_error = 0.01;
};

int RunImageryEdge(const ImageryEdgeArgs& args, std::ostream& out, std::ostream& err) {
  if (!(args.max_error > 0.0 && std::isfinite(args.max_error))) {
    err << "hdabench imagery edge: --max-error " << util::ShortestText(args.max_error)
        << ": expected a finite number > 0 (a fraction of the step)\n";
    return kExitUsage;
  }
  synth::SynthOptions options;
  options.render.anti_aliasing = synth::RenderOptions::AntiAliasing::kCamera;
  synth::TerrainOptions terrain;
  try {
    for (const std::string& text : args.overrides) {
      const size_t eq = text.find('=');
      if (eq == std::string::npos || text.rfind("render.", 0) != 0) {
        err << "hdabench imagery edge: --set expects render.key=value, got '" << text << "'\n";
        return kExitUsage;
      }
      synth::ApplyOverride(text.substr(0, eq), text.substr(eq + 1), &options, &terrain);
    }
    const std::vector<std::string> invalid = options.render.Validate();
    if (!invalid.empty()) throw InputError("invalid render options: " + JoinMessages(invalid, "; "));
  } catch (const InputError& e) {
    err << "hdabench imagery edge: " << e.what() << "\n";
    return kExitUsage;
  }
  const synth::EdgeSpreadCheck check = synth::CheckEdgeSpread(options.render);
  std::vector<std::vector<std::string>> table = {{"distance_px", "pixels", "measured", "expected", "difference"}};
  for (const synth::EdgeSpreadBin& bin : check.bins) {
    table.push_back({Cell(bin.distance_px, 1), std::to_string(bin.pixels), Cell(bin.measured, 4),
                     Cell(bin.expected, 4), Cell(bin.measured - bin.expected, 4)});
  }
  out << "Edge-spread function of a slanted albedo step (fraction of the step) against the configured "
         "response (aperture "
      << util::FixedText(std::sqrt(options.render.fill_factor), 3) << " px, PSF sigma "
      << util::FixedText(options.render.PsfSigmaPx(), 3) << " px):\n";
  out << util::FormatTextTable(table, {false, false, false, false, false});
  // A profile the check cannot measure (a blur wider than its +-3 px window,
  // an imager that records nothing) fails: it never passes on NaN.
  bool measurable = std::isfinite(check.width_10_90_px) && std::isfinite(check.expected_width_10_90_px);
  for (const synth::EdgeSpreadBin& bin : check.bins) {
    measurable = measurable && std::isfinite(bin.measured) && std::isfinite(bin.expected);
  }
  if (!measurable) {
    out << "10-90 % width not measurable within the +-3 px of the profile (measured "
        << util::ShortestText(check.width_10_90_px) << " px, expected " << util::ShortestText(check.expected_width_10_90_px)
        << " px): FAIL; the check needs a response narrower than that and an image with signal\n";
    return kExitCheckFailed;
  }
  const bool passed = check.max_error <= args.max_error;
  out << "10-90 % width " << util::FixedText(check.width_10_90_px, 3) << " px (expected "
      << util::FixedText(check.expected_width_10_90_px, 3) << "); largest difference "
      << util::FixedText(check.max_error, 4) << " of the step (limit " << util::FixedText(args.max_error, 4)
      << "): " << (passed ? "PASS" : "FAIL") << "\n";
  return passed ? kExitOk : kExitCheckFailed;
}

}  // namespace

std::vector<Command> AddImageryCommands(CLI::App& app) {
  CLI::App* imagery =
      app.add_subcommand("imagery", "Check that synthetic imagery behaves like a camera's (pair, edge)");
  imagery->require_subcommand(1);

  const auto pair_args = std::make_shared<ImageryPairArgs>();
  CLI::App* pair = imagery->add_subcommand(
      "pair",
      "The photometric residual at true correspondences per flight-method ROI, against what noise and\n"
      "the photometric model's view dependence explain, and the matches' error against truth");
  pair->add_option("DATASET", pair_args->dataset_dir, "Synthetic dataset folder (with truth)")->required();
  pair->add_option("--frames", pair_args->frames_text,
                   "Two different frame indices i,j (default: as `run`)");
  pair->add_option("--out", pair_args->out_dir, "Folder for imagery.csv and imagery.json (created if missing)")
      ->required();
  pair->add_option("--max-ratio", pair_args->max_ratio,
                   "Largest median ratio of residual to explained that passes (exit 1 beyond)")
      ->capture_default_str();
  pair->add_flag("--quiet", pair_args->quiet, "No progress lines");

  const auto edge_args = std::make_shared<ImageryEdgeArgs>();
  CLI::App* edge = imagery->add_subcommand(
      "edge",
      "The rendered edge-spread function of a sharp albedo step against the configured pixel\n"
      "response (camera model; render.* options as in `synth --set`)");
  edge->add_option("--set", edge_args->overrides, "render.key=value (repeatable)");
  edge->add_option("--max-error", edge_args->max_error,
                   "Largest difference, as a fraction of the step, that passes (exit 1 beyond)")
      ->capture_default_str();

  return {{pair, [pair_args] { return RunImageryPair(*pair_args, std::cout, std::cerr); }},
          {edge, [edge_args] { return RunImageryEdge(*edge_args, std::cout, std::cerr); }}};
}

}  // namespace hdabench::tools
