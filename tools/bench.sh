#!/usr/bin/env bash
# hdabench set-up and the README's two commands.
#
#   tools/bench.sh run     install what is missing, build the hdabench program, run the main job on
#                          the built-in default dataset
#   tools/bench.sh test    install what is missing, build, run the whole test suite
#                          (the normal build), then the unit tests (label fast) built with
#                          clang's address + undefined-behaviour sanitizers into build-sanitize/,
#                          30 s of each libFuzzer harness from the same tree
#                          (tools/fuzz.sh), then the merge gate on the CI-sized suite
#                          (gate/suite-ci.json), and the same gate with every site declared safe,
#                          which must fail
#   tools/bench.sh setup   install what is missing and build, nothing else
#
# Debian packages come from tools/debian-packages.txt (the one list). apt runs only
# when something is missing, and the build is incremental, so a second run is fast
# and changes nothing. Environment: HDABENCH_BUILD_DIR (default build),
# HDABENCH_JOBS (default: number of cores), HDABENCH_SKIP_SANITIZE=1 to test the
# normal build only, HDABENCH_SKIP_FUZZ=1 to skip the fuzzing, HDABENCH_SKIP_GATE=1 to
# skip the gate.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
source "$root/tools/sanitize-tree.sh"
build_dir=${HDABENCH_BUILD_DIR:-$root/build}
jobs=${HDABENCH_JOBS:-$(nproc)}

# The bench's programs run with glibc's malloc asking for transparent huge
# pages for its large blocks (huge_pages COMMAND...): the scene generator and
# the methods touch hundreds of megabytes each, and a 2 MB page takes one
# fault where 4 kB pages take 512. The same results. Not the compiler: GCC
# takes a tenth longer with them.
# Added to any tunables already set.
huge_pages() {
  GLIBC_TUNABLES=${GLIBC_TUNABLES:+$GLIBC_TUNABLES:}glibc.malloc.hugetlb=1 "$@"
}

say() { printf '== %s\n' "$*"; }
die() { printf 'tools/bench.sh: error: %s\n' "$1" >&2; exit "${2:-1}"; }

