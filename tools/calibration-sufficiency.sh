#!/bin/bash
# Does a calibration suffice for the HDA? Two calibrations of the default
# synthetic camera from the bench's own chessboard views, and the gate on the
# calibration's share of each slope's sigma (docs/calibration.md,
# "Calibrations that do and do not suffice"):
#   good: 30 views over the whole imager;
#   poor: 5 noisy, blurred views in the imager's top half, which leave the
#         HDA band's lower part (y 50-80 %) without a board.
# The default scene is rendered with the true camera; each calibration's
# model takes the dataset's camera.cameramodel. Each is run with the
# calibration check (--calibration-check) and gated alone with
# calibration_sigma_share_p90 <= 0.1 (the calibration under a tenth of the
# method's own sigma).
#
#   tools/calibration-sufficiency.sh OUT [HDABENCH]
#
# Exit 0 when the good calibration passes its gate and the poor one fails
# its own, as they must; 1 otherwise; 2 for a bad command line; 3 when a
# step fails (its message names it).
set -u -o pipefail

usage() { echo "usage: $0 OUT [HDABENCH]" >&2; exit 2; }
[ $# -ge 1 ] && [ $# -le 2 ] || usage
out=$1
hdabench=${2:-$(dirname "$0")/../build/tools/hdabench}
[ -x "$hdabench" ] || { echo "$0: $hdabench: not an executable (build first, or give HDABENCH)" >&2; exit 2; }
if [ -e "$out" ] && [ -n "$(ls -A "$out" 2>/dev/null)" ]; then
  echo "$0: $out exists and is not empty; choose a new OUT" >&2; exit 2
fi
mkdir -p "$out" || exit 3
out=$(cd "$out" && pwd)

# step NAME WHAT COMMAND...: runs COMMAND with its output in logs/NAME.txt.
mkdir -p "$out/logs" || exit 3
step() {
  local name=$1 what=$2
  shift 2
  echo "== $what" >&2
  "$@" > "$out/logs/$name.txt" 2>&1 || { echo "$0: failed: $* (log: $out/logs/$name.txt)" >&2; exit 3; }
}

step scene "the default scene, rendered with the true camera" \
  "$hdabench" synth --out "$out/scene" --frames pair --quiet
for kind in good poor; do
  if [ "$kind" = good ]; then
    views=(--views 30)
  else
    views=(--views 5 --region 0,1,0,0.5 --noise 8 --blur-px 1.5)
  fi
  step "$kind-views" "$kind: chessboard views" "$hdabench" chessboard --out "$out/$kind-views" "${views[@]}" --quiet
  step "$kind-calibration" "$kind: calibrate" "$hdabench" calibrate "$out/$kind-views"/board-*.png --board 9x6 --spacing 0.03 \
    --out "$out/$kind-calibration" --quiet
  mkdir -p "$out/$kind-dataset" && cp -r "$out/scene/." "$out/$kind-dataset/" &&
    cp "$out/$kind-calibration/camera-0.cameramodel" "$out/$kind-dataset/camera.cameramodel" || exit 3
  step "$kind-run" "$kind: the flight method with the calibration check" \
    "$hdabench" run "$out/$kind-dataset" --out "$out/$kind-run" --calibration-check 100 --quiet
  cat > "$out/$kind-suite.json" <<SUITE
{"format": "hdabench-gate-suite", "format_version": 1,
 "description": "the default scene with the $kind calibration of its camera",
 "methods": ["flight"],
 "entries": [{"name": "$kind", "dataset": "$kind-dataset"}]}
SUITE
  cat > "$out/$kind-thresholds.json" <<THRESHOLDS
{"format": "hdabench-gate-thresholds", "format_version": 1,
 "thresholds": [
  {"method": "flight", "metric": "calibration_sigma_share_p90", "max": 0.1,
   "why": "the calibration under a tenth of the flight method's own slope sigma (docs/calibration.md)"}]}
THRESHOLDS
  echo "== $kind: gate" >&2
  "$hdabench" gate --suite "$out/$kind-suite.json" --thresholds "$out/$kind-thresholds.json" \
    --out "$out/$kind-gate" --quiet > "$out/logs/$kind-gate.txt" 2>&1
  code=$?
  [ $code -le 1 ] || { echo "$0: the $kind gate failed to run (exit $code): $out/logs/$kind-gate.txt" >&2; exit 3; }
  eval "${kind}_gate=$code"
done

for kind in good poor; do
  code_var=${kind}_gate
  echo "$kind calibration: gate $([ "${!code_var}" -eq 0 ] && echo pass || echo FAIL)"
  grep -h "calibration_sigma_share_p90" "$out/logs/$kind-gate.txt" | head -1
  grep -hE "^calibration term|^slope error over|^tilt error|^calibration check" "$out/logs/$kind-run.txt"
done
[ "$good_gate" -eq 0 ] && [ "$poor_gate" -eq 1 ]
