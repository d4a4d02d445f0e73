#!/bin/bash
# Submits an observability study or a gate suite to Slurm as a job array of N
# shards and a merge job that runs when they have all ended (docs/slurm.md).
#
#   tools/slurm/submit.sh observability|gate --tasks N --out DIR [options] -- ARGS...
#
# ARGS are the command's own flags (`hdabench observability --help`, `hdabench
# gate --help`) but --out and --shard, which this script sets: shard k of N
# writes DIR/shards/k, the merge writes DIR, and the jobs' logs go to
# DIR/slurm/. Options:
#   --tasks N          shards (array tasks), default 4
#   --out DIR          the result folder; on a file system every node sees
#   --hdabench PATH    the hdabench program as the nodes see it (default: the
#                      one on PATH here, by its absolute path)
#   --cpus-per-task C  CPUs per shard (default 1): the study's --threads and
#                      the gate's --jobs unless ARGS give them
#   --sbatch ARG       passed to both sbatch calls (repeatable), e.g.
#                      --sbatch=--partition=batch --sbatch=--time=2:00:00
#   --wait             wait for the merge job and exit with its exit code
# Prints the two job ids. Exit codes: 0 submitted, 2 bad usage, 4 sbatch
# failed or missing; with --wait, the merge job's (hdabench's own: 1 for a
# gate that fails its thresholds, 3 for a shard missing or failed).
set -euo pipefail
die() { echo "submit.sh: $1" >&2; exit "${2:-2}"; }
usage() { sed -n '2,25p' "$0" | sed 's/^# \{0,1\}//'; }

[[ $# -ge 1 ]] || { usage >&2; exit 2; }
case $1 in
  -h | --help) usage; exit 0 ;;
  observability | gate) command=$1 ;;
  *) die "first argument '$1': expected observability or gate" ;;
esac
shift
tasks=4 out="" hdabench="" cpus=1 wait=0 sbatch_args=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --tasks) tasks=${2:-}; shift 2 || die "--tasks needs a value" ;;
    --tasks=*) tasks=${1#*=}; shift ;;
    --out) out=${2:-}; shift 2 || die "--out needs a value" ;;
    --out=*) out=${1#*=}; shift ;;
    --hdabench) hdabench=${2:-}; shift 2 || die "--hdabench needs a value" ;;
    --hdabench=*) hdabench=${1#*=}; shift ;;
    --cpus-per-task) cpus=${2:-}; shift 2 || die "--cpus-per-task needs a value" ;;
    --cpus-per-task=*) cpus=${1#*=}; shift ;;
    --sbatch) sbatch_args+=("${2:-}"); shift 2 || die "--sbatch needs a value" ;;
    --sbatch=*) sbatch_args+=("${1#*=}"); shift ;;
    --wait) wait=1; shift ;;
    --) shift; break ;;
    *) die "unknown option '$1' (the command's own flags go after --)" ;;
  esac
done
args=("$@")
[[ $tasks =~ ^[1-9][0-9]*$ ]] || die "--tasks '$tasks': expected a whole number >= 1"
[[ $cpus =~ ^[1-9][0-9]*$ ]] || die "--cpus-per-task '$cpus': expected a whole number >= 1"
[[ -n $out ]] || die "--out is required"
command -v sbatch >/dev/null || die "sbatch not found: install slurm-client and point it at the cluster (docs/slurm.md)" 4
if [[ -z $hdabench ]]; then
  hdabench=$(command -v hdabench) || die "hdabench not on PATH: give --hdabench PATH"
fi
[[ -x $hdabench ]] || die "--hdabench '$hdabench': not an executable file"
hdabench=$(realpath "$hdabench")
out=$(realpath -m "$out")

