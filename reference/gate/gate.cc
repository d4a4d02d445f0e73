#include "reference/gate/gate.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <unistd.h>

#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>

#include "tools/util/error.h"
#include "datasets/dataset.h"
#include "tools/util/files.h"
#include "tools/util/options_check.h"
#include "datasets/stereolunar.h"
#include "datasets/synth/terrain.h"
#include "reference/compare/compare.h"
#include "reference/compare/compare_outputs.h"
#include "reference/flight/flight_outputs.h"
#include "tools/util/text.h"
#include "tools/util/parallel_for.h"
#include "tools/util/statistics.h"
#include "reference/report/report.h"

namespace hdabench::reference {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

// ---------------------------------------------------------------------------
// Reading the JSON files

Json ReadJsonFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read the file");
  std::stringstream text;
  text << in.rdbuf();
  try {
    return Json::parse(text.str());
  } catch (const Json::exception& e) {
    throw InputError(path + ": not valid JSON: " + util::JsonErrorText(e.what()));
  }
}

// Checks that `object` has only `allowed` keys; throws naming the first other.
void OnlyKeys(const Json& object, const std::set<std::string>& allowed, const std::string& where) {
  for (const auto& item : object.items()) {
    if (allowed.count(item.key()) == 0) throw InputError(where + ": unknown field '" + item.key() + "'");
  }
}

void CheckFormat(const Json& j, const std::string& name, const std::string& path) {
  if (!j.is_object()) throw InputError(path + ": expected a JSON object");
  if (!j.contains("format") || j["format"] != name) {
    throw InputError(path + ": field 'format' must be \"" + name + "\"");
  }
  if (!j.contains("format_version") || j["format_version"] != kGateFormatVersion) {
    throw InputError(path + ": field 'format_version' must be " + std::to_string(kGateFormatVersion));
  }
}

std::string StringField(const Json& j, const std::string& key, const std::string& where) {
  if (!j.contains(key) || !j[key].is_string()) {
    throw InputError(where + ": field '" + key + "' must be a string");
  }
  return j[key].get<std::string>();
}

double NumberField(const Json& j, const std::string& key, const std::string& where) {
  if (!j[key].is_number() || !std::isfinite(j[key].get<double>())) {
    throw InputError(where + ": field '" + key + "' must be a finite number");
  }
  return j[key].get<double>();
}

bool ValidName(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '.' || c == '_' || c == '-';
  }) && name != "." && name != "..";
}

// A suite's COLMAP options over compare's.
void ApplyColmapOptions(const GateColmapOptions& from, ColmapOptions* to) {
  if (from.max_features) to->sift_max_num_features = *from.max_features;
  if (from.first_octave) to->sift_first_octave = *from.first_octave;
  if (from.octave_resolution) to->sift_octave_resolution = *from.octave_resolution;
  if (from.peak_threshold) to->sift_peak_threshold = *from.peak_threshold;
  if (from.nav_band_px) to->nav_guided_max_error_px = *from.nav_band_px;
}

// A suite's "colmap" object: its fields typed here, their ranges those of
// ColmapOptions::Validate.
GateColmapOptions ReadColmapOptions(const Json& c, const std::string& where) {
  if (!c.is_object()) throw InputError(where + ": expected an object");
  OnlyKeys(c, {"max_features", "first_octave", "octave_resolution", "peak_threshold", "nav_band_px"}, where);
  GateColmapOptions out;
  if (c.contains("max_features")) {
    if (!c["max_features"].is_number_integer() || c["max_features"].get<std::int64_t>() < 10 ||
        c["max_features"].get<std::int64_t>() > 1000000) {
      throw InputError(where + ": field 'max_features' must be an integer in [10, 1000000] (SIFT features "
                               "per image)");
    }
    out.max_features = c["max_features"].get<int>();
  }
  for (const auto& [key, field] : {std::pair{"first_octave", &out.first_octave},
                                   std::pair{"octave_resolution", &out.octave_resolution}}) {
    if (!c.contains(key)) continue;
    if (!c[key].is_number_integer() || std::abs(c[key].get<std::int64_t>()) > 1000) {
      throw InputError(where + ": field '" + key + "' must be an integer");
    }
    *field = c[key].get<int>();
  }
  if (c.contains("peak_threshold")) out.peak_threshold = NumberField(c, "peak_threshold", where);
  if (c.contains("nav_band_px")) out.nav_band_px = NumberField(c, "nav_band_px", where);
  ColmapOptions options;
  ApplyColmapOptions(out, &options);
  ThrowIfInvalid(where + ": ", options.Validate());
  return out;
}

// An observability entry's study ("observability": {...}, docs/gate.md): the
// keys of `hdabench observability`'s flags; the flight method's parameters
// come from the entry's "hda". Lists are JSON lists.
void ReadObservabilityEntry(const Json& o, const std::string& where, GateEntry* e) {
  if (!o.is_object()) throw InputError(where + ": expected an object");
  OnlyKeys(o, {"geometry", "baselines_m", "pixel_noise_px", "points", "trials", "seed", "camera", "altitude_m",
               "downrange_m", "site_size_m", "min_slope_deg", "max_slope_deg", "relief_m", "nav_position_sigma_m",
               "nav_attitude_sigma_deg", "lrf_sigma_m", "requirement_deg"},
           where);
  StudyOptions study;
  const auto numbers = [&](const char* key, std::vector<double>* to) {
    if (!o.contains(key)) return;
    const Json& list = o[key];
    if (!list.is_array() || list.empty()) throw InputError(where + ": field '" + key + "' must be a non-empty list of numbers");
    to->clear();
    for (const Json& v : list) {
      if (!v.is_number()) throw InputError(where + ": field '" + key + "' must be a non-empty list of numbers");
      to->push_back(v.get<double>());
    }
  };
  if (!o.contains("baselines_m")) throw InputError(where + ": field 'baselines_m' is required");
  numbers("baselines_m", &study.baselines_m);
  numbers("pixel_noise_px", &study.pixel_noises_px);
  if (o.contains("geometry")) {
    const Json& list = o["geometry"];
    if (!list.is_array() || list.empty()) throw InputError(where + ": field 'geometry' must be a non-empty list");
    study.geometries.clear();
    for (const Json& g : list) {
      if (!g.is_string()) throw InputError(where + ": field 'geometry' must hold names");
      try {
        study.geometries.push_back(ParseStudyGeometry(g.get<std::string>()));
      } catch (const InputError& ex) {
        throw InputError(where + ": geometry: " + ex.what());
      }
    }
  }
  if (o.contains("points")) {
    std::vector<double> points;
    numbers("points", &points);
    study.points.clear();
    for (const double p : points) {
      if (p != std::floor(p) || p < 3 || p > 1e6) {
        throw InputError(where + ": field 'points' must hold whole numbers in [3, 1000000]");
      }
      study.points.push_back(static_cast<int>(p));
    }
  }
  if (o.contains("trials")) {
    if (!o["trials"].is_number_integer()) throw InputError(where + ": field 'trials' must be an integer");
    study.trials = o["trials"].get<int>();
  }
  if (o.contains("seed")) {
    if (!o["seed"].is_number_unsigned()) throw InputError(where + ": field 'seed' must be an integer >= 0");
    study.seed = o["seed"].get<std::uint64_t>();
  }
  if (o.contains("camera")) e->observability_camera = StringField(o, "camera", where);
  for (const auto& [key, to] : std::vector<std::pair<const char*, double*>>{
           {"altitude_m", &study.altitude_m},
           {"downrange_m", &study.downrange_m},
           {"site_size_m", &study.site_size_m},
           {"min_slope_deg", &study.min_slope_deg},
           {"max_slope_deg", &study.max_slope_deg},
           {"relief_m", &study.relief_sigma_m},
           {"nav_position_sigma_m", &study.nav_position_sigma_m},
           {"nav_attitude_sigma_deg", &study.nav_attitude_sigma_deg},
           {"lrf_sigma_m", &study.lrf_sigma_m},
           {"requirement_deg", &study.requirement_deg}}) {
    if (o.contains(key)) *to = NumberField(o, key, where);
  }
  // Every value but the flight method's (resolved when the entry runs).
  std::vector<std::string> errors = study.Validate();
  errors.erase(std::remove_if(errors.begin(), errors.end(),
                              [](const std::string& m) { return m.rfind("hda: ", 0) == 0; }),
               errors.end());
  if (!errors.empty()) throw InputError(where + ": " + errors.front());
  e->observability = study;
  e->observability_spec = o.dump();
}

