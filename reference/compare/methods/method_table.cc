// The table of methods: the order of compare's columns, of `--methods`, of
// the CLI's help. Adding a method is one line here and its own file.
#include <algorithm>
#include <map>
#include <mutex>

#include "reference/compare/method.h"

namespace hdabench::reference {

MethodEntry FlightMethod();
MethodEntry FlightRefinedMethod();
MethodEntry ColmapNavMethod();
MethodEntry ColmapFreeMethod();
MethodEntry OpenGvMethod(OpenGvSolver solver);
MethodEntry DenseNavMethod();
MethodEntry PlaneNavMethod();
MethodEntry ExternalMethod();

namespace {

// The table, one line per method in column order; each function is defined
// in the method's own file of methods/.
std::vector<MethodEntry> BuiltInMethods() {
  std::vector<MethodEntry> table;
  table.push_back(FlightMethod());         // methods/flight.cc
  table.push_back(FlightRefinedMethod());  // methods/flight_refined.cc
  table.push_back(ColmapNavMethod());      // methods/colmap.cc
  table.push_back(ColmapFreeMethod());     // methods/colmap.cc
  for (const OpenGvSolver solver : AllOpenGvSolvers()) table.push_back(OpenGvMethod(solver));  // methods/opengv.cc
  table.push_back(DenseNavMethod());       // methods/dense_nav.cc
  table.push_back(PlaneNavMethod());       // methods/plane_nav.cc
  table.push_back(ExternalMethod());       // methods/external.cc
  return table;
}

// The methods registered by ScopedMethodRegistration, in the order registered.
std::mutex g_registered_mutex;
std::vector<MethodEntry>& Registered() {
  static std::vector<MethodEntry> registered;
  return registered;
}

}  // namespace

std::vector<MethodEntry> MethodTable() {
  std::vector<MethodEntry> table = BuiltInMethods();
  const std::lock_guard<std::mutex> lock(g_registered_mutex);
  for (const MethodEntry& entry : Registered()) {
    const auto same = std::find_if(table.begin(), table.end(),
                                   [&](const MethodEntry& m) { return m.name == entry.name; });
    if (same != table.end()) {
      *same = entry;
    } else {
      table.push_back(entry);
    }
  }
  return table;
}

std::unique_ptr<MethodEntry> FindMethod(const std::string& name) {
  for (MethodEntry& entry : MethodTable()) {
    if (entry.name == name) return std::make_unique<MethodEntry>(std::move(entry));
  }
  return nullptr;
}

std::string MethodListText() {
  const std::vector<MethodEntry> table = MethodTable();
  size_t width = 0;
  for (const MethodEntry& m : table) width = std::max(width, m.name.size());
  std::string text;
  for (const MethodEntry& m : table) {
    text += "  " + m.name + std::string(width + 2 - m.name.size(), ' ') + m.summary + "\n";
  }
  return text;
}

ScopedMethodRegistration::ScopedMethodRegistration(MethodEntry entry) : name_(entry.name) {
  const std::lock_guard<std::mutex> lock(g_registered_mutex);
  Registered().push_back(std::move(entry));
}

ScopedMethodRegistration::~ScopedMethodRegistration() {
  const std::lock_guard<std::mutex> lock(g_registered_mutex);
  std::vector<MethodEntry>& registered = Registered();
  for (auto it = registered.end(); it != registered.begin();) {
    --it;
    if (it->name == name_) {
      registered.erase(it);
      break;
    }
  }
}

}  // namespace hdabench::reference