# The flags this script owns, and the ones the merge needs from ARGS.
given() { local flag; for flag in "${args[@]}"; do [[ $flag == "$1" || $flag == "$1="* ]] && return 0; done; return 1; }
value_of() {
  local i
  for ((i = 0; i < ${#args[@]}; i++)); do
    [[ ${args[i]} == "$1" ]] && { echo "${args[i + 1]:-}"; return; }
    [[ ${args[i]} == "$1="* ]] && { echo "${args[i]#*=}"; return; }
  done
}
for flag in --out --shard; do
  given "$flag" && die "$flag is set by this script: leave it out of ARGS"
done
shard_args=() merge_args=()
if [[ $command == observability ]]; then
  given --threads || shard_args+=(--threads "$cpus")
  given --no-figures || shard_args+=(--no-figures)
  given --no-figures && merge_args+=(--no-figures)
  given --python && merge_args+=(--python "$(value_of --python)")
else
  given --jobs || shard_args+=(--jobs "$cpus")
  for flag in --suite --thresholds; do
    given "$flag" || die "gate needs $flag in ARGS"
  done
  for flag in --suite --thresholds --baseline --write-baseline; do
    given "$flag" && merge_args+=("$flag" "$(realpath -m "$(value_of "$flag")")")
  done
  given --quiet && merge_args+=(--quiet)
fi

mkdir -p "$out/slurm" "$out/shards"
quoted() { local a; for a in "$@"; do printf ' %q' "$a"; done; }
{
  echo '#!/bin/bash'
  echo "# Shard \$SLURM_ARRAY_TASK_ID of $tasks (written by tools/slurm/submit.sh)."
  echo 'set -euo pipefail'
  echo 'k=$SLURM_ARRAY_TASK_ID'
  echo "exec$(quoted "$hdabench" "$command" "${args[@]}" "${shard_args[@]}") --shard \"\$k/$tasks\" --out $(printf '%q' "$out/shards")/\"\$k\""
} > "$out/slurm/shard.sh"
shard_dirs=()
for ((k = 1; k <= tasks; k++)); do shard_dirs+=("$out/shards/$k"); done
{
  echo '#!/bin/bash'
  echo "# The merge of the $tasks shards (written by tools/slurm/submit.sh)."
  echo 'set -euo pipefail'
  echo "exec$(quoted "$hdabench" "$command" merge "${shard_dirs[@]}" "${merge_args[@]}" --out "$out")"
} > "$out/slurm/merge.sh"
chmod +x "$out/slurm/shard.sh" "$out/slurm/merge.sh"

array_id=$(sbatch --parsable "${sbatch_args[@]}" --job-name="hdabench-$command" --array="1-$tasks" \
  --cpus-per-task="$cpus" --output="$out/slurm/shard-%a.log" "$out/slurm/shard.sh") ||
  die "sbatch refused the job array (see above)" 4
array_id=${array_id%%;*}
echo "job array $array_id: $tasks shards of hdabench $command into $out/shards/1..$tasks"
# afterany: the merge runs even when a shard failed, and says which.
merge_opts=(--parsable "${sbatch_args[@]}" --job-name="hdabench-$command-merge" --dependency="afterany:$array_id"
  --kill-on-invalid-dep=yes --output="$out/slurm/merge.log")
if ((wait)); then
  echo "merge job waits for $array_id; waiting for it"
  rc=0
  sbatch "${merge_opts[@]}" --wait "$out/slurm/merge.sh" >"$out/slurm/merge.jobid" || rc=$?
  merge_id=$(cut -d';' -f1 "$out/slurm/merge.jobid")
  if ((rc == 0)); then
    echo "merge job $merge_id done: $out (log $out/slurm/merge.log)"
  else
    echo "submit.sh: merge job ${merge_id:-?} ended with exit code $rc: see $out/slurm/merge.log" \
      "and $out/slurm/shard-*.log" >&2
  fi
  exit "$rc"
fi
merge_id=$(sbatch "${merge_opts[@]}" "$out/slurm/merge.sh") || die "sbatch refused the merge job (see above)" 4
echo "merge job ${merge_id%%;*}: runs when $array_id has ended; result in $out (log $out/slurm/merge.log)"