// ---------------------------------------------------------------------------
// Metrics

const std::vector<std::string>& MetricNames() {
  static const std::vector<std::string> names = {
      "slope_error_median_deg", "slope_error_p90_deg",   "slope_error_max_deg",
      "tilt_error_median_deg",  "tilt_error_p90_deg",    "slope_bias_abs_deg",
      "roughness_error_median_m", "rois_with_slope_share", "within_two_sigma_share",
      "flight_seconds_per_pair", "failed_entries",        "slope_error_rois",
      "observability_p95_deg",  "observability_median_deg", "observability_sigma_ratio"};
  return names;
}

// Higher is better for these metrics; lower for the others.
bool HigherIsBetter(const std::string& metric) {
  return metric == "rois_with_slope_share" || metric == "within_two_sigma_share" ||
         metric == "slope_error_rois";
}

bool FlightHasSlope(const std::string& status) {
  return status == "evaluated" || status == "unsafe slope" || status == "unsafe roughness";
}

std::string FormatValue(double value) { return util::FixedCell(value, 3); }

// A method's pool as a person reads it: "flight", "flight under lrf-absent".
std::string MethodLabel(const std::string& method, const std::string& fault) {
  return fault.empty() ? method : method + " under " + fault;
}

// ---------------------------------------------------------------------------
// Running entries

std::string Hex(std::uint64_t value) {
  static const char* digits = "0123456789abcdef";
  std::string text(16, '0');
  for (int i = 15; i >= 0; --i, value >>= 4) text[static_cast<size_t>(i)] = digits[value & 15];
  return text;
}

// FNV-1a of the text: names a dataset by what it was made from.
std::uint64_t Fnv1a(const std::string& text) {
  std::uint64_t hash = 1469598103934665603ULL;
  for (const char c : text) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 1099511628211ULL;
  }
  return hash;
}

// The gate measures accuracy without time-budget kick-outs: which ROIs a
// wall-time budget reaches depends on the machine's load (entries run in
// parallel), so the flight method gets an ample budget here and its time is a
// metric of its own (flight_seconds_per_pair). The kick-outs have their own
// tests, with a fake clock.
constexpr double kGateComputeBudgetS = 1.0e6;

// The seed of a fault's random numbers (lrf-noise), as `hdabench faults`'s default.
constexpr std::uint64_t kGateFaultSeed = 1;

// An observability setting whose plane is missing in more than 5 % of the
// trials has no finite p95: it counts as the largest slope error there is.
constexpr double kObservabilityUnjudgedDeg = 90.0;

// What an entry's dataset is made from (its folder name hashes this): the
// source, not the flight method's parameters.
Json EntryDatasetSpecJson(const GateEntry& e) {
  Json j;
  j["name"] = e.name;
  if (e.synth_preset) {
    Json overrides = Json::array();
    for (const auto& [key, value] : e.synth_overrides) overrides.push_back(key + "=" + value);
    j["synth"] = {{"preset", *e.synth_preset}, {"terrain", e.synth_terrain},
                  {"seed", e.synth_seed},      {"image_size", e.synth_image_size_px},
                  {"set", overrides}};
  }
  if (e.dataset_dir) j["dataset"] = *e.dataset_dir;
  if (e.stereolunar_pair_dir) {
    j["stereolunar"] = {{"pair", *e.stereolunar_pair_dir}, {"sun", e.stereolunar_sun}, {"cameras", "npz"}};
  }
  if (e.observability) j["observability"] = Json::parse(e.observability_spec);
  return j;
}

// The entry as read: its dataset's source and its flight-method parameters.
Json EntrySpecJson(const GateEntry& e) {
  Json j = EntryDatasetSpecJson(e);
  const Json given = e.hda.GivenJson();
  // site_size_m alone keeps the record of suites written before "hda".
  if (given.size() == 1 && given.contains("quadtree.site_size_m")) {
    j["site_size_m"] = given["quadtree.site_size_m"];
  } else if (given.empty()) {
    j["site_size_m"] = nullptr;
  } else {
    j["hda"] = given;
  }
  // Only when set, so that the records of entries without them stay as they were.
  if (e.fault) j["fault"] = datasets::FaultLabel(*e.fault);
  if (!e.methods.empty()) j["methods"] = e.methods;
  return j;
}

// The methods compared on an entry: its own, or the suite's.
const std::vector<std::string>& EntryMethods(const GateEntry& e, const GateSuite& suite) {
  return e.methods.empty() ? suite.methods : e.methods;
}

// The settings an entry's results depend on: a complete folder with other
// settings is redone.
std::string EntrySettings(const GateEntry& e, const GateSuite& suite, const GateRunOptions& o) {
  Json j;
  j["format"] = "hdabench-gate-entry";
  j["format_version"] = kGateFormatVersion;
  j["entry"] = EntrySpecJson(e);
  j["methods"] = EntryMethods(e, suite);
  // Only when set, so that the folders of suites without it stay complete.
  if (suite.colmap.max_features) j["colmap_max_features"] = *suite.colmap.max_features;
  if (suite.colmap.first_octave) j["colmap_first_octave"] = *suite.colmap.first_octave;
  if (suite.colmap.octave_resolution) j["colmap_octave_resolution"] = *suite.colmap.octave_resolution;
  if (suite.colmap.peak_threshold) j["colmap_peak_threshold"] = *suite.colmap.peak_threshold;
  if (suite.colmap.nav_band_px) j["colmap_nav_band_px"] = *suite.colmap.nav_band_px;
  j["fault_match_noise_px"] = o.fault_match_noise_px;
  j["flight_compute_budget_s"] = kGateComputeBudgetS;
  j["colmap"] = o.colmap_executable;
  // The program itself: results of another build are not reused.
  std::error_code ec;
  const fs::path program = fs::read_symlink("/proc/self/exe", ec);
  const auto stamp = ec ? 0 : fs::last_write_time(program, ec).time_since_epoch().count();
  j["program"] = {{"path", ec ? "" : program.string()},
                  {"modified", static_cast<std::int64_t>(ec ? 0 : stamp)},
                  {"size", ec ? 0 : static_cast<std::uint64_t>(fs::file_size(program, ec))}};
  return j.dump(1) + "\n";
}

