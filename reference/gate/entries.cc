// Running a suite's entries: each entry's dataset made or found (cached by
// its source and the build), the comparison or the observability study run
// into a folder placed when complete, and entries complete from an earlier
// run with the same settings and build reused.
#include "reference/gate/gate.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <optional>

#include <opencv2/core/utility.hpp>

#include "datasets/dataset.h"
#include "datasets/stereolunar.h"
#include "datasets/synth/terrain.h"
#include "reference/compare/compare.h"
#include "reference/compare/compare_outputs.h"
#include "reference/gate/internal/common.h"
#include "reference/report/report.h"
#include "tools/util/build_identity.h"
#include "tools/util/files.h"
#include "tools/util/options_check.h"
#include "tools/util/parallel_for.h"
#include "tools/util/process.h"

namespace hdabench::reference {

using namespace gate_internal;  // NOLINT(google-build-using-namespace): the gate's own helpers

namespace {

// The gate measures accuracy without time-budget kick-outs, over every ROI:
// the flight method gets an ample budget here and its time (predicted from
// its counted work) is a metric of its own (flight_seconds_per_pair). The
// kick-outs have their own tests.
constexpr double kGateComputeBudgetS = 1.0e6;

// The seed of a fault's random numbers (lrf-noise), as `hdabench faults`'s default.
constexpr std::uint64_t kGateFaultSeed = 1;

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

// The entry as read: its dataset's source, its flight-method parameters, its
// fault and its own methods.
Json EntrySpecJson(const GateEntry& e) {
  Json j = EntryDatasetSpecJson(e);
  j["hda"] = e.hda.GivenJson();
  j["fault"] = e.fault ? Json(datasets::FaultLabel(*e.fault)) : Json(nullptr);
  if (!e.pool.empty()) j["pool"] = e.pool;  // only then: the records without one keep their bytes
  j["methods"] = e.methods;
  return j;
}

// The build whose results the caches hold (GateRunOptions::build_identity).
const std::string& BuildOf(const GateRunOptions& o) {
  return o.build_identity.empty() ? util::BuildIdentity() : o.build_identity;
}

// The bytes of the external method's program (looked up in PATH when it is a
// bare name); empty when it cannot be read, and the entry's run then fails
// with the reason.
std::string ProgramBytes(const std::string& program) {
  const std::string path = util::FindExecutable(program);
  if (path.empty()) return "";
  std::string bytes;
  std::string error;
  return util::ReadFileBytes(path, &bytes, &error) ? bytes : "";
}

// The settings an entry's results depend on: a complete folder with other
// settings is redone.
std::string EntrySettings(const GateEntry& e, const GateSuite& suite, const GateRunOptions& o) {
  Json j;
  j["format"] = "hdabench-gate-entry";
  j["format_version"] = kGateFormatVersion;
  j["entry"] = EntrySpecJson(e);
  j["methods"] = EntryMethods(e, suite);
  const auto optional = [](const auto& value) { return value ? Json(*value) : Json(nullptr); };
  j["colmap_max_features"] = optional(suite.colmap.max_features);
  j["colmap_first_octave"] = optional(suite.colmap.first_octave);
  j["colmap_octave_resolution"] = optional(suite.colmap.octave_resolution);
  j["colmap_peak_threshold"] = optional(suite.colmap.peak_threshold);
  j["colmap_nav_band_px"] = optional(suite.colmap.nav_band_px);
  j["fault_match_noise_px"] = o.fault_match_noise_px;
  j["flight_compute_budget_s"] = kGateComputeBudgetS;
  j["colmap"] = o.colmap_executable;
  const std::vector<std::string>& methods = EntryMethods(e, suite);
  if (std::find(methods.begin(), methods.end(), kMethodExternal) != methods.end()) {
    // The program's command and its file's bytes: an entry is redone when the program changes.
    j["external"] = {{"program", suite.external.program},
                     {"args", suite.external.args},
                     {"timeout_s", suite.external.timeout_s},
                     {"program_fnv1a", Hex(Fnv1a(ProgramBytes(suite.external.program)))}};
  }
  // Results of another build are not reused.
  j["build"] = BuildOf(o);
  return j.dump(1) + "\n";
}

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

// Whether a synthetic dataset renders the frame after the default pair: when
// an entry that shares it drops a frame (the next frame takes image 2's place).
bool RendersNextFrame(const GateEntry& owner, const GateSuite& suite) {
  return std::any_of(suite.entries.begin(), suite.entries.end(), [&](const GateEntry& other) {
    return other.fault && other.fault->kind == datasets::FaultKind::kFrameDropped &&
           &DatasetOwner(other, suite) == &owner;
  });
}

// The folder name of a dataset the gate makes: the owner's name and a hash of
// its source, the frames rendered and the build (a new build makes its
// datasets again, since the scene generator may have changed).
std::string MadeDatasetName(const GateEntry& owner, bool with_next, const GateRunOptions& o) {
  const std::string frames = with_next ? "pair+next" : "pair";
  return owner.name + "-" +
         Hex(Fnv1a(EntryDatasetSpecJson(owner).dump() + "\n" + frames + "\n" + BuildOf(o))).substr(0, 8);
}

// Removes the datasets an earlier build made for this owner (its name and
// another hash), so that they do not pile up, one per build.
void RemoveOtherBuildsDatasets(const fs::path& made, const std::string& owner_name) {
  std::error_code ec;
  for (const fs::directory_entry& d : fs::directory_iterator(made.parent_path(), ec)) {
    const std::string name = d.path().filename().string();
    const bool same_owner = name.size() == owner_name.size() + 9 && name.rfind(owner_name + "-", 0) == 0 &&
                            name.find_first_not_of("0123456789abcdef", owner_name.size() + 1) == std::string::npos;
    if (same_owner && d.path() != made) fs::remove_all(d.path(), ec);
  }
}

// The dataset folder of an entry (its owner's, DatasetOwner): made if it is
// synthetic (under a temporary name, renamed into place), found otherwise.
std::string EntryDataset(const GateEntry& entry, const GateSuite& suite, const GateRunOptions& o) {
  const GateEntry& e = DatasetOwner(entry, suite);
  const fs::path suite_dir = fs::path(suite.file).parent_path();
  if (e.dataset_dir) return (suite_dir / *e.dataset_dir).lexically_normal().string();
  // The entries take the default pair; a dropped-frame fault on an entry
  // that shares the dataset takes the frame after it too.
  const bool with_next = RendersNextFrame(e, suite);
  const fs::path made = fs::path(o.out_dir) / "datasets" / MadeDatasetName(e, with_next, o);
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
    options.frames_to_render = [with_next](const datasets::Dataset& d) { return PairFramesToRender(d, with_next); };
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
  RemoveOtherBuildsDatasets(made, e.name);
  return made.string();
}

// Loading a dataset reads its camera model through libmrcal, whose parser
// messages are captured from stderr: one load at a time.
std::mutex g_load_mutex;

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
    compare.hda.Set("compute_budget_s", kGateComputeBudgetS, "gate");
    compare.colmap.executable = o.colmap_executable;
    suite.colmap.ApplyTo(&compare.colmap);
    compare.external = suite.external;
    // The entries that run at once share the cores: each entry's own thread
    // pools (the exact matcher, the figures) get its share, not every core.
    // Neither changes what they compute.
    const int entry_threads = std::max(1, util::AvailableCores() / std::max(1, o.jobs));
    compare.colmap.matcher_threads = entry_threads;
    const fs::path staging = final_dir.string() + ".partial-" + std::to_string(::getpid());
    fs::remove_all(staging);
    fs::create_directories(staging);
    compare.external.work_dir = (staging / "external").string();
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

std::vector<std::string> GateRunOptions::Validate() const {
  std::vector<std::string> errors;
  if (out_dir.empty()) errors.push_back("out_dir is empty: expected the gate's output folder");
  RequireOption(jobs >= 1, "jobs", jobs, ">= 1", &errors);
  RequireOption(synth_threads >= 1, "synth_threads", synth_threads, ">= 1", &errors);
  RequireOption(fault_match_noise_px >= 0.0, "fault_match_noise_px", fault_match_noise_px, ">= 0",
                &errors);
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

}  // namespace hdabench::reference
