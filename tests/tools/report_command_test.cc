// `hdabench report` and the report `run` and `compare` write by default, as a
// person meets it: the page loaded in headless Chromium (screenshot and DOM),
// its per-ROI table and every embedded figure, determinism, a compare folder
// with a failed method, a missing Python, and folders that are not run
// folders. Skipped only when chromium is not installed.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <set>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "datasets/map_preview.h"
#include "reference/flight/flight_outputs.h"
#include "tools/images/codecs.h"
#include "tools/util/files.h"
#include "tools/util/process.h"
#include "tests/support/test_support.h"

namespace {

namespace fs = std::filesystem;

using hdabench::testing_support::CommandResult;
using hdabench::testing_support::CurrentTestName;
using hdabench::testing_support::FreshTestDir;
using hdabench::testing_support::ReadText;

constexpr char kPngSignature[] = "\x89PNG\r\n\x1a\n";

// The small synthetic dataset of these tests: 256 x 256 px, 15 deg field of
// view, 2.4 s collection window (a few seconds to generate). The first test
// process generates it into a staging folder renamed into place; the others
// reuse it. The name carries the binary's time stamp.
const fs::path& Dataset() {
  static const fs::path dir = hdabench::testing_support::CachedDataset(
      HDABENCH_TEST_TMP, "report_dataset", [](const fs::path& out) {
        const CommandResult synth = hdabench::testing_support::RunHdabench(
            {"synth", "--out", out.string(), "--image-size", "256", "--seed", "3", "--set",
             "horizontal_fov_deg=15", "--set", "collection_s=2.4", "--quiet"},
            out.parent_path());
        EXPECT_EQ(synth.exit_code, 0) << synth.out << synth.err;
      });
  return dir;
}

CommandResult Hdabench(const std::vector<std::string>& args, const std::vector<std::string>& env = {}) {
  const fs::path scratch = fs::path(HDABENCH_TEST_TMP) / (CurrentTestName() + ".cli");
  fs::create_directories(scratch);
  return hdabench::testing_support::RunHdabench(args, scratch, env);
}

std::string Chromium() { return hdabench::util::FindExecutable("chromium"); }

#define SKIP_WITHOUT_CHROMIUM()                                                                \
  if (Chromium().empty()) {                                                                    \
    GTEST_SKIP() << "chromium is not installed (Debian package chromium, listed in "           \
                    "tools/debian-packages.txt): the report cannot be rendered";               \
  }

// Runs headless Chromium on `page` with `flag` (--dump-dom, --screenshot=FILE)
// through the bench's process runner (60 s limit); returns its standard
// output (its standard error is dropped).
std::string RunChromium(const fs::path& page, const std::string& flag, const fs::path& work) {
  const fs::path out = work / (flag == "--dump-dom" ? "chromium-dom.html" : "chromium-screenshot.out");
  fs::remove(out);
  std::string command = "exec " + hdabench::testing_support::ShellQuote(Chromium());
  for (const std::string& arg :
       {std::string("--headless"), std::string("--no-sandbox"), std::string("--disable-gpu"),
        std::string("--hide-scrollbars"), "--user-data-dir=" + (work / "chromium-profile").string(),
        std::string("--window-size=1400,3000"), flag, "file://" + fs::absolute(page).string()}) {
    command += " " + hdabench::testing_support::ShellQuote(arg);
  }
  command += " 2>/dev/null";
  hdabench::util::ProcessOptions options;
  options.log_file = out.string();
  options.timeout_s = 60.0;
  const hdabench::util::ProcessResult result =
      hdabench::util::RunProcess({"/bin/sh", "-c", command}, options);
  EXPECT_TRUE(result.Ok()) << "chromium " << flag << ": " << result.error;
  return ReadText(out);
}

std::string Base64Decode(const std::string& text) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  std::string out;
  std::uint32_t buffer = 0;
  int bits = 0;
  for (const char c : text) {
    if (c == '=') break;
    const int v = value(c);
    if (v < 0) return "";  // not base64
    buffer = (buffer << 6) | static_cast<std::uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((buffer >> bits) & 0xffu);
    }
  }
  return out;
}