constexpr char kEntryRecord[] = "gate_entry.json";

// The entry whose dataset an entry uses: the first of the suite with the same
// source (an entry under a fault shares the dataset of its clean twin), which
// is the entry itself when no earlier one has its source.
const GateEntry& DatasetOwner(const GateEntry& e, const GateSuite& suite) {
  const auto source = [](const GateEntry& entry) {
    Json j = EntryDatasetSpecJson(entry);
    j.erase("name");
    return j;
  };
  const Json mine = source(e);
  for (const GateEntry& other : suite.entries) {
    if (source(other) == mine) return other;
  }
  return e;
}

// One lock per dataset folder: entries that share a dataset (run in
// parallel) make it once.
std::mutex& DatasetFolderLock(const std::string& folder) {
  static std::mutex guard;
  static std::map<std::string, std::mutex> locks;
  const std::lock_guard<std::mutex> lock(guard);
  return locks[folder];
}

// The dataset folder of an entry (its owner's, DatasetOwner): made if it is
// synthetic (under a temporary name, renamed into place), found otherwise.
std::string EntryDataset(const GateEntry& entry, const GateSuite& suite, const GateRunOptions& o) {
  const GateEntry& e = DatasetOwner(entry, suite);
  const fs::path suite_dir = fs::path(suite.file).parent_path();
  if (e.dataset_dir) return (suite_dir / *e.dataset_dir).lexically_normal().string();
  const fs::path made = fs::path(o.out_dir) / "datasets" /
                        (e.name + "-" + Hex(Fnv1a(EntryDatasetSpecJson(e).dump())).substr(0, 8));
  const std::lock_guard<std::mutex> folder_lock(DatasetFolderLock(made.string()));
  if (fs::exists(made / "manifest.json")) return made.string();
  const fs::path staging = made.string() + ".partial-" + std::to_string(::getpid());
  fs::remove_all(staging);
  fs::create_directories(made.parent_path());
  if (e.synth_preset) {
    datasets::synth::SynthOptions options = datasets::synth::SynthPreset(*e.synth_preset);
    if (!e.synth_terrain.empty()) options.terrain = e.synth_terrain;
    if (e.synth_image_size_px > 0) options.image_size_px = e.synth_image_size_px;
    datasets::synth::TerrainOptions terrain = datasets::synth::TerrainPreset(options.terrain);
    for (const auto& [key, value] : e.synth_overrides) {
      datasets::synth::ApplyOverride(key, value, &options, &terrain);
    }
    datasets::synth::ScaleTerrain(options.terrain_scale, &terrain);
    options.threads = o.synth_threads;
    datasets::WriteDataset(datasets::synth::GenerateSynthDataset(options, terrain, e.synth_seed),
                           staging.string());
  } else {
    const std::string pair_dir = (suite_dir / *e.stereolunar_pair_dir).lexically_normal().string();
    datasets::WriteDataset(datasets::ConvertStereoLunarPair(
                               pair_dir, /*cameras_txt=*/"",
                               e.stereolunar_sun),
                           staging.string());
  }
  std::error_code ec;
  fs::rename(staging, made, ec);
  if (ec) {
    fs::remove_all(staging);
    if (!fs::exists(made / "manifest.json")) {
      throw InputError(made.string() + ": cannot move the new dataset into place: " + ec.message());
    }
  }
  return made.string();
}

// Loading a dataset reads its camera model through libmrcal, whose parser
// messages are captured from stderr: one load at a time.
std::mutex g_load_mutex;

constexpr char kReportPage[] = "report.html";
constexpr char kStudyPage[] = "settings.csv";

// The page of a complete entry folder: an observability study's settings, or
// the comparison's report.
std::string EntryPage(const fs::path& entry_dir) {
  return fs::exists(entry_dir / "study.json") ? kStudyPage : kReportPage;
}

// Stages a folder's files and renames it into place once complete, the
// entry's record written last.
void PlaceEntryFolder(const fs::path& staging, const fs::path& final_dir, const std::string& settings) {
  util::WriteFileAtomically(staging / kEntryRecord, settings);
  fs::remove_all(final_dir);
  fs::rename(staging, final_dir);
}

// An observability entry: the whole study on one thread (entries run in
// parallel), its folder as `hdabench observability --no-figures` writes it.
void RunObservabilityEntry(const GateEntry& e, const GateSuite& suite, const GateRunOptions& o,
                           const std::string& settings, const fs::path& final_dir) {
  StudyOptions study = *e.observability;
  std::optional<calib::CameraModel> camera;
  if (e.observability_camera.empty()) {
    camera = datasets::synth::DefaultSynthCamera(1024, 30.0);
  } else {
    const std::lock_guard<std::mutex> lock(g_load_mutex);
    camera = calib::CameraModel::Load(
        (fs::path(suite.file).parent_path() / e.observability_camera).lexically_normal().string());
  }
  HdaSettings hda = e.hda;
  hda.Set("fault_match_noise_px", o.fault_match_noise_px, "gate");
  ResolveStudyHdaOptions(hda, *camera, &study);
  ThrowIfInvalid("observability: ", study.Validate());
  const util::Shard whole;
  const std::vector<SettingStats> stats = RunStudy(study, *camera, whole, 1, {});
  const fs::path staging = final_dir.string() + ".partial-" + std::to_string(::getpid());
  fs::remove_all(staging);
  WriteStudyFolder(staging.string(), StudyJsonText(study, *camera, whole), stats, true, study.requirement_deg);
  PlaceEntryFolder(staging, final_dir, settings);
}

