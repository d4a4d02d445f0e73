// The gate's suite and thresholds files read and checked (docs/gate.md).
#include "reference/gate/gate.h"

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <map>
#include <set>

#include "datasets/faults.h"
#include "reference/gate/internal/common.h"
#include "reference/compare/compare.h"
#include "tools/util/options_check.h"

namespace hdabench::reference {

using namespace gate_internal;  // NOLINT(google-build-using-namespace): the gate's own helpers

namespace {

// A suite's "colmap" object: its fields typed here, their ranges those of
// ColmapOptions::Validate.
ColmapSettings ReadColmapOptions(const Json& c, const std::string& where) {
  if (!c.is_object()) throw InputError(where + ": expected an object");
  OnlyKeys(c, {"max_features", "first_octave", "octave_resolution", "peak_threshold", "nav_band_px"}, where);
  ColmapSettings out;
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
  out.ApplyTo(&options);
  ThrowIfInvalid(where + ": ", options.Validate());
  return out;
}

// A suite's "external" object: the external method's program, its
// arguments and time limit. A program named with a folder is taken relative
// to the suite's folder (as the entries' datasets are); a bare name is looked
// up in PATH when it runs.
ExternalMethodOptions ReadExternalOptions(const Json& x, const std::string& suite_path, const std::string& where) {
  if (!x.is_object()) throw InputError(where + ": expected an object");
  OnlyKeys(x, {"program", "args", "timeout_s"}, where);
  ExternalMethodOptions out;
  out.program = StringField(x, "program", where);
  if (out.program.empty()) throw InputError(where + ": field 'program' must not be empty");
  const std::filesystem::path program(out.program);
  if (program.is_relative() && out.program.find('/') != std::string::npos) {
    out.program = (std::filesystem::path(suite_path).parent_path() / program).lexically_normal().string();
  }
  if (x.contains("args")) {
    if (!x["args"].is_array()) throw InputError(where + ": field 'args' must be a list of strings");
    for (const Json& a : x["args"]) {
      if (!a.is_string()) throw InputError(where + ": field 'args' must be a list of strings");
      out.args.push_back(a.get<std::string>());
    }
  }
  if (x.contains("timeout_s")) out.timeout_s = NumberField(x, "timeout_s", where);
  ThrowIfInvalid(where + ": ", out.Validate());
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

// An entry's "synth" object: the preset, terrain and overrides, each checked now, not halfway.
void ReadSynthEntry(const Json& s, const std::string& where, GateEntry* e) {
  if (!s.is_object()) throw InputError(where + ": expected an object");
  OnlyKeys(s, {"preset", "terrain", "seed", "image_size", "set"}, where);
  e->synth_preset = StringField(s, "preset", where);
  if (s.contains("terrain")) e->synth_terrain = StringField(s, "terrain", where);
  if (s.contains("seed")) {
    if (!s["seed"].is_number_unsigned()) throw InputError(where + ": field 'seed' must be an integer >= 0");
    e->synth_seed = s["seed"].get<std::uint64_t>();
  }
  if (s.contains("image_size")) {
    if (!s["image_size"].is_number_integer()) throw InputError(where + ": field 'image_size' must be an integer");
    e->synth_image_size_px = s["image_size"].get<int>();
  }
  if (s.contains("set")) {
    if (!s["set"].is_object()) throw InputError(where + ": field 'set' must be an object of key: value");
    for (const auto& item : s["set"].items()) {
      const Json& v = item.value();
      std::string value = v.is_string() ? v.get<std::string>() : v.dump();
      e->synth_overrides.emplace_back(item.key(), value);
    }
  }
  try {
    datasets::synth::SynthOptions options = datasets::synth::SynthPreset(*e->synth_preset);
    datasets::synth::TerrainOptions terrain =
        datasets::synth::TerrainPreset(e->synth_terrain.empty() ? options.terrain : e->synth_terrain);
    for (const auto& [key, value] : e->synth_overrides) {
      datasets::synth::ApplyOverride(key, value, &options, &terrain);
    }
  } catch (const InputError& ex) {
    throw InputError(where + ": " + ex.what());
  }
}

// An entry's "hda" or "site_size_m": the flight method's parameters it sets.
void ReadEntryHda(const Json& ej, const std::string& where, GateEntry* e) {
  if (ej.contains("site_size_m")) {
    const double site = NumberField(ej, "site_size_m", where);
    if (!(site > 0)) throw InputError(where + ": field 'site_size_m' must be > 0");
    e->hda.Set("quadtree.site_size_m", site, where);
  }
  if (ej.contains("hda")) {
    if (ej.contains("site_size_m")) {
      throw InputError(where + ": give the site size once: 'site_size_m' or 'hda'");
    }
    e->hda.SetAll(ej["hda"], where + ".hda");
    for (const char* key : {"compute_budget_s", "flight_instructions_per_s", "fault_match_noise_px"}) {
      if (e->hda.given.count(key) != 0) {
        throw InputError(where + ".hda: '" + key + "' is the gate's own (an unlimited budget, the " +
                         "default flight computer, gate --fault-match-noise-px), not an entry's");
      }
    }
  }
  e->hda.Validate(where);
}

// One entry of the suite, at `where`; its name is checked against `names` (and added).
GateEntry ReadGateEntry(const Json& ej, const std::string& where, const GateSuite& suite,
                        std::set<std::string>* names) {
  if (!ej.is_object()) throw InputError(where + ": expected an object");
  OnlyKeys(ej,
           {"name", "synth", "dataset", "stereolunar", "observability", "site_size_m", "hda", "fault", "pool",
            "methods"},
           where);
  GateEntry e;
  e.name = StringField(ej, "name", where);
  if (!ValidName(e.name)) {
    throw InputError(where + ": name '" + e.name + "' must be letters, digits, '.', '_' or '-'");
  }
  if (!names->insert(e.name).second) throw InputError(where + ": name '" + e.name + "' is repeated");
  const int sources = static_cast<int>(ej.contains("synth")) + static_cast<int>(ej.contains("dataset")) +
                      static_cast<int>(ej.contains("stereolunar")) + static_cast<int>(ej.contains("observability"));
  if (sources != 1) {
    throw InputError(where + ": give exactly one of 'synth', 'dataset', 'stereolunar', 'observability'");
  }
  if (ej.contains("observability")) ReadObservabilityEntry(ej["observability"], where + ".observability", &e);
  if (ej.contains("synth")) ReadSynthEntry(ej["synth"], where + ".synth", &e);
  if (ej.contains("dataset")) e.dataset_dir = StringField(ej, "dataset", where);
  if (ej.contains("stereolunar")) {
    const Json& s = ej["stereolunar"];
    if (!s.is_object()) throw InputError(where + ".stereolunar: expected an object");
    OnlyKeys(s, {"pair", "sun"}, where + ".stereolunar");
    e.stereolunar_pair_dir = StringField(s, "pair", where + ".stereolunar");
    if (s.contains("sun")) e.stereolunar_sun = static_cast<int>(NumberField(s, "sun", where + ".stereolunar"));
  }
  ReadEntryHda(ej, where, &e);
  for (const char* key : {"fault", "pool", "methods"}) {
    if (e.observability && ej.contains(key)) {
      throw InputError(where + ": '" + key + "' applies to a dataset, not to an observability study");
    }
  }
  if (ej.contains("fault")) e.fault = ReadOneFault(StringField(ej, "fault", where), where + ": fault");
  if (ej.contains("pool")) {
    e.pool = StringField(ej, "pool", where);
    if (!ValidName(e.pool)) {
      throw InputError(where + ": pool '" + e.pool + "' must be letters, digits, '.', '_' or '-'");
    }
  }
  if (ej.contains("methods")) e.methods = ReadMethods(ej["methods"], where);
  const std::vector<std::string>& methods = e.methods.empty() ? suite.methods : e.methods;
  if (!e.observability && suite.external.program.empty() &&
      std::find(methods.begin(), methods.end(), kMethodExternal) != methods.end()) {
    throw InputError(where + ": the method 'external' needs the suite's \"external\": {\"program\": ...}");
  }
  return e;
}

// "a, b, c": the names a selection's error offers.
template <typename Names>
std::string JoinNames(const Names& names) {
  std::string joined;
  for (const std::string& name : names) joined += (joined.empty() ? "" : ", ") + name;
  return joined;
}

}  // namespace

GateSuite ReadGateSuite(const std::string& path) {
  const Json j = ReadJsonFile(path);
  CheckFormat(j, kGateSuiteFormatName, path);
  OnlyKeys(j, {"format", "format_version", "description", "methods", "colmap", "external", "entries"}, path);
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
  if (j.contains("external")) suite.external = ReadExternalOptions(j["external"], path, path + ": external");
  if (!j.contains("entries") || !j["entries"].is_array() || j["entries"].empty()) {
    throw InputError(path + ": field 'entries' must be a non-empty list");
  }
  std::set<std::string> names;
  for (size_t i = 0; i < j["entries"].size(); ++i) {
    suite.entries.push_back(
        ReadGateEntry(j["entries"][i], path + ": entries[" + std::to_string(i) + "]", suite, &names));
  }
  return suite;
}

GateSuite SelectGateEntries(const GateSuite& suite, const std::vector<std::string>& names) {
  GateSuite selected = suite;
  selected.entries.clear();
  const std::set<std::string> wanted(names.begin(), names.end());
  for (const GateEntry& e : suite.entries) {
    if (wanted.count(e.name) > 0) selected.entries.push_back(e);
  }
  for (const std::string& name : wanted) {
    const bool held = std::any_of(suite.entries.begin(), suite.entries.end(),
                                  [&](const GateEntry& e) { return e.name == name; });
    if (held) continue;
    std::vector<std::string> known;
    for (const GateEntry& e : suite.entries) known.push_back(e.name);
    throw InputError(suite.file + ": no entry named '" + name + "' (its entries: " + JoinNames(known) + ")");
  }
  return selected;
}

GateSuite SelectGateMethods(const GateSuite& suite, const std::vector<std::string>& methods) {
  const std::set<std::string> wanted(methods.begin(), methods.end());
  std::set<std::string> compared;
  for (const GateEntry& e : suite.entries) {
    if (!e.observability) compared.insert(EntryMethods(e, suite).begin(), EntryMethods(e, suite).end());
  }
  for (const std::string& name : wanted) {
    if (compared.count(name) > 0) continue;
    throw InputError(suite.file + ": no entry compares a method named '" + name + "' (its methods: " +
                     JoinNames(compared) + ")");
  }
  GateSuite selected = suite;
  const auto cut = [&](const std::vector<std::string>& list) {
    std::vector<std::string> kept;
    for (const std::string& m : list) {
      if (wanted.count(m) > 0 || m == kMethodFlight) kept.push_back(m);
    }
    return kept;
  };
  selected.methods = cut(suite.methods);
  for (GateEntry& e : selected.entries) {
    if (!e.methods.empty()) e.methods = cut(e.methods);
  }
  return selected;
}

bool SuiteGivesThresholdPool(const GateSuite& suite, const GateThreshold& threshold) {
  for (const GateEntry& e : suite.entries) {
    if (e.observability) {
      if (threshold.method == kMethodFlight && threshold.fault.empty() && threshold.pool.empty()) return true;
      continue;
    }
    const std::string fault = e.fault ? datasets::FaultLabel(*e.fault) : "";
    if (fault != threshold.fault || e.pool != threshold.pool) continue;
    const std::vector<std::string>& methods = EntryMethods(e, suite);
    if (std::find(methods.begin(), methods.end(), threshold.method) != methods.end()) return true;
  }
  return false;
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
  const std::vector<std::string> all_methods = KnownMethodNames();
  const std::vector<std::string>& metrics = MetricNames();
  std::set<std::string> seen;
  for (size_t i = 0; i < j["thresholds"].size(); ++i) {
    const Json& t = j["thresholds"][i];
    const std::string where = path + ": thresholds[" + std::to_string(i) + "]";
    if (!t.is_object()) throw InputError(where + ": expected an object");
    OnlyKeys(t, {"method", "metric", "fault", "pool", "max", "min", "tolerance", "why"}, where);
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
    if (t.contains("pool")) th.pool = StringField(t, "pool", where);
    const std::string label = MethodLabel(th.method, th.fault, th.pool);
    if (!seen.insert(label + " " + th.metric).second) {
      throw InputError(where + ": " + label + " " + th.metric + " is given twice");
    }
    result.thresholds.push_back(th);
  }
  return result;
}

}  // namespace hdabench::reference