// Width and height from a PNG's IHDR; 0 x 0 when the bytes are no PNG.
std::pair<std::uint32_t, std::uint32_t> PngSize(const std::string& png) {
  if (png.size() < 24 || png.compare(0, 8, kPngSignature, 8) != 0 || png.compare(12, 4, "IHDR") != 0) {
    return {0, 0};
  }
  auto be32 = [&png](size_t at) {
    std::uint32_t v = 0;
    for (size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(png[at + i]);
    return v;
  };
  return {be32(16), be32(20)};
}

// What the test reads from the rendered DOM.
struct Dom {
  std::vector<std::string> images;       // decoded bytes of each <img> data: URI
  int non_data_images = 0;               // <img> elements whose src is not a data: URI
  std::set<std::string> figure_ids;      // id of every <figure>
  int roi_table_rows = -1;               // <tr> in the tbody of #roi-table; -1: no table
  int roi_table_columns = -1;            // <th> in its header
  std::string text;                      // the whole DOM
};

// Each <figure> of a page: its id, the size of its embedded PNG (0 x 0 when
// the figure has no data: image), its caption. Read within the figure's own
// element, so a figure without an image never takes the next one's.
struct EmbeddedFigure {
  std::string id;
  std::pair<std::uint32_t, std::uint32_t> size;
  std::string caption;
};

std::vector<EmbeddedFigure> EmbeddedFigures(const std::string& html) {
  std::vector<EmbeddedFigure> figures;
  const std::string prefix = "src=\"data:image/png;base64,";
  for (size_t at = html.find("<figure id=\""); at != std::string::npos; at = html.find("<figure id=\"", at + 1)) {
    const size_t end = html.find("</figure>", at);
    const std::string element = html.substr(at, end == std::string::npos ? std::string::npos : end - at);
    EmbeddedFigure figure;
    figure.id = element.substr(12, element.find('"', 12) - 12);
    const size_t src = element.find(prefix);
    if (src != std::string::npos) {
      const size_t begin = src + prefix.size();
      figure.size = PngSize(Base64Decode(element.substr(begin, element.find('"', begin) - begin)));
    }
    const size_t caption = element.find("<figcaption>");
    if (caption != std::string::npos) figure.caption = element.substr(caption);
    figures.push_back(figure);
  }
  return figures;
}

Dom ParseDom(const std::string& dom) {
  Dom parsed;
  parsed.text = dom;
  for (size_t at = dom.find("<img"); at != std::string::npos; at = dom.find("<img", at + 4)) {
    const size_t end = dom.find('>', at);
    const std::string tag = dom.substr(at, end - at);
    const std::string prefix = "src=\"data:image/png;base64,";
    const size_t src = tag.find(prefix);
    if (src == std::string::npos) {
      ++parsed.non_data_images;
      continue;
    }
    const size_t begin = src + prefix.size();
    parsed.images.push_back(Base64Decode(tag.substr(begin, tag.find('"', begin) - begin)));
  }
  for (const EmbeddedFigure& figure : EmbeddedFigures(dom)) parsed.figure_ids.insert(figure.id);
  const size_t table = dom.find("<table id=\"roi-table\">");
  if (table != std::string::npos) {
    const size_t table_end = dom.find("</table>", table);
    const size_t body = dom.find("<tbody>", table);
    const size_t head_end = dom.find("</thead>", table);
    parsed.roi_table_rows = 0;
    parsed.roi_table_columns = 0;
    for (size_t at = dom.find("<tr", body); at < table_end; at = dom.find("<tr", at + 3)) {
      ++parsed.roi_table_rows;
    }
    for (size_t at = dom.find("<th", table); at < head_end; at = dom.find("<th", at + 3)) {
      if (dom.compare(at, 7, "<thead>") != 0) ++parsed.roi_table_columns;
    }
  }
  return parsed;
}

// Renders the report: a screenshot saved in the test's folder and copied to
// a folder that outlives the test (the path is printed), and the DOM.
Dom Render(const fs::path& html, const fs::path& test_dir) {
  const fs::path screenshot = test_dir / "report_screenshot.png";
  RunChromium(html, "--screenshot=" + screenshot.string(), test_dir);
  const std::string shot = ReadText(screenshot);
  const auto size = PngSize(shot);
  EXPECT_EQ(size.first, 1400u) << screenshot;
  EXPECT_EQ(size.second, 3000u) << screenshot;
  const fs::path kept = fs::path(HDABENCH_TEST_TMP) / "report_screenshots" / (CurrentTestName() + ".png");
  fs::create_directories(kept.parent_path());
  fs::copy_file(screenshot, kept, fs::copy_options::overwrite_existing);
  std::cout << "report screenshot: " << screenshot << " (copy kept: " << kept << ")\n";
  ::testing::Test::RecordProperty("screenshot", kept.string());
  return ParseDom(RunChromium(html, "--dump-dom", test_dir));
}

// Every <img> is a data: URI that decodes to a PNG of non-zero size.
void ExpectEveryImageIsAnEmbeddedPng(const Dom& dom) {
  EXPECT_EQ(dom.non_data_images, 0);
  for (size_t i = 0; i < dom.images.size(); ++i) {
    const auto size = PngSize(dom.images[i]);
    EXPECT_GT(size.first, 0u) << "image " << i;
    EXPECT_GT(size.second, 0u) << "image " << i;
  }
}

// The ids of the flight figures a run folder's figures/ holds.
std::set<std::string> FlightFigureIds(const fs::path& figures) {
  std::set<std::string> ids = {"fig-quadtree", "fig-matches"};
  for (const auto& entry : fs::directory_iterator(figures / "roi_pairs")) {
    ids.insert("fig-" + entry.path().stem().string());
  }
  return ids;
}

// The figure count from "report: DIR/report.html (N figures, ...".
int FiguresPrinted(const std::string& out) {
  const size_t at = out.find("report.html (");
  if (at == std::string::npos) return -1;
  return std::stoi(out.substr(at + 13));
}

TEST(ReportCommand, RunFolderRendersInChromiumWithTheTableAndEveryFigure) {
  SKIP_WITHOUT_CHROMIUM();
  const fs::path dir = FreshTestDir();
  const CommandResult run = Hdabench({"run", Dataset().string(), "--out", (dir / "run").string(), "--quiet"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_EQ(run.err, "");
  ASSERT_TRUE(fs::is_regular_file(dir / "run" / "report.html")) << run.out;
  ASSERT_TRUE(fs::is_regular_file(dir / "run" / "report.md"));

  const nlohmann::json result = nlohmann::json::parse(ReadText(dir / "run" / "result.json"));
  bool any_fit_with_truth = false;
  for (const nlohmann::json& roi : result["rois"]) {
    any_fit_with_truth |= roi["fit"].is_object() && roi["truth"]["available"] == true;
  }
  std::set<std::string> expected = FlightFigureIds(dir / "run" / "figures");
  expected.insert({"plot-stage_timings", "map-elevation", "map-slope", "map-hazards"});
  if (any_fit_with_truth) {
    expected.insert({"plot-slope_scatter", "plot-slope_error_histogram", "plot-error_vs_points"});
  }

  const Dom dom = Render(dir / "run" / "report.html", dir);
  EXPECT_EQ(dom.roi_table_rows, static_cast<int>(result["rois"].size()));
  EXPECT_EQ(dom.roi_table_columns, 10);
  for (const std::string& id : expected) EXPECT_EQ(dom.figure_ids.count(id), 1u) << id;
  EXPECT_EQ(dom.images.size(), dom.figure_ids.size());
  EXPECT_EQ(static_cast<int>(dom.images.size()), FiguresPrinted(run.out)) << run.out;
  EXPECT_GE(dom.images.size(), expected.size());
  ExpectEveryImageIsAnEmbeddedPng(dom);
  EXPECT_EQ(dom.text.find("id=\"plots-error\""), std::string::npos);
  EXPECT_NE(ReadText(dir / "run" / "report.md").find("# Flight run of "), std::string::npos);
}

TEST(ReportCommand, CompareFolderWithAFailedMethodRendersAndShowsTheFailure) {
  SKIP_WITHOUT_CHROMIUM();
  const fs::path dir = FreshTestDir();
  const fs::path out = dir / "compare";
  const CommandResult compare = Hdabench({"compare", Dataset().string(), "--out", out.string(),
                                          "--colmap", "/nonexistent/colmap", "--quiet"});
  // The colmap methods fail (exit code 4, as without a report); the report is written.
  ASSERT_EQ(compare.exit_code, 4) << compare.out << compare.err;
  ASSERT_TRUE(fs::is_regular_file(out / "report.html")) << compare.out << compare.err;
  EXPECT_EQ(compare.err.find("warning"), std::string::npos) << compare.err;

  const nlohmann::json json = nlohmann::json::parse(ReadText(out / "compare.json"));
  std::vector<std::string> failed;
  for (const nlohmann::json& m : json["methods"]) {
    if (m["ok"] == false) failed.push_back(m["name"]);
  }
  ASSERT_FALSE(failed.empty());

  std::set<std::string> expected = FlightFigureIds(out / "flight" / "figures");
  expected.insert({"plot-stage_timings", "plot-method_timings", "map-elevation", "map-slope"});
  const Dom dom = Render(out / "report.html", dir);
  EXPECT_EQ(dom.roi_table_rows, static_cast<int>(json["rois"].size()));
  EXPECT_EQ(dom.roi_table_columns, 2 + static_cast<int>(json["methods"].size()));
  for (const std::string& id : expected) EXPECT_EQ(dom.figure_ids.count(id), 1u) << id;
  EXPECT_EQ(dom.images.size(), dom.figure_ids.size());
  EXPECT_EQ(static_cast<int>(dom.images.size()), FiguresPrinted(compare.out)) << compare.out;
  ExpectEveryImageIsAnEmbeddedPng(dom);
  // The failure is shown: the failures box names each failed method and the
  // method table and the ROI cells say "failed".
  const size_t box = dom.text.find("id=\"failures\"");
  ASSERT_NE(box, std::string::npos);
  for (const std::string& name : failed) {
    EXPECT_NE(dom.text.find("<li>" + name + ": ", box), std::string::npos) << name;
  }
  EXPECT_NE(dom.text.find("class=\"st-failed\""), std::string::npos);
  EXPECT_NE(dom.text.find("- (failed)"), std::string::npos);
  EXPECT_NE(ReadText(out / "report.md").find("## Failed methods"), std::string::npos);
}

// The README's main command on the built-in default (`hdabench demo`: the
// default novac-lateral scene, every method compared), with a 256 x 256
// imager (the whole job at 1024 x 1024 takes over 100 s; the gate runs the
// default scene at full size): its report renders with the per-ROI table of
// every method and every figure, including the method plots (the scene has
// ROIs with a fit and truth) and the scene's maps.
TEST(ReportCommand, TheDefaultDatasetsReportRendersWithTheTableAndEveryFigure) {
  SKIP_WITHOUT_CHROMIUM();
  const fs::path dir = FreshTestDir();
  const CommandResult demo = Hdabench({"demo", "--out", (dir / "demo").string(), "--image-size", "256"});
  // 0, or 4 when a method failed for the run: either way the report is written.
  ASSERT_TRUE(demo.exit_code == 0 || demo.exit_code == 4) << demo.out << demo.err;
  const fs::path out = dir / "demo" / "compare";
  ASSERT_TRUE(fs::is_regular_file(out / "report.html")) << demo.out << demo.err;
  const nlohmann::json json = nlohmann::json::parse(ReadText(out / "compare.json"));
  EXPECT_EQ(json["dataset"], "novac-lateral-cratered-seed1");
  EXPECT_EQ(json["image_size_px"], nlohmann::json::array({256, 256}));

  std::set<std::string> expected = FlightFigureIds(out / "flight" / "figures");
  expected.insert({"plot-stage_timings", "plot-method_timings", "plot-slope_scatter",
                   "plot-slope_error_histogram", "plot-error_vs_points", "map-elevation",
                   "map-slope", "map-hazards"});
  const Dom dom = Render(out / "report.html", dir);
  EXPECT_EQ(dom.roi_table_rows, static_cast<int>(json["rois"].size()));
  EXPECT_EQ(dom.roi_table_columns, 2 + static_cast<int>(json["methods"].size()));
  EXPECT_EQ(json["methods"].size(), 11u);
  for (const std::string& id : expected) EXPECT_EQ(dom.figure_ids.count(id), 1u) << id;
  EXPECT_EQ(dom.images.size(), dom.figure_ids.size());
  ExpectEveryImageIsAnEmbeddedPng(dom);
  EXPECT_EQ(dom.text.find("id=\"plots-error\""), std::string::npos);
}

TEST(ReportCommand, TheSameFolderGivesTheSameBytes) {
  const fs::path dir = FreshTestDir();
  const fs::path out = dir / "run";
  const CommandResult run = Hdabench({"run", Dataset().string(), "--out", out.string(), "--quiet"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const std::string html = ReadText(out / "report.html");
  const std::string md = ReadText(out / "report.md");
  ASSERT_FALSE(html.empty());
  // Again, by hand, with the same dataset: byte for byte the same.
  const CommandResult again = Hdabench({"report", out.string(), "--dataset", Dataset().string()});
  ASSERT_EQ(again.exit_code, 0) << again.out << again.err;
  EXPECT_TRUE(ReadText(out / "report.html") == html) << "report.html differs";
  EXPECT_EQ(ReadText(out / "report.md"), md);
  // And when no thread can be had for the plots (HDABENCH_FAULT_NO_THREAD
  // stands for a process at its thread limit), they are drawn after the rest
  // of the page: the same bytes.
  const CommandResult threadless = Hdabench({"report", out.string(), "--dataset", Dataset().string()},
                                            {"HDABENCH_FAULT_NO_THREAD=report plots"});
  ASSERT_EQ(threadless.exit_code, 0) << threadless.out << threadless.err;
  EXPECT_TRUE(ReadText(out / "report.html") == html) << "report.html differs without a thread for the plots";
  EXPECT_EQ(ReadText(out / "report.md"), md);
  // No temporary file is left beside them.
  for (const auto& entry : fs::directory_iterator(out)) {
    const std::string name = entry.path().filename().string();
    EXPECT_TRUE(name.rfind("report.", 0) != 0 || name == "report.html" || name == "report.md") << name;
  }
}

// The scene maps a report embeds come from the previews beside them when
// they are there and of the right size, and are made from the maps otherwise:
// the same page either way.
TEST(ReportCommand, MapPreviewsGiveTheSamePageAsTheMapsThemselves) {
  const fs::path dir = FreshTestDir();
  const fs::path dataset = dir / "dataset";
  fs::copy(Dataset(), dataset, fs::copy_options::recursive);
  // Maps larger than a preview (the small scene's own may not be).
  fs::remove_all(dataset / "maps");
  fs::create_directories(dataset / "maps" / hdabench::datasets::kMapPreviewFolder);
  for (const char* name : {"elevation.png", "slope.png", "hazards.png"}) {
    cv::Mat map(1300, 1700, CV_8UC3);
    cv::randu(map, 0, 256);
    ASSERT_TRUE(hdabench::images::Write((dataset / "maps" / name).string(), map));
    hdabench::util::WriteFileAtomically(dataset / "maps" / hdabench::datasets::kMapPreviewFolder / name,
                                        hdabench::datasets::PreviewPng(map, hdabench::datasets::kMapPreviewSidePx));
  }
  const fs::path out = dir / "run";
  const CommandResult run = Hdabench({"run", dataset.string(), "--out", out.string(), "--no-figures", "--quiet"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const std::string with_previews = ReadText(out / "report.html");
  EXPECT_NE(with_previews.find("id=\"map-slope\""), std::string::npos);
  EXPECT_NE(with_previews.find("shrunk from 1700 x 1300 px"), std::string::npos);
  // A preview of another size is not taken; no previews at all: made from the maps.
  const fs::path slope_preview = dataset / "maps" / hdabench::datasets::kMapPreviewFolder / "slope.png";
  cv::Mat other(100, 100, CV_8UC3, cv::Scalar(1, 2, 3));
  ASSERT_TRUE(hdabench::images::Write(slope_preview.string(), other));
  CommandResult again = Hdabench({"report", out.string(), "--dataset", dataset.string()});
  ASSERT_EQ(again.exit_code, 0) << again.out << again.err;
  EXPECT_TRUE(ReadText(out / "report.html") == with_previews) << "a wrong-size preview changed the page";
  fs::remove_all(dataset / "maps" / hdabench::datasets::kMapPreviewFolder);
  again = Hdabench({"report", out.string(), "--dataset", dataset.string()});
  ASSERT_EQ(again.exit_code, 0) << again.out << again.err;
  EXPECT_TRUE(ReadText(out / "report.html") == with_previews) << "the page without previews differs";
}

// The figures a run draws are no larger than the page shows them (its width;
// in the grids of the ROI pairs and the maps, also the grid's height), so the
// report embeds them as drawn. Larger figures (an older run's) and the maps
// are embedded shrunk to that size, saying so.
TEST(ReportCommand, EveryFigureIsEmbeddedAtTheSizeThePageShowsIt) {
  using hdabench::reference::kFigureGridHeightPx;
  using hdabench::reference::kFigureShownWidthPx;
  const fs::path dir = FreshTestDir();
  const fs::path dataset = dir / "dataset";
  fs::copy(Dataset(), dataset, fs::copy_options::recursive);
  fs::remove_all(dataset / "maps" / hdabench::datasets::kMapPreviewFolder);
  cv::Mat map(1300, 1700, CV_8UC3);
  cv::randu(map, 0, 256);
  ASSERT_TRUE(hdabench::images::Write((dataset / "maps" / "slope.png").string(), map));
  const fs::path out = dir / "run";
  const CommandResult run = Hdabench({"run", dataset.string(), "--out", out.string(), "--quiet"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const auto fits = [&](const EmbeddedFigure& figure) {
    // The landing decisions and the safety map beside them share the page's width.
    const bool beside = figure.id == "fig-decision" || figure.id == "map-safety-beside-decisions";
    if (beside) {
      EXPECT_LE(figure.size.first, static_cast<std::uint32_t>(hdabench::reference::kFigureHalfWidthPx));
    }
    const bool in_grid = !beside && (figure.id.rfind("fig-roi_", 0) == 0 || figure.id.rfind("map-", 0) == 0);
    EXPECT_GT(figure.size.first, 0u) << figure.id;
    EXPECT_LE(figure.size.first, static_cast<std::uint32_t>(kFigureShownWidthPx)) << figure.id;
    if (in_grid) {
      EXPECT_LE(figure.size.second, static_cast<std::uint32_t>(kFigureGridHeightPx)) << figure.id;
    }
  };
  const std::vector<EmbeddedFigure> as_drawn = EmbeddedFigures(ReadText(out / "report.html"));
  int roi_pairs = 0;
  for (const EmbeddedFigure& figure : as_drawn) {
    fits(figure);
    if (figure.id == "map-slope") {
      EXPECT_NE(figure.caption.find("shrunk from 1700 x 1300 px"), std::string::npos) << figure.caption;
      EXPECT_NEAR(figure.size.first, 1700.0 * kFigureGridHeightPx / 1300, 1.0);
      EXPECT_NEAR(figure.size.second, kFigureGridHeightPx, 1.0);
    } else if (figure.id.rfind("map-", 0) != 0) {
      EXPECT_EQ(figure.caption.find("shrunk"), std::string::npos) << figure.id << ": " << figure.caption;
    }
    if (figure.id.rfind("fig-roi_", 0) == 0) {
      ++roi_pairs;
      // Its title is not shortened at this size: the figure is the grid's height.
      EXPECT_EQ(figure.size.second, static_cast<std::uint32_t>(kFigureGridHeightPx)) << figure.id;
    }
  }
  EXPECT_GT(roi_pairs, 0);

  // An older run's larger figures: embedded shrunk, the figure files as they were.
  cv::Mat wide(1020, 2048, CV_8UC3), tall(700, 600, CV_8UC3);
  cv::randu(wide, 0, 256);
  cv::randu(tall, 0, 256);
  ASSERT_TRUE(hdabench::images::Write((out / "figures" / "matches.png").string(), wide));
  fs::path pair;
  for (const auto& entry : fs::directory_iterator(out / "figures" / "roi_pairs")) pair = entry.path();
  ASSERT_TRUE(hdabench::images::Write(pair.string(), tall));
  const CommandResult report = Hdabench({"report", out.string(), "--dataset", dataset.string(), "--quiet"});
  ASSERT_EQ(report.exit_code, 0) << report.out << report.err;
  bool saw_matches = false, saw_pair = false;
  for (const EmbeddedFigure& figure : EmbeddedFigures(ReadText(out / "report.html"))) {
    fits(figure);
    if (figure.id == "fig-matches") {
      saw_matches = true;
      EXPECT_EQ(figure.size.first, static_cast<std::uint32_t>(kFigureShownWidthPx));
      EXPECT_NEAR(figure.size.second, 1020.0 * kFigureShownWidthPx / 2048, 1.0);
      EXPECT_NE(figure.caption.find("(shrunk from 2048 x 1020 px)"), std::string::npos) << figure.caption;
    }
    if (figure.id == "fig-" + pair.stem().string()) {
      saw_pair = true;
      EXPECT_NEAR(figure.size.second, kFigureGridHeightPx, 1.0);
      EXPECT_NE(figure.caption.find("(shrunk from 600 x 700 px)"), std::string::npos) << figure.caption;
    }
  }
  EXPECT_TRUE(saw_matches && saw_pair);
  EXPECT_EQ(hdabench::images::Read((out / "figures" / "matches.png").string(), cv::IMREAD_COLOR).cols, 2048);
}

TEST(ReportCommand, AFolderThatIsNeitherARunNorACompareFolderIsExitCode3) {
  const fs::path dir = FreshTestDir();
  fs::create_directories(dir / "empty");
  const CommandResult empty = Hdabench({"report", (dir / "empty").string()});
  EXPECT_EQ(empty.exit_code, 3) << empty.out << empty.err;
  EXPECT_NE(empty.err.find((dir / "empty").string() + ": neither a run folder (result.json"),
            std::string::npos)
      << empty.err;
  EXPECT_FALSE(fs::exists(dir / "empty" / "report.html"));

  const CommandResult missing = Hdabench({"report", (dir / "missing").string()});
  EXPECT_EQ(missing.exit_code, 3) << missing.err;
  EXPECT_NE(missing.err.find("no such folder"), std::string::npos) << missing.err;

  fs::create_directories(dir / "broken");
  hdabench::testing_support::WriteText(dir / "broken" / "result.json", "{\"format\": ");
  const CommandResult broken = Hdabench({"report", (dir / "broken").string()});
  EXPECT_EQ(broken.exit_code, 3) << broken.err;
  EXPECT_NE(broken.err.find((dir / "broken" / "result.json").string() + ": not valid JSON"),
            std::string::npos)
      << broken.err;

  const CommandResult no_dataset =
      Hdabench({"report", (dir / "empty").string(), "--dataset", (dir / "nowhere").string()});
  EXPECT_EQ(no_dataset.exit_code, 3) << no_dataset.err;
}

// A record whose values the report reads are of another kind than its
// format's (a string for a slope, an unknown status, an ROI that is no
// object) is refused with exit code 3, naming the file, the ROI and the key,
// and no page is written; a key that is absent (a record written before it
// existed) still gives a page, with "-" for it.
TEST(ReportCommand, ADamagedRecordIsExitCode3NamingTheRoiAndTheKey) {
  const fs::path dir = FreshTestDir();
  CommandResult made = Hdabench(
      {"run", Dataset().string(), "--out", (dir / "run").string(), "--no-figures", "--no-report", "--quiet"});
  ASSERT_EQ(made.exit_code, 0) << made.err;
  made = Hdabench({"compare", Dataset().string(), "--methods", "flight,dense-nav", "--out",
                   (dir / "compare").string(), "--no-figures", "--no-report", "--quiet"});
  ASSERT_EQ(made.exit_code, 0) << made.err;
  const nlohmann::json run = nlohmann::json::parse(ReadText(dir / "run" / "result.json"));
  const nlohmann::json compare = nlohmann::json::parse(ReadText(dir / "compare" / "compare.json"));
  ASSERT_GE(run["rois"].size(), 2u);
  ASSERT_GE(compare["rois"].size(), 2u);
  const int second_id = run["rois"][1]["id"].get<int>();

  int made_folders = 0;
  // Writes `record` as `file` into a fresh folder and runs the report on it.
  const auto report_of = [&](const nlohmann::json& record, const std::string& file) {
    const fs::path folder = dir / ("case" + std::to_string(made_folders++));
    fs::create_directories(folder);
    hdabench::testing_support::WriteText(folder / file, record.dump(1));
    const CommandResult result = Hdabench({"report", folder.string(), "--dataset", Dataset().string()});
    return std::make_pair(folder, result);
  };
  const auto expect_refused = [&](const nlohmann::json& record, const std::string& file,
                                  const std::string& message) {
    const auto [folder, result] = report_of(record, file);
    EXPECT_EQ(result.exit_code, 3) << message << ": " << result.out << result.err;
    EXPECT_NE(result.err.find((folder / file).string() + ": " + message), std::string::npos) << result.err;
    EXPECT_FALSE(fs::exists(folder / "report.html")) << message;
    EXPECT_FALSE(fs::exists(folder / "report.md")) << message;
  };

  nlohmann::json damaged = run;
  damaged["rois"][1]["fit"] = {{"slope_deg", "abc"}};
  expect_refused(damaged, "result.json",
                 "rois[1] (ROI " + std::to_string(second_id) + "), key \"fit\", key \"slope_deg\": expected a finite "
                 "number, found \"abc\"");
  damaged = run;
  damaged["rois"][1]["status"] = "bogus";
  expect_refused(damaged, "result.json",
                 "rois[1] (ROI " + std::to_string(second_id) + "), key \"status\": expected one of \"evaluated\"");
  damaged = run;
  damaged["rois"][0] = 7;
  expect_refused(damaged, "result.json", "rois[0]: expected an object, found 7");
  damaged = run;
  damaged["frames"] = {0, "x"};
  expect_refused(damaged, "result.json", "key \"frames\", element 1: expected an integer, found \"x\"");

  damaged = compare;
  damaged["rois"][1]["methods"]["dense-nav"]["num_points"] = 2.5;
  expect_refused(damaged, "compare.json",
                 "rois[1] (ROI " + compare["rois"][1]["id"].dump() +
                     "), method \"dense-nav\", key \"num_points\": expected an integer, found 2.5");
  damaged = compare;
  damaged["methods"][0]["slope_error_vs_truth_deg"] = {{"median", "x"}};
  expect_refused(damaged, "compare.json",
                 "methods[0], key \"slope_error_vs_truth_deg\", key \"median\": expected a finite number");

  damaged = compare;
  damaged["rois"][0]["methods"]["unlisted"] = {{"status", "ok"}, {"slope_deg", 3.0}, {"num_points", "abc"}};
  expect_refused(damaged, "compare.json",
                 "rois[0] (ROI " + compare["rois"][0]["id"].dump() +
                     "), method \"unlisted\", key \"num_points\": expected an integer, found \"abc\"");
  {
    const auto [folder, result] = report_of(compare, "compare.json");
    ASSERT_EQ(result.exit_code, 0) << result.err;
    hdabench::testing_support::WriteText(folder / "compare_timings.json",
                                         R"({"format": "hdabench-compare-timings", "format_version": 1, )"
                                         R"("methods": [{"name": "flight", "seconds": "slow"}]})");
    fs::remove(folder / "report.html");
    const CommandResult timed = Hdabench({"report", folder.string(), "--dataset", Dataset().string()});
    EXPECT_EQ(timed.exit_code, 3) << timed.err;
    EXPECT_NE(timed.err.find((folder / "compare_timings.json").string() +
                             ": key \"methods\", element 0, key \"seconds\": expected a finite number"),
              std::string::npos)
        << timed.err;
    EXPECT_FALSE(fs::exists(folder / "report.html"));
  }

  // Absent and null keys and the undamaged records: pages.
  nlohmann::json older = run;
  for (auto& roi : older["rois"]) roi.erase("tilt_error_deg");
  older["rois"][1].erase("fit");
  auto [older_folder, older_result] = report_of(older, "result.json");
  EXPECT_EQ(older_result.exit_code, 0) << older_result.err;
  EXPECT_TRUE(fs::is_regular_file(older_folder / "report.html"));
  nlohmann::json without_count = compare;
  without_count["min_points_for_stats"] = nullptr;
  auto [count_folder, count_result] = report_of(without_count, "compare.json");
  EXPECT_EQ(count_result.exit_code, 0) << count_result.err;
  EXPECT_NE(ReadText(count_folder / "report.md").find("at least 20 points"), std::string::npos);
  for (const auto& [record, file] : {std::make_pair(run, std::string("result.json")),
                                     std::make_pair(compare, std::string("compare.json"))}) {
    const auto [folder, result] = report_of(record, file);
    EXPECT_EQ(result.exit_code, 0) << file << ": " << result.err;
    EXPECT_TRUE(fs::is_regular_file(folder / "report.html")) << file;
  }
}

TEST(ReportCommand, WithoutPythonTheReportIsWrittenWithTheReasonAndExitCode4) {
  const fs::path dir = FreshTestDir();
  const fs::path out = dir / "run";
  const CommandResult run =
      Hdabench({"run", Dataset().string(), "--out", out.string(), "--quiet", "--no-report"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_FALSE(fs::exists(out / "report.html"));  // --no-report

  // The dataset is not beside the run folder: a note, not an error.
  const CommandResult report = Hdabench({"report", out.string(), "--python", "/nonexistent/python3"});
  EXPECT_EQ(report.exit_code, 4) << report.out << report.err;
  EXPECT_NE(report.err.find("'/nonexistent/python3' was not found"), std::string::npos) << report.err;
  const std::string html = ReadText(out / "report.html");
  ASSERT_FALSE(html.empty());
  EXPECT_NE(html.find("id=\"plots-error\""), std::string::npos);
  EXPECT_NE(html.find("/nonexistent/python3"), std::string::npos);
  EXPECT_NE(html.find("was not found beside the run folder"), std::string::npos);
  EXPECT_EQ(html.find("id=\"plot-"), std::string::npos);
  EXPECT_EQ(html.find("id=\"map-"), std::string::npos);
  EXPECT_NE(html.find("id=\"fig-quadtree\""), std::string::npos);
  EXPECT_NE(html.find("<table id=\"roi-table\">"), std::string::npos);

  // A Python that cannot import matplotlib (Debian's, without its site
  // packages): the message names matplotlib and the package to install.
  const fs::path bare_python = dir / "python-without-site";
  hdabench::testing_support::WriteText(bare_python, "#!/bin/sh\nexec /usr/bin/python3 -S \"$@\"\n");
  fs::permissions(bare_python, fs::perms::owner_all);
  const CommandResult bare = Hdabench({"report", out.string(), "--python", bare_python.string()});
  EXPECT_EQ(bare.exit_code, 4) << bare.out << bare.err;
  EXPECT_NE(bare.err.find("matplotlib and numpy are needed"), std::string::npos) << bare.err;
  EXPECT_NE(bare.err.find("python3-matplotlib"), std::string::npos) << bare.err;
  EXPECT_NE(ReadText(out / "report.html").find("matplotlib and numpy are needed"), std::string::npos);
}

}  // namespace
