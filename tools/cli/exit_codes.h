// Exit codes of the hdabench binary. The README's "Exit codes" table lists the same.
#pragma once

namespace hdabench::tools {

constexpr int kExitOk = 0;              // the command did what was asked and every check passed
constexpr int kExitCheckFailed = 1;     // the command ran and found problems (invalid dataset, failed gate)
constexpr int kExitUsage = 2;           // bad command line: unknown command or flag, bad flag value
constexpr int kExitInput = 3;           // an input could not be used (missing, unreadable or malformed file)
constexpr int kExitExternal = 4;        // another program the bench runs failed (COLMAP, mrcal tools, the report's Python)
constexpr int kExitInternal = 70;       // a bug in hdabench: an unexpected exception
// 130 and 143: ended by SIGINT or SIGTERM (util::kExitInterrupted and
// util::kExitTerminated, tools/util/process.h), with the programs it started.

}  // namespace hdabench::tools