GateEntryOutcome RunEntry(const GateEntry& e, const GateSuite& suite, const GateRunOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  GateEntryOutcome outcome;
  outcome.name = e.name;
  const fs::path final_dir = fs::path(o.out_dir) / "entries" / e.name;
  const std::string settings = EntrySettings(e, suite, o);
  // Complete from an earlier run with the same settings: reuse.
  if (fs::exists(final_dir / kEntryRecord)) {
    std::ifstream in(final_dir / kEntryRecord, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    if (text.str() == settings) {
      outcome.dir = final_dir.string();
      outcome.page = EntryPage(final_dir);
      outcome.reused = true;
      outcome.ok = true;
      return outcome;
    }
  }
  try {
    if (e.observability) {
      RunObservabilityEntry(e, suite, o, settings, final_dir);
      outcome.dir = final_dir.string();
      outcome.page = kStudyPage;
      outcome.ok = true;
      outcome.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      return outcome;
    }
    const std::string dataset_dir = EntryDataset(e, suite, o);
    datasets::LoadOptions load;
    load.keep_images = true;
    load.keep_truth = true;
    std::optional<datasets::Dataset> dataset;
    {
      std::lock_guard<std::mutex> lock(g_load_mutex);
      datasets::DatasetLoadResult loaded = datasets::LoadDataset(dataset_dir, load);
      if (!loaded.Ok()) {
        // The problems themselves, not only their count: the entry's FAILED
        // line and gate.md are all its reader sees (the first five, and how
        // many more `hdabench dataset check` lists).
        std::string message = dataset_dir + ": " + loaded.Summary();
        const size_t shown = std::min<size_t>(loaded.problems.size(), 5);
        for (size_t i = 0; i < shown; ++i) message += (i == 0 ? ": " : "; ") + loaded.problems[i].ToString();
        if (loaded.problems.size() > shown) {
          message += "; and " + std::to_string(loaded.problems.size() - shown) + " more (hdabench dataset check " +
                     dataset_dir + ")";
        }
        throw InputError(message);
      }
      dataset = std::move(loaded.dataset);
    }
    const std::pair<int, int> pair = DefaultFramePair(*dataset);
    if (e.fault) datasets::ApplyFault(*e.fault, pair.first, pair.second, kGateFaultSeed, &*dataset);
    CompareOptions compare;
    compare.methods = EntryMethods(e, suite);
    compare.hda = e.hda;
    compare.hda.Set("fault_match_noise_px", o.fault_match_noise_px, "gate");
    compare.hda.Set("processor_scale", o.processor_scale, "gate");
    compare.hda.Set("compute_budget_s", kGateComputeBudgetS, "gate");
    compare.colmap.executable = o.colmap_executable;
    ApplyColmapOptions(suite.colmap, &compare.colmap);
    // The entries that run at once share the cores: each entry's own thread
    // pools (the exact matcher, the figures) get its share, not every core.
    // Neither changes what they compute.
    const int entry_threads = std::max(1, util::AvailableCores() / std::max(1, o.jobs));
    compare.colmap.matcher_threads = entry_threads;
    const fs::path staging = final_dir.string() + ".partial-" + std::to_string(::getpid());
    fs::remove_all(staging);
    fs::create_directories(staging);
    const CompareRun run =
        RunCompare(*dataset, pair.first, pair.second, compare, (staging / "colmap").string());
    WriteCompareOutputs(run, dataset->frames[static_cast<size_t>(pair.first)].image,
                        dataset->frames[static_cast<size_t>(pair.second)].image, staging.string(),
                        true, entry_threads);
    // The report a person reads; without Python's plots it is still written
    // (and says why), so it never fails the entry.
    ReportOptions report;
    report.dataset_dir = dataset_dir;
    WriteReport(staging.string(), report);
    PlaceEntryFolder(staging, final_dir, settings);
    outcome.dir = final_dir.string();
    outcome.page = kReportPage;
    outcome.ok = true;
  } catch (const std::exception& ex) {
    outcome.error = ex.what();
  }
  outcome.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return outcome;
}

}  // namespace

// ---------------------------------------------------------------------------

namespace {

// A "methods" list of a suite or an entry (`where` names it).
std::vector<std::string> ReadMethods(const Json& list, const std::string& where) {
  if (!list.is_array()) throw InputError(where + ": field 'methods' must be a list of method names");
  std::string text;
  for (const auto& m : list) {
    if (!m.is_string()) throw InputError(where + ": field 'methods' must hold strings");
    text += (text.empty() ? "" : ",") + m.get<std::string>();
  }
  try {
    return ParseMethodList(text);
  } catch (const InputError& e) {
    throw InputError(where + ": methods: " + e.what());
  }
}

// One fault, "NAME" (a fault without a magnitude) or "NAME=M".
datasets::Fault ReadOneFault(const std::string& text, const std::string& where) {
  try {
    return datasets::ParseOneFault(text);
  } catch (const InputError& e) {
    throw InputError(where + ": " + e.what());
  }
}

}  // namespace

GateSuite ReadGateSuite(const std::string& path) {
  const Json j = ReadJsonFile(path);
  CheckFormat(j, kGateSuiteFormatName, path);
  OnlyKeys(j, {"format", "format_version", "description", "methods", "colmap", "entries"}, path);
  GateSuite suite;
  suite.file = path;
  if (j.contains("description")) suite.description = StringField(j, "description", path);
  if (!j.contains("methods")) throw InputError(path + ": field 'methods' must be a list of method names");
  suite.methods = ReadMethods(j["methods"], path);
  if (j.contains("colmap")) {
    const Json& c = j["colmap"];
    const std::string where = path + ": colmap";
    if (!c.is_object()) throw InputError(where + ": expected an object");
    suite.colmap = ReadColmapOptions(c, where);
  }
  if (!j.contains("entries") || !j["entries"].is_array() || j["entries"].empty()) {
    throw InputError(path + ": field 'entries' must be a non-empty list");
  }
  std::set<std::string> names;
  for (size_t i = 0; i < j["entries"].size(); ++i) {
    const Json& ej = j["entries"][i];
    const std::string where = path + ": entries[" + std::to_string(i) + "]";
    if (!ej.is_object()) throw InputError(where + ": expected an object");
    OnlyKeys(ej, {"name", "synth", "dataset", "stereolunar", "observability", "site_size_m", "hda", "fault", "methods"},
             where);
    GateEntry e;
    e.name = StringField(ej, "name", where);
    if (!ValidName(e.name)) {
      throw InputError(where + ": name '" + e.name + "' must be letters, digits, '.', '_' or '-'");
    }
    if (!names.insert(e.name).second) throw InputError(where + ": name '" + e.name + "' is repeated");
    const int sources = static_cast<int>(ej.contains("synth")) + static_cast<int>(ej.contains("dataset")) +
                        static_cast<int>(ej.contains("stereolunar")) + static_cast<int>(ej.contains("observability"));
    if (sources != 1) {
      throw InputError(where + ": give exactly one of 'synth', 'dataset', 'stereolunar', 'observability'");
    }
    if (ej.contains("observability")) ReadObservabilityEntry(ej["observability"], where + ".observability", &e);
    if (ej.contains("synth")) {
      const Json& s = ej["synth"];
      const std::string swhere = where + ".synth";
      if (!s.is_object()) throw InputError(swhere + ": expected an object");
      OnlyKeys(s, {"preset", "terrain", "seed", "image_size", "set"}, swhere);
      e.synth_preset = StringField(s, "preset", swhere);
      if (s.contains("terrain")) e.synth_terrain = StringField(s, "terrain", swhere);
      if (s.contains("seed")) {
        if (!s["seed"].is_number_unsigned()) throw InputError(swhere + ": field 'seed' must be an integer >= 0");
        e.synth_seed = s["seed"].get<std::uint64_t>();
      }
      if (s.contains("image_size")) {
        if (!s["image_size"].is_number_integer()) throw InputError(swhere + ": field 'image_size' must be an integer");
        e.synth_image_size_px = s["image_size"].get<int>();
      }
      if (s.contains("set")) {
        if (!s["set"].is_object()) throw InputError(swhere + ": field 'set' must be an object of key: value");
        for (const auto& item : s["set"].items()) {
          const Json& v = item.value();
          std::string value = v.is_string() ? v.get<std::string>() : v.dump();
          e.synth_overrides.emplace_back(item.key(), value);
        }
      }
      // The preset, terrain and overrides must be usable now, not halfway.
      try {
        datasets::synth::SynthOptions options = datasets::synth::SynthPreset(*e.synth_preset);
        datasets::synth::TerrainOptions terrain = datasets::synth::TerrainPreset(
            e.synth_terrain.empty() ? options.terrain : e.synth_terrain);
        for (const auto& [key, value] : e.synth_overrides) {
          datasets::synth::ApplyOverride(key, value, &options, &terrain);
        }
      } catch (const InputError& ex) {
        throw InputError(swhere + ": " + ex.what());
      }
    }
    if (ej.contains("dataset")) e.dataset_dir = StringField(ej, "dataset", where);
    if (ej.contains("stereolunar")) {
      const Json& s = ej["stereolunar"];
      if (!s.is_object()) throw InputError(where + ".stereolunar: expected an object");
      OnlyKeys(s, {"pair", "sun"}, where + ".stereolunar");
      e.stereolunar_pair_dir = StringField(s, "pair", where + ".stereolunar");
      if (s.contains("sun")) e.stereolunar_sun = static_cast<int>(NumberField(s, "sun", where + ".stereolunar"));
    }
    if (ej.contains("site_size_m")) {
      const double site = NumberField(ej, "site_size_m", where);
      if (!(site > 0)) throw InputError(where + ": field 'site_size_m' must be > 0");
      e.hda.Set("quadtree.site_size_m", site, where);
    }
    if (ej.contains("hda")) {
      if (ej.contains("site_size_m")) {
        throw InputError(where + ": give the site size once: 'site_size_m' or 'hda'");
      }
      e.hda.SetAll(ej["hda"], where + ".hda");
      for (const char* key : {"compute_budget_s", "processor_scale", "fault_match_noise_px"}) {
        if (e.hda.given.count(key) != 0) {
          throw InputError(where + ".hda: '" + key + "' is the gate's own (gate --processor-scale, " +
                           "--fault-match-noise-px; an unlimited budget), not an entry's");
        }
      }
    }
    e.hda.Validate(where);
    if (ej.contains("fault")) {
      if (e.observability) throw InputError(where + ": 'fault' applies to a dataset, not to an observability study");
      e.fault = ReadOneFault(StringField(ej, "fault", where), where + ": fault");
    }
    if (ej.contains("methods")) {
      if (e.observability) throw InputError(where + ": 'methods' applies to a dataset, not to an observability study");
      e.methods = ReadMethods(ej["methods"], where);
    }
    suite.entries.push_back(e);
  }
  return suite;
}

