# Sourced by tools/bench.sh and tools/fuzz.sh: the one clang tree (default
# build-sanitize/) that holds both the AddressSanitizer + UndefinedBehaviorSanitizer
# build of the unit tests and the libFuzzer harnesses. The modules are compiled
# once, with the sanitizers and libFuzzer's coverage counters; the tests link
# them with the sanitizers' runtime, the harnesses with libFuzzer.
#
# -O1, as the sanitizers' documentation advises (half the compile time of -O2
# under them, every check kept); the renderers' inner loops at -O2 (HOT in
# cmake/hdabenchTargets.cmake). A unity build (a target's sources compiled up
# to eight to a translation unit): a fifth less compile time, as in the
# normal build (tools/bench.sh). Precompiled headers, as in the normal build:
# clang then parses the standard library, Eigen, OpenCV's core and
# nlohmann/json once, not once per unit. The parsers of outside input, which carry libFuzzer's counters, compile without
# (clang takes no precompiled header made without the counters).

# sanitize_tree_clang: clang++ (14 first), or nothing.
sanitize_tree_clang() {
  command -v clang++-14 || command -v clang++ || true
}

# configure_sanitize_tree ROOT DIR: configures DIR unless it is this tree
# already. A folder configured otherwise (with GCC, or without the harnesses)
# is made anew: CMake cannot change a configured folder's compiler. Returns 3
# when there is no clang, 1 when configuring fails.
configure_sanitize_tree() {
  local root=$1 dir=$2 clang
  if [[ -f $dir/CMakeCache.txt ]]; then
    grep -q '^HDABENCH_FUZZ:BOOL=ON$' "$dir/CMakeCache.txt" &&
      grep -q '^HDABENCH_SANITIZE:BOOL=ON$' "$dir/CMakeCache.txt" && return 0
    printf '== %s was configured as another tree: made anew\n' "$dir"
    rm -rf "$dir"
  fi
  clang=$(sanitize_tree_clang)
  if [[ -z $clang ]]; then
    printf 'error: clang++ not found (Debian package clang-14, in tools/debian-packages.txt)\n' >&2
    return 3
  fi
  printf '== Configuring %s (clang, sanitizers and libFuzzer)\n' "$dir"
  cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" -DCMAKE_CXX_COMPILER="$clang" \
    -DCMAKE_C_COMPILER="${clang%++*}${clang##*++}" -DHDABENCH_SANITIZE=ON -DHDABENCH_FUZZ=ON \
    -DHDABENCH_PCH=ON -DCMAKE_UNITY_BUILD=ON >/dev/null || {
    printf 'error: configuring %s failed (is libFuzzer there: libclang-rt-14-dev?)\n' "$dir" >&2
    return 1
  }
}
