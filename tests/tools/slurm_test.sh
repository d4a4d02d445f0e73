#!/bin/bash
# A single-node Slurm on this machine (tools/slurm/local-cluster.sh: munged,
# slurmctld and slurmd on 127.0.0.1 only, started and stopped here), an
# observability study submitted as a 4-task job array with its merge job
# (tools/slurm/submit.sh), and the merged result checked against a
# one-process run byte for byte; then a small gate suite the same way, its
# table and verdict against one process's.
#   slurm_test.sh HDABENCH SOURCE_DIR WORK_DIR
# Exit codes: 0 passed, 1 failed, 77 skipped (not root, or Slurm or munge not
# installed: tools/debian-packages.txt lists them).
set -euo pipefail
hdabench=$1 source_dir=$2 work=$3
fail() { echo "FAILED: $*" >&2; exit 1; }
now_ms() { echo $(($(date +%s%N) / 1000000)); }
seconds_since() { local ms=$(($(now_ms) - $1)); printf '%d.%03d' $((ms / 1000)) $((ms % 1000)); }
if [[ $(id -u) != 0 ]]; then echo "skipped: slurmd must run as root to start jobs"; exit 77; fi
for program in munged slurmctld slurmd sbatch sinfo; do
  command -v "$program" >/dev/null || { echo "skipped: $program not installed"; exit 77; }
done

rm -rf "$work"
mkdir -p "$work"
cluster=$work/cluster
trap '"$source_dir/tools/slurm/local-cluster.sh" stop "$cluster" || true' EXIT
start=$(now_ms)
cluster_env=$("$source_dir/tools/slurm/local-cluster.sh" start "$cluster" 2) || fail "the local cluster did not start"
eval "$cluster_env"
echo "cluster up in $(seconds_since "$start") s: $(sinfo -h -o '%P %D %c %T')"
# Both daemons listen on loopback only.
listening=$(ss -ltnp | grep -E 'slurm(ctld|d)' || true)
echo "$listening"
[[ $(grep -c . <<<"$listening") -ge 2 ]] || fail "slurmctld and slurmd are not both listening"
if grep -vE '127\.0\.0\.1:' <<<"$listening" | grep -q .; then fail "a slurm daemon listens beyond loopback"; fi

# The study: one process, then 4 shards and the merge through Slurm.
study=(--geometry lateral,boresight --baseline 10:40:10 --pixel-noise 0.1,0.25 --points 30,50 --trials 300
  --no-figures --quiet)
"$hdabench" observability "${study[@]}" --threads 2 --out "$work/one" >/dev/null
start=$(now_ms)
"$source_dir/tools/slurm/submit.sh" observability --tasks 4 --wait --hdabench "$hdabench" --out "$work/array" \
  -- "${study[@]}" || fail "the study's job array or its merge failed: $(cat "$work/array/slurm/"*.log)"
echo "study through Slurm (4 shards + merge) in $(seconds_since "$start") s"
for k in 1 2 3 4; do
  [[ -f $work/array/shards/$k/settings.csv ]] || fail "shard $k wrote nothing"
  /usr/bin/python3 -c 'import json, sys; s = json.load(open(sys.argv[1]))["shard"]; sys.exit(s != {"index": int(sys.argv[2]), "count": 4})' \
    "$work/array/shards/$k/study.json" "$k" || fail "shard $k is not shard $k/4: $(grep -A3 '"shard"' "$work/array/shards/$k/study.json")"
done
for file in study.json settings.csv baselines.csv; do
  cmp "$work/one/$file" "$work/array/$file" || fail "$file differs between the job array and one process"
done
echo "study: study.json, settings.csv and baselines.csv identical to one process's ($(wc -l <"$work/one/settings.csv") lines)"

# A gate suite of three observability entries in 2 shards.
cat >"$work/suite.json" <<'JSON'
{"format": "hdabench-gate-suite", "format_version": 1, "methods": ["flight"],
 "entries": [
  {"name": "lateral-20", "observability": {"geometry": ["lateral"], "baselines_m": [20], "pixel_noise_px": [0.1], "trials": 300}},
  {"name": "lateral-30", "observability": {"geometry": ["lateral"], "baselines_m": [30], "pixel_noise_px": [0.1], "trials": 300}},
  {"name": "lateral-40", "observability": {"geometry": ["lateral"], "baselines_m": [40], "pixel_noise_px": [0.25], "trials": 300}}]}
JSON
cat >"$work/thresholds.json" <<'JSON'
{"format": "hdabench-gate-thresholds", "format_version": 1, "thresholds": [
 {"method": "flight", "metric": "observability_p95_deg", "max": 90},
 {"method": "flight", "metric": "observability_sigma_ratio", "max": 1.0}]}
JSON
gate=(--suite "$work/suite.json" --thresholds "$work/thresholds.json" --quiet)
rc_one=0
"$hdabench" gate "${gate[@]}" --out "$work/gate-one" >/dev/null 2>&1 || rc_one=$?
rc_array=0
"$source_dir/tools/slurm/submit.sh" gate --tasks 2 --wait --hdabench "$hdabench" --out "$work/gate-array" \
  -- "${gate[@]}" || rc_array=$?
[[ $rc_one == 1 ]] || fail "the one-process gate should fail its sigma-ratio threshold (exit $rc_one)"
[[ $rc_array == "$rc_one" ]] || fail "the gate through Slurm exited $rc_array, one process $rc_one: $(cat "$work/gate-array/slurm/merge.log")"
for file in gate.md gate.html; do
  cmp "$work/gate-one/$file" "$work/gate-array/$file" || fail "gate $file differs between Slurm and one process"
done
cmp "$work/gate-one/metrics.json" "$work/gate-array/metrics.json" || fail "gate metrics.json differs"
grep -q "FAILED flight observability_sigma_ratio" "$work/gate-array/slurm/merge.log" ||
  fail "the merge job's log does not name the failing metric"
echo "gate: gate.md, gate.html and metrics.json identical to one process's, the same verdict (exit $rc_one)"
echo PASSED