GateThresholds ReadGateThresholds(const std::string& path) {
  const Json j = ReadJsonFile(path);
  CheckFormat(j, kGateThresholdsFormatName, path);
  OnlyKeys(j, {"format", "format_version", "description", "thresholds"}, path);
  if (!j.contains("thresholds") || !j["thresholds"].is_array()) {
    throw InputError(path + ": field 'thresholds' must be a list");
  }
  GateThresholds result;
  result.file = path;
  const std::vector<std::string> all_methods = AllMethodNames();
  const std::vector<std::string>& metrics = MetricNames();
  std::set<std::string> seen;
  for (size_t i = 0; i < j["thresholds"].size(); ++i) {
    const Json& t = j["thresholds"][i];
    const std::string where = path + ": thresholds[" + std::to_string(i) + "]";
    if (!t.is_object()) throw InputError(where + ": expected an object");
    OnlyKeys(t, {"method", "metric", "fault", "max", "min", "tolerance", "why"}, where);
    GateThreshold th;
    th.method = StringField(t, "method", where);
    th.metric = StringField(t, "metric", where);
    if (std::find(all_methods.begin(), all_methods.end(), th.method) == all_methods.end()) {
      throw InputError(where + ": unknown method '" + th.method + "'");
    }
    if (std::find(metrics.begin(), metrics.end(), th.metric) == metrics.end()) {
      throw InputError(where + ": unknown metric '" + th.metric + "'");
    }
    if (t.contains("max")) th.max = NumberField(t, "max", where);
    if (t.contains("min")) th.min = NumberField(t, "min", where);
    if (th.max.has_value() == th.min.has_value()) {
      throw InputError(where + ": give exactly one of 'max' and 'min'");
    }
    if (t.contains("tolerance")) {
      th.tolerance = NumberField(t, "tolerance", where);
      if (th.tolerance < 0) throw InputError(where + ": field 'tolerance' must be >= 0");
    }
    if (t.contains("why")) th.why = StringField(t, "why", where);
    if (t.contains("fault")) {
      th.fault = datasets::FaultLabel(ReadOneFault(StringField(t, "fault", where), where + ": fault"));
    }
    if (!seen.insert(MethodLabel(th.method, th.fault) + " " + th.metric).second) {
      throw InputError(where + ": " + MethodLabel(th.method, th.fault) + " " + th.metric + " is given twice");
    }
    result.thresholds.push_back(th);
  }
  return result;
}

std::vector<std::string> GateMetricNames() { return MetricNames(); }

namespace {

// One method's ROIs, failures and time over the entries of one pool.
struct MetricPool {
  std::vector<double> slope_errors, tilt_errors, roughness_errors;
  double signed_slope_error_sum = 0.0;
  int within_two_sigma = 0, rois = 0, rois_with_slope = 0, failed = 0;
  double flight_seconds = -1.0;
};

// A pool: a method and a fault (empty: the entries without one).
using PoolKey = std::pair<std::string, std::string>;

struct MetricPools {
  std::map<PoolKey, MetricPool> by_key;
  std::vector<PoolKey> order;  // the pools with metrics, in the order first met

