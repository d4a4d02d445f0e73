// The gate's verdict as a person reads it: gate.md's table and gate.html.
#include "reference/gate/gate.h"

#include "reference/gate/internal/common.h"

namespace hdabench::reference {

using namespace gate_internal;  // NOLINT(google-build-using-namespace): the gate's own helpers

std::string GateTable(const std::vector<GateCheck>& checks) {
  std::ostringstream out;
  out << "| method | metric | value | threshold | margin | baseline | verdict |\n"
      << "| --- | --- | --- | --- | --- | --- | --- |\n";
  for (const GateCheck& c : checks) {
    const GateThreshold& t = c.threshold;
    const std::string threshold = t.max ? "<= " + FormatValue(*t.max) : ">= " + FormatValue(*t.min);
    std::string verdict = !c.has_value ? "FAIL (no data)" : c.passed ? "pass" : "FAIL";
    if (c.regressed) verdict += c.passed ? " but REGRESSED" : ", REGRESSED";
    out << "| " << MethodLabel(t.method, t.fault, t.pool) << " | " << t.metric << " | " << (c.has_value ? FormatValue(c.value) : "-")
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
        << util::HtmlEscape(MethodLabel(t.method, t.fault, t.pool)) << "</td><td>" << util::HtmlEscape(t.metric) << "</td><td>"
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

}  // namespace hdabench::reference
