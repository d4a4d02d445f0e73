#!/usr/bin/python3
"""An example of the bench's external method (docs/external-method.md).

Run as `plane_fit.py INPUT_JSON OUTPUT_JSON` by `hdabench compare
--methods external --external-program tools/external/plane_fit.py` (or a gate
suite's "external"). For every ROI it fits a plane to the flight method's own
points by total least squares, every point alike: the plane of the
points' centroid and their direction of least spread. It reads nothing else
of the input, and is a template for a team's own method: read the images, the
camera model and the navigation from the same input instead.

Exit status: 0 with the output written; 2 for bad arguments or an input it
cannot read (the message on stderr, which the bench shows as the column's
failure).
"""
import json
import sys

import numpy as np

# A fit is degenerate when the points' second direction of spread is under
# this share of their first: they lie on a line, and a line has no plane.
COLLINEAR_RATIO = 1e-6


def fit_roi(roi, min_points, up):
    """The output record of one ROI: its plane, or why there is none."""
    points = np.asarray(roi["flight_points_in_local_m"], dtype=float).reshape(-1, 3)
    record = {"id": roi["id"], "num_points": int(len(points))}
    if len(points) < max(3, min_points):
        record["status"] = "too few points"
        record["reason"] = f"{len(points)} of the flight method's points, fewer than {max(3, min_points)}"
        return record
    centroid = points.mean(axis=0)
    _, singular, vt = np.linalg.svd(points - centroid, full_matrices=False)
    if singular[1] <= COLLINEAR_RATIO * singular[0]:
        record["status"] = "degenerate"
        record["reason"] = f"{len(points)} points on a line"
        return record
    normal = vt[2]
    if normal.dot(up) < 0:
        normal = -normal
    distances = (points - centroid) @ normal
    record.update({
        "status": "ok",
        "reason": f"{len(points)} points, total least squares",
        "normal_in_local": normal.tolist(),
        "roughness_rms_m": float(np.sqrt(np.mean(distances ** 2))),
        "roughness_max_m": float(np.max(np.abs(distances))),
        "points_in_local_m": points.tolist(),
    })
    return record


def main(argv):
    if len(argv) != 3:
        print("usage: plane_fit.py INPUT_JSON OUTPUT_JSON", file=sys.stderr)
        return 2
    try:
        with open(argv[1], encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, ValueError) as e:
        print(f"{argv[1]}: cannot read the input: {e}", file=sys.stderr)
        return 2
    if data.get("format") != "hdabench-external-input" or data.get("format_version") != 1:
        print(f"{argv[1]}: not an hdabench-external-input of format_version 1", file=sys.stderr)
        return 2
    up = -np.asarray(data["gravity_in_local_mps2"], dtype=float)
    up /= np.linalg.norm(up)
    rois = [fit_roi(roi, int(data["min_points"]), up) for roi in data["rois"]]
    fitted = sum(1 for r in rois if r["status"] == "ok")
    output = {
        "format": "hdabench-external-output",
        "format_version": 1,
        "note": f"plane_fit.py: {fitted} of {len(rois)} ROIs fitted to the flight method's points",
        "rois": rois,
    }
    with open(argv[2], "w", encoding="utf-8") as f:
        json.dump(output, f)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