  // The pool of a method that ran, listed among the metrics.
  MetricPool& Listed(const PoolKey& key) {
    if (by_key.count(key) == 0) order.push_back(key);
    return by_key[key];
  }
};

// The worst setting of any of the suite's observability entries.
struct StudyWorst {
  bool present = false;
  double p95 = 0.0, median = 0.0, sigma_ratio = 1.0;
};

// An observability entry's settings.csv into the worst setting so far.
void AddStudyEntry(const fs::path& dir, StudyWorst* study) {
  const std::string path = (dir / "settings.csv").string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read the file");
  std::stringstream text;
  text << in.rdbuf();
  for (const SettingStats& s : ParseSettingsCsv(text.str(), path)) {
    study->present = true;
    const bool judged = s.fits >= 0.95 * s.trials;
    study->p95 = std::max(study->p95, judged ? s.p95_abs_error_deg : kObservabilityUnjudgedDeg);
    study->median = std::max(study->median, std::isfinite(s.median_abs_error_deg) ? s.median_abs_error_deg
                                                                                   : kObservabilityUnjudgedDeg);
    if (s.sd_error_deg > 0.0 && s.rms_sigma_deg > 0.0) {
      study->sigma_ratio = std::max({study->sigma_ratio, s.sd_error_deg / s.rms_sigma_deg,
                                     s.rms_sigma_deg / s.sd_error_deg});
    }
  }
}

// An entry's fault, from its record (empty for a folder without one).
std::string EntryFault(const fs::path& dir) {
  const fs::path record = dir / kEntryRecord;
  if (!fs::exists(record)) return "";
  const Json r = ReadJsonFile(record.string());
  if (!r.contains("entry") || !r["entry"].contains("fault")) return "";
  return StringField(r["entry"], "fault", record.string());
}

// One method's result on one ROI (compare.json) into its pool.
void AddRoi(const std::string& method, const Json& r, const Json& truth, MetricPool* pool) {
  ++pool->rois;
  const std::string status = r.at("status").get<std::string>();
  const bool has_slope =
      !r.at("slope_deg").is_null() && (method == kMethodFlight ? FlightHasSlope(status) : status == "ok");
  if (has_slope) ++pool->rois_with_slope;
  // Only slopes the method stands by: a degenerate ROI's plane is a
  // diagnostic (the method says the slope is not observable).
  if (!has_slope || truth.is_null() || r.at("slope_error_deg").is_null() ||
      r.at("num_points").get<int>() < kMinPointsForSlopeStats) {
    return;
  }
  const double signed_error = r.at("slope_error_deg").get<double>();
  const double error = std::abs(signed_error);
  pool->slope_errors.push_back(error);
  pool->signed_slope_error_sum += signed_error;
  if (r.contains("tilt_error_deg") && r.at("tilt_error_deg").is_number()) {
    pool->tilt_errors.push_back(r.at("tilt_error_deg").get<double>());
  }
  if (!r.at("roughness_rms_m").is_null() && !truth.at("roughness_rms_m").is_null()) {
    pool->roughness_errors.push_back(
        std::abs(r.at("roughness_rms_m").get<double>() - truth.at("roughness_rms_m").get<double>()));
  }
  if (!r.at("slope_sigma_deg").is_null() && error <= 2.0 * r.at("slope_sigma_deg").get<double>()) {
    ++pool->within_two_sigma;
  }
}

// A comparison entry (compare.json and compare_timings.json) into the pools
// of its fault.
void AddCompareEntry(const fs::path& dir, double processor_scale, MetricPools* pools) {
  const std::string fault = EntryFault(dir);
  const std::string path = (dir / "compare.json").string();
  const Json j = ReadJsonFile(path);
  for (const Json& m : j.at("methods")) {
    MetricPool& pool = pools->Listed({m.at("name").get<std::string>(), fault});
    if (!m.at("ok").get<bool>()) ++pool.failed;
  }
  for (const Json& roi : j.at("rois")) {
    for (const auto& item : roi.at("methods").items()) {
      AddRoi(item.key(), item.value(), roi.at("truth"), &pools->by_key[{item.key(), fault}]);
    }
  }
  const Json t = ReadJsonFile((dir / "compare_timings.json").string());
  for (const Json& m : t.at("methods")) {
    if (m.at("name") != kMethodFlight || m.at("seconds").is_null()) continue;
    MetricPool& pool = pools->by_key[{kMethodFlight, fault}];
    pool.flight_seconds = std::max(pool.flight_seconds, m.at("seconds").get<double>() / processor_scale);
  }
}

// The metrics of one pool (docs/gate.md), those without data left out.
void AddPoolMetrics(const PoolKey& key, const MetricPool& pool, const StudyWorst& study,
                    std::vector<GateMetric>* metrics) {
  const std::string& method = key.first;
  const auto add = [&](const std::string& metric, double value) {
    metrics->push_back({method, metric, value, key.second});
  };
  const auto sorted = [](std::vector<double> values) {
    std::sort(values.begin(), values.end());
    return values;
  };
  if (!pool.slope_errors.empty()) {
    const std::vector<double> errors = sorted(pool.slope_errors);
    add("slope_error_median_deg", util::Quantile(errors, 0.5));
    add("slope_error_p90_deg", util::Quantile(errors, 0.9));
    add("slope_error_max_deg", errors.back());
    add("slope_bias_abs_deg", std::abs(pool.signed_slope_error_sum / static_cast<double>(errors.size())));
  }
  if (!pool.tilt_errors.empty()) {
    const std::vector<double> errors = sorted(pool.tilt_errors);
    add("tilt_error_median_deg", util::Quantile(errors, 0.5));
    add("tilt_error_p90_deg", util::Quantile(errors, 0.9));
  }
  if (!pool.roughness_errors.empty()) {
    add("roughness_error_median_m", util::Quantile(sorted(pool.roughness_errors), 0.5));
  }
  if (pool.rois > 0) add("rois_with_slope_share", static_cast<double>(pool.rois_with_slope) / pool.rois);
  if (method == kMethodFlight && !pool.slope_errors.empty()) {
    add("within_two_sigma_share",
        static_cast<double>(pool.within_two_sigma) / static_cast<double>(pool.slope_errors.size()));
  }
  if (method == kMethodFlight && pool.flight_seconds >= 0.0) add("flight_seconds_per_pair", pool.flight_seconds);
  add("failed_entries", pool.failed);
  add("slope_error_rois", static_cast<double>(pool.slope_errors.size()));
  if (method == kMethodFlight && key.second.empty() && study.present) {
    add("observability_p95_deg", study.p95);
    add("observability_median_deg", study.median);
    add("observability_sigma_ratio", study.sigma_ratio);
  }
}

}  // namespace

std::vector<GateMetric> ComputeGateMetrics(const std::vector<std::string>& entry_dirs,
                                           double processor_scale) {
  MetricPools pools;
  StudyWorst study;
  for (const std::string& dir : entry_dirs) {
    if (fs::exists(fs::path(dir) / "study.json")) {
      AddStudyEntry(dir, &study);
      // The study's metrics are the flight method's.
      if (study.present) pools.Listed({kMethodFlight, ""});
    } else {
      AddCompareEntry(dir, processor_scale, &pools);
    }
  }
  std::vector<GateMetric> metrics;
  for (const PoolKey& key : pools.order) AddPoolMetrics(key, pools.by_key[key], study, &metrics);
  return metrics;
}

std::string GateCheck::Summary() const {
  const std::string name = MethodLabel(threshold.method, threshold.fault) + " " + threshold.metric;
  if (!has_value) return name + ": no value in this run (no data for the metric)";
  std::string text = name + " = " + FormatValue(value);
  if (!passed) {
    text += threshold.max ? " > " + FormatValue(*threshold.max) + " (threshold)"
                          : " < " + FormatValue(*threshold.min) + " (threshold)";
  }
  if (regressed) {
    text += std::string(passed ? "" : ";") + " regressed from the baseline's " + FormatValue(baseline) +
            " by more than " + FormatValue(threshold.tolerance);
  }
  return text;
}

