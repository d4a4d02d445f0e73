#!/usr/bin/python3
"""Calibrates the flight method's work model (hda/work_model.cc) against callgrind.

For each dataset, `hdabench run` is run under callgrind with the budget lifted
(every ROI evaluated), instructions counted inside RunHda only. The inclusive
instructions of the functions that do each unit's work are read from
callgrind's call graph and fitted, group by group, to the units the run
counted (result.json's flight_computer.work). Printed: the instructions per
unit, ready for hda/work_model.cc, and for every run the measured and the
predicted instructions, with the fit's leave-one-out error (the model fitted
without that run), which says how far the model can be trusted on a run it
has not seen.

  tools/calibrate-work-model.py --hdabench build/tools/hdabench --out DIR DATASET...

Needs valgrind (tools/debian-packages.txt). Exit codes: 0 done, 2 bad usage or
input, 3 a run failed.
"""

import argparse
import concurrent.futures
import json
import os
import re
import subprocess
import sys

import numpy as np

# Each group: the functions whose inclusive instructions it is (a name is
# matched as a substring of callgrind's demangled names), and the units that
# drive it. "refine" is what is left of MatchRoiPair after the other matching
# groups: the nav-aided refinement, inlined there.
GROUPS = [
    ("quadtree", ["hdabench::hda::RunQuadtree("], ["quadtree_pixels", "quadtree_blocks"]),
    ("prediction", ["hdabench::hda::PredictRoi(", "MarkUnobservableDepth("],
     ["predicted_rois", "iterated_predictions"]),
    ("orb", ["DetectInBox("], ["orb_pixels", "orb_keypoints"]),
    ("descriptors", ["MatchDescriptors("], ["descriptor_pairs"]),
    ("prewarp", ["cv::warpAffine("], ["prewarp_pixels"]),
    ("lucas-kanade", ["cv::calcOpticalFlowPyrLK("], ["tracked_points"]),
    ("unprojection", ["Normalised("], ["unprojected_pixels", "iterated_pixels"]),
    ("ransac", ["cv::findEssentialMat("], ["ransac_hypotheses", "ransac_tests"]),
    ("refine", None, ["refine_pixels"]),
    ("rejection", ["RejectAndTriangulate("], ["rejection_points"]),
    ("plane", ["FitAndClassify("], ["plane_points"]),
    ("convert", ["hdabench::hda::ToEightBit("], ["converted_pixels"]),
]
MATCHING_GROUPS = ["orb", "descriptors", "prewarp", "lucas-kanade", "unprojection", "ransac"]


def fail(message, code=2):
    print("calibrate-work-model: " + message, file=sys.stderr)
    sys.exit(code)


def call_costs(path):
    """The call graph's edges, (caller, callee, inclusive instructions of the
    calls), by function name. Callgrind splits an inlined function by source
    file into parts of the same name; calls between the parts are left out."""
    names = {}
    edges = {}
    caller = None
    callee = None
    pending = False

    def name_of(text):
        m = re.match(r"\((\d+)\)(?: (.*))?$", text)
        if not m:
            return text
        if m.group(2) is not None:
            names[m.group(1)] = m.group(2)
        return names[m.group(1)]

    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            line = line.rstrip("\n")
            if line.startswith("fn="):
                caller = name_of(line[3:])
            elif line.startswith("cfn="):
                callee = name_of(line[4:])
            elif line.startswith("calls="):
                pending = True
            elif pending and line and (line[0].isdigit() or line[0] in "+-*"):
                pending = False
                fields = line.split()
                if len(fields) >= 2 and callee != caller:
                    edges[(caller, callee)] = edges.get((caller, callee), 0) + int(fields[1])
    return edges


def summed(edges, patterns):
    """Inclusive instructions of the functions `patterns` name (substrings of
    callgrind's demangled names): the calls into them from functions the
    patterns do not name, so that a named function calling another is counted
    once."""
    named = lambda name: any(p in name for p in patterns)
    return sum(cost for (caller, callee), cost in edges.items() if named(callee) and not named(caller))


def measure(hdabench, dataset, out_dir):
    name = os.path.basename(os.path.normpath(dataset))
    run_dir = os.path.join(out_dir, name)
    profile = os.path.join(out_dir, name + ".callgrind")
    result_path = os.path.join(run_dir, "result.json")
    # A run already profiled in this folder is read again, not run again:
    # callgrind writes its profile when the program ends, after the result.
    done = (os.path.isfile(profile) and os.path.getsize(profile) > 0 and os.path.isfile(result_path)
            and os.path.getmtime(result_path) <= os.path.getmtime(profile))
    if not done:
        run_profiled(hdabench, dataset, run_dir, profile)
    return read_run(name, result_path, profile)


