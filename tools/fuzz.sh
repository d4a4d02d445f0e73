#!/usr/bin/env bash
# The libFuzzer harnesses of every parser of outside input (tests/fuzz/,
# docs/fuzzing.md): builds them with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer into build-sanitize/ (the tree of the sanitizer
# tests too: tools/sanitize-tree.sh), and runs each from its seed
# corpus (the repository's own files of its kind, and the valid files the
# harness is built around) for a time or a number of runs.
#
#   tools/fuzz.sh [--seconds N | --runs N] [--only NAME[,NAME...]]
#
# Default: 30 seconds each (the test command's run), up to HDABENCH_JOBS
# harnesses at once, each on one core. Prints per harness the
# executions, the time, the corpus size and the crashes; a crash's input is
# kept in build-sanitize/fuzz-artifacts/ and the script exits 1. The corpus each
# run grows is kept in build-sanitize/fuzz-corpus/NAME and the next run starts
# from it. Environment: HDABENCH_FUZZ_BUILD_DIR (default build-sanitize),
# HDABENCH_JOBS (default: number of cores). Each harness's scratch files go to
# build-sanitize/fuzz-tmp/NAME (its TMPDIR), which it must leave empty. Exit codes:
# 0 no crash, 1 a harness crashed (or leaked memory or scratch files, or a
# sanitizer reported), 2 bad usage, 3 no clang or libFuzzer.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=${HDABENCH_FUZZ_BUILD_DIR:-$root/build-sanitize}
jobs=${HDABENCH_JOBS:-$(nproc)}
all=(npy png cameramodel dataset field_log colmap_model gate_files external_output report_records)
limit=(-max_total_time=30)
only=()

die() { printf 'tools/fuzz.sh: error: %s\n' "$1" >&2; exit "${2:-2}"; }

while (($#)); do
  case $1 in
    --seconds) [[ ${2:-} =~ ^[0-9]+$ ]] || die "--seconds needs a whole number"; limit=(-max_total_time="$2"); shift 2 ;;
    --runs) [[ ${2:-} =~ ^[0-9]+$ ]] || die "--runs needs a whole number"; limit=(-runs="$2"); shift 2 ;;
    --only) IFS=, read -r -a only <<<"${2:-}"; shift 2 ;;
    -h | --help) sed -n '2,20p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown argument '$1' (see tools/fuzz.sh --help)" ;;
  esac
done
((${#only[@]})) || only=("${all[@]}")
for name in "${only[@]}"; do
  [[ " ${all[*]} " == *" $name "* ]] || die "no harness '$name' (there are: ${all[*]})"
done

source "$root/tools/sanitize-tree.sh"
status=0
configure_sanitize_tree "$root" "$build_dir" || status=$?
((status == 0)) || die "the harnesses' tree $build_dir could not be configured" 3
printf '== Building the harnesses in %s\n' "$build_dir"
cmake --build "$build_dir" -j "$jobs" --target hdabench_fuzzers || die "building the harnesses failed" 1

# seeds NAME DIR SCRATCH: the seed corpus of a harness (rebuilt every run).
# The harness writes the valid files it is built around, with SCRATCH as its
# TMPDIR; its output goes to fuzz-logs/NAME-seeds.log. Returns the harness's
# exit status.
seeds() {
  local name=$1 dir=$2 scratch=$3 file status=0
  rm -rf "$dir"
  mkdir -p "$dir"
  HDABENCH_FUZZ_SEEDS=$dir TMPDIR=$scratch "$build_dir/tests/fuzz/${name}_fuzzer" -runs=0 "$dir" \
    >"$build_dir/fuzz-logs/$name-seeds.log" 2>&1 || status=$?
  case $name in
    npy) git -C "$root" ls-files '*.npy' '*.npz' | while read -r file; do cp "$root/$file" "$dir/$(echo "$file" | tr / -)"; done ;;
    cameramodel) git -C "$root" ls-files '*.cameramodel' | while read -r file; do cp "$root/$file" "$dir/$(echo "$file" | tr / -)"; done ;;
    png) git -C "$root" ls-files '*01.jpg' | while read -r file; do cp "$root/$file" "$dir/$(echo "$file" | tr / -)"; done ;;
    gate_files)
      # Index byte 0: the suite; 1: the thresholds.
      for file in "$root"/gate/suite*.json; do { printf '\000'; cat "$file"; } >"$dir/$(basename "$file")"; done
      for file in "$root"/gate/thresholds*.json; do { printf '\001'; cat "$file"; } >"$dir/$(basename "$file")"; done
      ;;
  esac
  return "$status"
}