std::vector<GateCheck> CheckGate(const std::vector<GateMetric>& metrics,
                                 const GateThresholds& thresholds,
                                 const std::vector<GateMetric>* baseline) {
  const auto find = [](const std::vector<GateMetric>& list, const GateThreshold& t) -> const GateMetric* {
    for (const GateMetric& m : list) {
      if (m.method == t.method && m.metric == t.metric && m.fault == t.fault) return &m;
    }
    return nullptr;
  };
  std::vector<GateCheck> checks;
  for (const GateThreshold& t : thresholds.thresholds) {
    GateCheck check;
    check.threshold = t;
    const GateMetric* m = find(metrics, t);
    if (m != nullptr) {
      check.has_value = true;
      check.value = m->value;
      check.margin = t.max ? *t.max - m->value : m->value - *t.min;
      check.passed = check.margin >= 0.0;
    }
    if (baseline != nullptr && m != nullptr) {
      if (const GateMetric* b = find(*baseline, t)) {
        check.has_baseline = true;
        check.baseline = b->value;
        const double worse = HigherIsBetter(t.metric) ? b->value - m->value : m->value - b->value;
        check.regressed = worse > t.tolerance;
      }
    }
    checks.push_back(check);
  }
  return checks;
}

std::string GateMetricsJson(const std::vector<GateMetric>& metrics) {
  Json j;
  j["format"] = kGateMetricsFormatName;
  j["format_version"] = kGateFormatVersion;
  Json list = Json::array();
  for (const GateMetric& m : metrics) {
    Json item = {{"method", m.method}, {"metric", m.metric}, {"value", m.value}};
    if (!m.fault.empty()) item["fault"] = m.fault;  // only then: the baselines without faults keep their bytes
    list.push_back(item);
  }
  j["metrics"] = list;
  return j.dump(1) + "\n";
}

std::vector<GateMetric> ReadGateMetrics(const std::string& path) {
  const Json j = ReadJsonFile(path);
  CheckFormat(j, kGateMetricsFormatName, path);
  std::vector<GateMetric> metrics;
  if (!j.contains("metrics") || !j["metrics"].is_array()) {
    throw InputError(path + ": field 'metrics' must be a list");
  }
  for (size_t i = 0; i < j["metrics"].size(); ++i) {
    const Json& m = j["metrics"][i];
    const std::string where = path + ": metrics[" + std::to_string(i) + "]";
    if (!m.is_object()) throw InputError(where + ": expected an object");
    metrics.push_back({StringField(m, "method", where), StringField(m, "metric", where),
                       NumberField(m, "value", where),
                       m.contains("fault") ? StringField(m, "fault", where) : std::string()});
  }
  return metrics;
}

std::string GateTable(const std::vector<GateCheck>& checks) {
  std::ostringstream out;
  out << "| method | metric | value | threshold | margin | baseline | verdict |\n"
      << "| --- | --- | --- | --- | --- | --- | --- |\n";
  for (const GateCheck& c : checks) {
    const GateThreshold& t = c.threshold;
    const std::string threshold = t.max ? "<= " + FormatValue(*t.max) : ">= " + FormatValue(*t.min);
    std::string verdict = !c.has_value ? "FAIL (no data)" : c.passed ? "pass" : "FAIL";
    if (c.regressed) verdict += c.passed ? " but REGRESSED" : ", REGRESSED";
    out << "| " << MethodLabel(t.method, t.fault) << " | " << t.metric << " | " << (c.has_value ? FormatValue(c.value) : "-")
        << " | " << threshold << " | " << (c.has_value ? FormatValue(c.margin) : "-") << " | "
        << (c.has_baseline ? FormatValue(c.baseline) : "-") << " | " << verdict << " |\n";
  }
  return out.str();
}

std::string GateHtml(const std::string& suite_file, const std::vector<GateCheck>& checks,
                     const std::vector<GateEntryOutcome>& outcomes) {
  std::ostringstream out;
  int failures = 0;
  for (const GateCheck& c : checks) failures += (c.has_value && c.passed && !c.regressed) ? 0 : 1;
  for (const GateEntryOutcome& o : outcomes) failures += o.ok ? 0 : 1;
  out << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>Gate: "
      << util::HtmlEscape(suite_file) << "</title>\n<style>body{font-family:sans-serif;margin:2em}"
      << "table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}"
      << "td:first-child,td:nth-child(2),th{text-align:left}tr.fail td{background:#f8c8c8}"
      << ".verdict{font-weight:bold}</style></head><body>\n<h1>Gate: " << util::HtmlEscape(suite_file)
      << "</h1>\n<p class=\"verdict\" id=\"verdict\">"
      << (failures == 0 ? "PASS: every metric within its threshold"
                        : "FAIL: " + std::to_string(failures) + " failure(s)")
      << "</p>\n<table id=\"gate-table\"><thead><tr><th>method</th><th>metric</th><th>value</th>"
      << "<th>threshold</th><th>margin</th><th>baseline</th><th>verdict</th></tr></thead><tbody>\n";
  for (const GateCheck& c : checks) {
    const GateThreshold& t = c.threshold;
    const bool ok = c.has_value && c.passed && !c.regressed;
    std::string verdict = !c.has_value ? "FAIL (no data)" : c.passed ? "pass" : "FAIL";
    if (c.regressed) verdict += c.passed ? " but REGRESSED" : ", REGRESSED";
    out << "<tr" << (ok ? "" : " class=\"fail\"") << " title=\"" << util::HtmlEscape(t.why) << "\"><td>"
        << util::HtmlEscape(MethodLabel(t.method, t.fault)) << "</td><td>" << util::HtmlEscape(t.metric) << "</td><td>"
        << (c.has_value ? FormatValue(c.value) : "-") << "</td><td>"
        << (t.max ? "&lt;= " + FormatValue(*t.max) : "&gt;= " + FormatValue(*t.min)) << "</td><td>"
        << (c.has_value ? FormatValue(c.margin) : "-") << "</td><td>"
        << (c.has_baseline ? FormatValue(c.baseline) : "-") << "</td><td>" << verdict << "</td></tr>\n";
  }
  out << "</tbody></table>\n<h2>Entries</h2>\n<ul id=\"entries\">\n";
  for (const GateEntryOutcome& o : outcomes) {
    out << "<li>";
    if (o.ok) {
      out << "<a href=\"entries/" << util::HtmlEscape(o.name) << "/" << util::HtmlEscape(o.page) << "\">"
          << util::HtmlEscape(o.name)
          << "</a>" << (o.reused ? " (complete from an earlier run)" : "");
    } else {
      out << util::HtmlEscape(o.name) << ": FAILED: " << util::HtmlEscape(o.error);
    }
    out << "</li>\n";
  }
  out << "</ul>\n</body></html>\n";
  return out.str();
}

std::vector<std::string> GateRunOptions::Validate() const {
  std::vector<std::string> errors;
  if (out_dir.empty()) errors.push_back("out_dir is empty: expected the gate's output folder");
  RequireOption(jobs >= 1, "jobs", jobs, ">= 1", &errors);
  RequireOption(synth_threads >= 1, "synth_threads", synth_threads, ">= 1", &errors);
  RequireOption(fault_match_noise_px >= 0.0, "fault_match_noise_px", fault_match_noise_px, ">= 0",
                &errors);
  RequireOption(processor_scale > 0.0, "processor_scale", processor_scale, "> 0", &errors);
  if (colmap_executable.empty()) errors.push_back("colmap_executable is empty: expected a program");
  return errors;
}

