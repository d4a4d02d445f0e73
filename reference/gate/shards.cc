// Shards: a suite's entries run in N processes (or Slurm tasks), each into
// its own folder with gate_shard.json, then merged into one folder.
#include "reference/gate/gate.h"

#include <unistd.h>

#include <map>
#include <set>

#include "reference/gate/internal/common.h"
#include "tools/util/files.h"

namespace hdabench::reference {

using namespace gate_internal;  // NOLINT(google-build-using-namespace): the gate's own helpers

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