# fuzz_one NAME: one harness from its corpus and seeds; its result row goes to
# fuzz-logs/NAME.row, and fuzz-logs/NAME.crashed exists when it crashed.
fuzz_one() {
  local name=$1 corpus=$build_dir/fuzz-corpus/$1 seed_dir=$build_dir/fuzz-seeds/$1
  local log=$build_dir/fuzz-logs/$1.log start end execs files status=0 verdict="no crash"
  # The harness's scratch files go to a folder of its own (TMPDIR), one for
  # the seed run and one for the fuzz run, which a run that ends without a
  # crash must leave empty.
  local scratch=$build_dir/fuzz-tmp/$1 seed_scratch=$build_dir/fuzz-tmp/$1-seeds left seed_status=0
  rm -rf "$scratch" "$seed_scratch"
  mkdir -p "$corpus" "$scratch" "$seed_scratch"
  rm -f "$build_dir/fuzz-logs/$name.row" "$build_dir/fuzz-logs/$name.crashed"
  seeds "$name" "$seed_dir" "$seed_scratch" || seed_status=$?
  if ((seed_status != 0)); then
    printf '%-14s %12s %8s %8s  %s\n' "$name" - - - \
      "SEED RUN FAILED (exit $seed_status): see $build_dir/fuzz-logs/$name-seeds.log" >"$build_dir/fuzz-logs/$name.row"
    touch "$build_dir/fuzz-logs/$name.crashed"
    return
  fi
  if [[ -n $(find "$seed_scratch" -mindepth 1 -maxdepth 1) ]]; then
    printf '%-14s %12s %8s %8s  %s\n' "$name" - - - "SEED RUN LEFT scratch entries in $seed_scratch" \
      >"$build_dir/fuzz-logs/$name.row"
    touch "$build_dir/fuzz-logs/$name.crashed"
    return
  fi
  start=$(date +%s)
  # Leak checking on; a timeout of 10 s per input; inputs up to 64 KB.
  TMPDIR=$scratch "$build_dir/tests/fuzz/${name}_fuzzer" "${limit[@]}" -timeout=10 -max_len=65536 \
    -print_final_stats=1 -artifact_prefix="$build_dir/fuzz-artifacts/$name-" "$corpus" "$seed_dir" \
    >"$log" 2>&1 || status=$?
  end=$(date +%s)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  files=$(find "$corpus" -type f | wc -l)
  left=$(find "$scratch" -mindepth 1 -maxdepth 1 | wc -l)
  if ((status != 0)); then
    verdict="CRASH (exit $status): $(grep -m1 -E 'ERROR: |SUMMARY: |runtime error' "$log" || tail -1 "$log")"
    touch "$build_dir/fuzz-logs/$name.crashed"
  elif ((left != 0)); then
    verdict="LEFT $left scratch entries in $scratch"
    touch "$build_dir/fuzz-logs/$name.crashed"
  fi
  printf '%-14s %12s %8s %8s  %s\n' "$name" "${execs:-?}" "$((end - start))" "$files" "$verdict" \
    >"$build_dir/fuzz-logs/$name.row"
}

# A harness is one process on one core, so up to $jobs run at once, each for
# the whole time or number of runs asked for.
mkdir -p "$build_dir/fuzz-artifacts" "$build_dir/fuzz-logs"
running=0
for name in "${only[@]}"; do
  if ((running >= jobs)); then
    wait -n || true
    running=$((running - 1))
  fi
  printf '== %s_fuzzer (%s)\n' "$name" "${limit[*]}"
  fuzz_one "$name" &
  running=$((running + 1))
done
wait
crashed=()
rows=()
for name in "${only[@]}"; do
  rows+=("$(cat "$build_dir/fuzz-logs/$name.row" 2>/dev/null || printf '%-14s %12s %8s %8s  %s' "$name" '?' '?' '?' 'NO RESULT')")
  if [[ -f $build_dir/fuzz-logs/$name.crashed || ! -f $build_dir/fuzz-logs/$name.row ]]; then crashed+=("$name"); fi
done
printf '\n%-14s %12s %8s %8s  %s\n' harness executions seconds corpus verdict
printf '%s\n' "${rows[@]}"
if ((${#crashed[@]})); then
  printf '\ntools/fuzz.sh: %s failed (verdicts above); inputs that crashed in %s, logs in %s\n' "${crashed[*]}" \
    "$build_dir/fuzz-artifacts" "$build_dir/fuzz-logs" >&2
  exit 1
fi