std::vector<GateEntryOutcome> RunGateSuite(const GateSuite& suite, const GateRunOptions& options,
                                           const GateProgress& progress) {
  ThrowIfInvalid("", options.Validate());
  {
    std::error_code ec;
    fs::create_directories(fs::path(options.out_dir) / "entries", ec);
    if (ec) {
      throw InputError((fs::path(options.out_dir) / "entries").string() + ": cannot create the folder (" +
                       ec.message() + ")");
    }
  }
  // Leftovers of an interrupted run are never trusted.
  for (const fs::path& folder : {fs::path(options.out_dir) / "entries", fs::path(options.out_dir) / "datasets"}) {
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) continue;
    for (const auto& item : fs::directory_iterator(folder, ec)) {
      if (item.path().filename().string().find(".partial-") != std::string::npos) {
        fs::remove_all(item.path(), ec);
      }
    }
  }
  std::vector<size_t> held;
  for (size_t i = 0; i < suite.entries.size(); ++i) {
    if (options.shard.Holds(static_cast<int>(i))) held.push_back(i);
  }
  std::vector<GateEntryOutcome> outcomes(held.size());
  std::atomic<int> finished{0};
  std::mutex say_mutex;
  const int total = static_cast<int>(held.size());
  util::ParallelFor("gate entries", total, options.jobs, [&](int index) {
    const size_t i = static_cast<size_t>(index);
    outcomes[i] = RunEntry(suite.entries[held[i]], suite, options);
    const int done = ++finished;
    if (!progress) return;
    const GateEntryOutcome& o = outcomes[i];
    std::ostringstream line;
    line << "[" << done << "/" << total << "] " << o.name << ": "
         << (o.reused ? "complete from an earlier run"
                      : o.ok ? "done in " + util::FixedCell(o.wall_s, 1) + " s" : "FAILED: " + o.error);
    const std::lock_guard<std::mutex> lock(say_mutex);
    progress(line.str());
  });
  return outcomes;
}

// ---------------------------------------------------------------------------
// Shards

namespace {

constexpr char kGateShardFormatName[] = "hdabench-gate-shard";

std::string SuiteDigest(const GateSuite& suite) {
  std::ifstream in(suite.file, std::ios::binary);
  if (!in) throw InputError(suite.file + ": cannot read the file");
  std::stringstream text;
  text << in.rdbuf();
  return Hex(Fnv1a(text.str()));
}

// A folder's files into `to` (created), hard-linked where the file system
// allows, copied otherwise.
void LinkOrCopyTree(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::copy(from, to, fs::copy_options::recursive | fs::copy_options::create_hard_links, ec);
  if (!ec) return;
  fs::remove_all(to);
  fs::copy(from, to, fs::copy_options::recursive);
}

}  // namespace

std::string GateShardJson(const GateSuite& suite, const util::Shard& shard,
                          const std::vector<GateEntryOutcome>& outcomes) {
  Json j;
  j["format"] = kGateShardFormatName;
  j["format_version"] = kGateFormatVersion;
  j["suite"] = suite.file;
  j["suite_digest"] = SuiteDigest(suite);
  j["shard"] = shard.Text();
  Json list = Json::array();
  for (const GateEntryOutcome& o : outcomes) {
    list.push_back({{"name", o.name}, {"ok", o.ok}, {"error", o.error}, {"reused", o.reused}, {"wall_s", o.wall_s}});
  }
  j["entries"] = list;
  return j.dump(1) + "\n";
}

std::vector<GateEntryOutcome> MergeGateShards(const GateSuite& suite, const std::vector<std::string>& shard_dirs,
                                              const std::string& out_dir) {
  if (shard_dirs.empty()) throw InputError("no shard folders given");
  const std::string digest = SuiteDigest(suite);
  std::map<std::string, GateEntryOutcome> by_name;
  std::map<std::string, std::string> from_dir;
  std::map<int, std::string> shard_of;  // shard index -> its folder
  int count = 0;
  for (const std::string& dir : shard_dirs) {
    const std::string path = (fs::path(dir) / kGateShardFileName).string();
    if (!fs::exists(path)) {
      throw InputError(path + ": no such file: not a finished `hdabench gate --shard` folder");
    }
    const Json j = ReadJsonFile(path);
    CheckFormat(j, kGateShardFormatName, path);
    if (StringField(j, "suite_digest", path) != digest) {
      throw InputError(path + ": the shard ran the suite " + StringField(j, "suite", path) +
                       ", whose contents differ from " + suite.file);
    }
    const util::Shard shard = util::ParseShard(StringField(j, "shard", path));
    if (count != 0 && shard.count != count) {
      throw InputError(path + ": shard " + shard.Text() + " of another split than the others (of " +
                       std::to_string(count) + ")");
    }
    count = shard.count;
    if (!shard_of.emplace(shard.index, dir).second) {
      throw InputError(path + ": shard " + shard.Text() + " is also in " + shard_of[shard.index]);
    }
    if (!j.contains("entries") || !j["entries"].is_array()) throw InputError(path + ": field 'entries' must be a list");
    for (const Json& e : j["entries"]) {
      GateEntryOutcome o;
      o.name = StringField(e, "name", path);
      o.ok = e.at("ok").get<bool>();
      o.error = StringField(e, "error", path);
      o.reused = e.at("reused").get<bool>();
      o.wall_s = NumberField(e, "wall_s", path);
      from_dir[o.name] = dir;
      by_name[o.name] = o;
    }
  }
  for (int k = 1; k <= count; ++k) {
    if (shard_of.count(k) == 0) {
      throw InputError("shard " + std::to_string(k) + "/" + std::to_string(count) + " is missing among the " +
                       std::to_string(shard_dirs.size()) + " folders given");
    }
  }
  std::vector<GateEntryOutcome> outcomes;
  fs::create_directories(fs::path(out_dir) / "entries");
  for (const GateEntry& e : suite.entries) {
    const auto found = by_name.find(e.name);
    if (found == by_name.end()) {
      throw InputError("entry '" + e.name + "' of " + suite.file + " is in no shard's " + kGateShardFileName);
    }
    GateEntryOutcome o = found->second;
    if (o.ok) {
      const fs::path source = fs::path(from_dir[e.name]) / "entries" / e.name;
      const fs::path target = fs::path(out_dir) / "entries" / e.name;
      if (!fs::exists(source / kEntryRecord)) {
        throw InputError(source.string() + ": the shard recorded the entry complete, but its folder is not");
      }
      std::error_code ec;
      if (!fs::equivalent(source, target, ec)) {
        const fs::path staging = target.string() + ".partial-" + std::to_string(::getpid());
        fs::remove_all(staging);
        LinkOrCopyTree(source, staging);
        fs::remove_all(target);
        fs::rename(staging, target);
      }
      o.dir = target.string();
      o.page = EntryPage(target);
    }
    outcomes.push_back(o);
  }
  return outcomes;
}

}  // namespace hdabench::reference