install_packages() {
  local wanted=() missing=() pkg status
  mapfile -t wanted < <(sed -e 's/#.*//' -e '/^[[:space:]]*$/d' "$root/tools/debian-packages.txt")
  for pkg in "${wanted[@]}"; do
    status=$(dpkg-query -W -f='${db:Status-Abbrev}' "$pkg" 2>/dev/null || true)
    [[ $status == ii* ]] || missing+=("$pkg")
  done
  if ((${#missing[@]} == 0)); then
    say "Debian packages: all ${#wanted[@]} present"
    return
  fi
  say "Debian packages: installing ${#missing[@]} missing: ${missing[*]}"
  [[ $(id -u) -eq 0 ]] || die "installing packages needs root (missing: ${missing[*]})" 3
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq || die "apt-get update failed" 4
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null ||
    die "apt-get install failed for: ${missing[*]}" 4
}

# configure_and_build DIR [extra cmake args...]
# A new build folder is configured RelWithDebInfo with line tables only
# (-g1: file, line and function in every backtrace and profile, no variable
# locations), which compiles in two thirds of the time of -g and makes the
# same code, and as a unity build (a target's sources compiled in batches of
# eight: a third less compile time, the same code). Extra arguments come
# after, so they can change that.
# configure_and_build DIR [CMAKE_ARGS...]: the whole build, or only the targets
# named in $build_targets (space-separated) when it is set.
configure_and_build() {
  local dir=$1
  shift
  if [[ ! -f $dir/CMakeCache.txt ]]; then
    say "Configuring $dir"
    cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" -DCMAKE_UNITY_BUILD=ON "$@" >/dev/null
  fi
  local targets=()
  [[ -n ${build_targets:-} ]] && read -r -a targets <<<"--target $build_targets"
  say "Building $dir${build_targets:+ (${build_targets})}"
  cmake --build "$dir" -j "$jobs" "${targets[@]}" || die "build failed in $dir"
}

# run_tests DIR [ctest args...]
run_tests() {
  local dir=$1
  shift
  say "Testing $dir"
  huge_pages ctest --test-dir "$dir" --output-on-failure -j "$jobs" "$@"
}

# The merge gate on the CI-sized suite (gate/suite-ci.json against
# gate/thresholds-ci.json). Its folder is kept between runs: a rerun with the
# same build reuses complete entries. HDABENCH_SKIP_GATE=1 skips it.
run_gate() {
  [[ ${HDABENCH_SKIP_GATE:-0} == 1 ]] && return
  say "Gate (gate/suite-ci.json)"
  huge_pages "$build_dir/tools/hdabench" gate --suite "$root/gate/suite-ci.json" \
    --thresholds "$root/gate/thresholds-ci.json" --out "$build_dir/gate-ci"
  # The gate must catch a method that calls unsafe sites safe: the same suite
  # with every site declared safe (the slope limit raised to 89 deg and the
  # relief limit to 100 m) must fail on the landing decision of the steep
  # pool (docs/gate.md, "Catching an unsafe change"). Only that pool's entry
  # and the flight method run (--entries flank-s1 --methods flight), with the
  # flight method's thresholds of that pool; its scene is the gate's above
  # (the same build and suite make the same dataset folder, linked here).
  say "Gate on flank-s1 with every site declared safe (--set hda.max_slope_deg=89 hda.max_roughness_rms_m=100): must fail"
  local log="$build_dir/gate-ci-every-site-safe.log" status=0 what_if="$build_dir/gate-ci-every-site-safe"
  rm -rf "$what_if/datasets"
  mkdir -p "$what_if/datasets"
  cp -al "$build_dir"/gate-ci/datasets/flank-s1-* "$what_if/datasets/" 2>/dev/null ||
    say "(the gate's flank-s1 dataset could not be linked into $what_if: the entry makes it again)"
  huge_pages "$build_dir/tools/hdabench" gate --suite "$root/gate/suite-ci.json" \
    --thresholds "$root/gate/thresholds-ci.json" --out "$what_if" --entries flank-s1 --methods flight \
    --set hda.max_slope_deg=89 --set hda.max_roughness_rms_m=100 --quiet 2>"$log" || status=$?
  cat "$log"
  [[ $status == 1 ]] || die "the gate with every site declared safe exited $status, expected 1 (a failed metric)"
  grep -q "FAILED flight on steep unsafe_caught_rate = 0.000" "$log" ||
    die "the gate with every site declared safe did not fail on the flight method's unsafe_caught_rate ($log)"
}

command=${1:-}
case $command in
  setup)
    install_packages
    configure_and_build "$build_dir"
    ;;
  run)
    install_packages
    # The demo needs the program alone; the tests and benchmarks are built by `test` and `setup`.
    build_targets=hdabench configure_and_build "$build_dir"
    huge_pages "$build_dir/tools/hdabench" demo --out "$root/hdabench-demo"
    ;;
  test)
    install_packages
    configure_and_build "$build_dir"
    run_tests "$build_dir"
    # The unit tests (label fast) again under AddressSanitizer and
    # UndefinedBehaviorSanitizer, in the clang tree that also holds the
    # libFuzzer harnesses (tools/sanitize-tree.sh): one build of the modules
    # serves both.
    if [[ ${HDABENCH_SKIP_SANITIZE:-0} != 1 ]]; then
      status=0
      configure_sanitize_tree "$root" "${build_dir}-sanitize" || status=$?
      ((status == 0)) || die "configuring ${build_dir}-sanitize failed" "$status"
      configure_and_build "${build_dir}-sanitize"
      # The datasets the normal build's tests made are used as they are (the
      # same bytes, made several times faster than under the sanitizers).
      HDABENCH_TEST_DATASETS_FROM=$build_dir run_tests "${build_dir}-sanitize" -L fast
    fi
    # Every parser of outside input under libFuzzer for 30 s (docs/fuzzing.md).
    if [[ ${HDABENCH_SKIP_FUZZ:-0} != 1 ]]; then
      say "Fuzzing (tools/fuzz.sh --seconds 30)"
      HDABENCH_FUZZ_BUILD_DIR=${build_dir}-sanitize "$root/tools/fuzz.sh" --seconds 30 ||
        die "tools/fuzz.sh failed with exit $? (1: a harness failed or the harnesses did not build, 3: no clang or libFuzzer; its message above says which)"
    fi
    run_gate
    ;;
  -h | --help | help)
    sed -n '2,20p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
    ;;
  *)
    die "usage: tools/bench.sh run|test|setup (see tools/bench.sh --help)" 2
    ;;
esac