def run_profiled(hdabench, dataset, run_dir, profile):
    command = ["valgrind", "--tool=callgrind", "--callgrind-out-file=" + profile,
               "--toggle-collect=hdabench::hda::RunHda*", hdabench, "run", dataset, "--out", run_dir,
               "--quiet", "--no-figures", "--no-report", "--set", "hda.compute_budget_s=1e9"]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        fail(f"{' '.join(command)} exited {done.returncode}:\n{done.stderr[-2000:]}", 3)


def read_run(name, result_path, profile):
    with open(result_path, encoding="utf-8") as f:
        result = json.load(f)
    costs = call_costs(profile)
    groups = {}
    for group, patterns, _ in GROUPS:
        if patterns is not None:
            groups[group] = summed(costs, patterns)
    matching = summed(costs, ["hdabench::hda::MatchRoiPair("])
    groups["refine"] = matching - sum(groups[g] for g in MATCHING_GROUPS)
    total = summed(costs, ["hdabench::hda::RunHda("])
    return {"name": name, "work": result["flight_computer"]["work"], "groups": groups, "total": total,
            "rois": len(result["rois"])}


def fit_group(runs, units, group):
    """Instructions per unit, >= 0, minimising the runs' relative errors."""
    a = np.array([[float(r["work"][u]) for u in units] for r in runs])
    b = np.array([float(r["groups"][group]) for r in runs])
    weight = 1.0 / np.maximum(b, 1.0)
    used = [j for j in range(len(units)) if a[:, j].any()]
    best = np.zeros(len(units))
    if not used:
        return best
    candidates = [used] + [[j] for j in used] if len(used) > 1 else [used]
    best_error = None
    for columns in candidates:
        x, *_ = np.linalg.lstsq(a[:, columns] * weight[:, None], b * weight, rcond=None)
        if (x < 0).any():
            continue
        coefficients = np.zeros(len(units))
        coefficients[columns] = x
        error = float(np.sum(((a @ coefficients - b) * weight) ** 2))
        if best_error is None or error < best_error:
            best, best_error = coefficients, error
    return best


def fit(runs):
    coefficients = {}
    for group, _, units in GROUPS:
        for unit, c in zip(units, fit_group(runs, units, group)):
            coefficients[unit] = c
    return coefficients


def predicted(run, coefficients):
    return sum(coefficients[u] * float(run["work"][u]) for u in coefficients)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("datasets", nargs="+", metavar="DATASET", help="dataset folders (at least 3)")
    parser.add_argument("--hdabench", default="build/tools/hdabench", help="the hdabench program")
    parser.add_argument("--out", required=True, help="folder for the runs and the callgrind profiles")
    parser.add_argument("--jobs", type=int, default=2, help="runs at once")
    args = parser.parse_args()
    if len(args.datasets) < 3:
        fail("give at least 3 datasets: the leave-one-out error needs two runs to fit on")
    for d in args.datasets:
        if not os.path.isfile(os.path.join(d, "manifest.json")):
            fail(f"{d}: not a dataset folder (no manifest.json)")
    if not os.access(args.hdabench, os.X_OK):
        fail(f"{args.hdabench}: not an executable program (build first: tools/bench.sh build)")
    os.makedirs(args.out, exist_ok=True)
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        runs = list(pool.map(lambda d: measure(args.hdabench, d, args.out), args.datasets))

    coefficients = fit(runs)
    print("instructions per unit (hda/work_model.cc):")
    for _, _, units in GROUPS:
        for u in units:
            print(f"  {u:20s} {coefficients[u]:.4g}")
    print()
    print("run | ROIs | measured (G) | predicted (G) | error | left-out error | unmodelled")
    print("---|---|---|---|---|---|---")
    for i, run in enumerate(runs):
        others = runs[:i] + runs[i + 1:]
        left_out = predicted(run, fit(others))
        modelled = sum(run["groups"].values())
        p = predicted(run, coefficients)
        print(f"{run['name']} | {run['rois']} | {run['total'] / 1e9:.3f} | {p / 1e9:.3f} | "
              f"{100 * (p / run['total'] - 1):+.1f} % | {100 * (left_out / run['total'] - 1):+.1f} % | "
              f"{100 * (1 - modelled / run['total']):.1f} %")
    print()
    print("per group, measured / predicted (G):")
    for run in runs:
        parts = []
        for group, _, units in GROUPS:
            g = run["groups"][group]
            p = sum(coefficients[u] * float(run["work"][u]) for u in units)
            if g or p:
                parts.append(f"{group} {g / 1e9:.3f}/{p / 1e9:.3f}")
        print(f"  {run['name']}: " + ", ".join(parts))


if __name__ == "__main__":
    main()
