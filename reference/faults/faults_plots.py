# The sensor-fault study's figure (compiled into hdabench;
# reference/faults/CMakeLists.txt).
# Usage: faults_plots.py STUDY_DIR OUT_DIR
# Reads STUDY_DIR/faults.json; writes OUT_DIR/faults.png: one panel per fault
# with a magnitude, against it: the slope error median and 90th percentile
# (degrees, left axis, with their requirements) and the share of ROIs with a
# slope and the share within 2 predicted sigmas (right axis, with theirs);
# the clean run where the fault does nothing (magnitude 0, a gain of 1). A
# case without a result is a cross at the
# bottom of its panel.
# Exit 3 when matplotlib is missing (the message says so).
import json
import math
import os
import sys

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("the fault plots need matplotlib (Debian: python3-matplotlib)")
    sys.exit(3)


def value(case, key):
    v = case.get(key)
    return math.nan if v is None else float(v)


def main():
    study_dir, out_dir = sys.argv[1], sys.argv[2]
    with open(os.path.join(study_dir, "faults.json")) as f:
        study = json.load(f)
    req = study["requirements"]
    clean = next(c for c in study["cases"] if c["fault"] is None)
    faults = []
    for c in study["cases"]:
        if c["fault"] is not None and c["unit"] and c["fault"] not in faults:
            faults.append(c["fault"])
    if not faults:
        faults = [None]
    columns = min(4, len(faults))
    rows = (len(faults) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.2 * rows), squeeze=False)
    for index, name in enumerate(faults):
        ax = axes[index // columns][index % columns]
        if name is None:
            ax.axis("off")
            ax.text(0.5, 0.5, "no fault with a magnitude in this study", ha="center", va="center")
            continue
        cases = [c for c in study["cases"] if c["fault"] == name and c["applied"]]
        # The clean run where the fault does nothing: a gain of 1, any other magnitude 0.
        neutral = 1.0 if cases and cases[0]["unit"] == "x" else 0.0
        points = sorted([(neutral, clean)] + [(c["magnitude"], c) for c in cases], key=lambda p: p[0])
        xs = [p[0] for p in points]
        ax.plot(xs, [value(c, "slope_error_median_deg") for _, c in points], "-o", markersize=3,
                color="tab:blue", label="median |error|")
        ax.plot(xs, [value(c, "slope_error_p90_deg") for _, c in points], "-s", markersize=3,
                color="tab:purple", label="p90 |error|")
        ax.axhline(req["max_slope_error_median_deg"], color="tab:blue", linestyle=":", linewidth=1.0)
        ax.axhline(req["max_slope_error_p90_deg"], color="tab:purple", linestyle=":", linewidth=1.0)
        failed = [p[0] for p in points if not p[1]["ran"]]
        if failed:
            ax.plot(failed, [0.0] * len(failed), "x", color="red", markersize=8, label="no result")
        ax.set_ylim(bottom=0.0)
        ax.set_xlabel("%s (%s)" % (name, cases[0]["unit"] if cases else ""))
        ax.set_ylabel("slope error (deg)")
        ax.grid(True, alpha=0.3)
        shares = ax.twinx()
        shares.plot(xs, [value(c, "evaluated_share") for _, c in points], "-^", markersize=3, color="tab:green",
                    label="share with a slope")
        shares.plot(xs, [value(c, "within_two_sigma") for _, c in points], "-v", markersize=3, color="tab:orange",
                    label="within 2 sigma")
        shares.plot(xs, [min(value(c, "rois_vs_clean"), 1.05) for _, c in points], "-d", markersize=3,
                    color="tab:brown", label="ROIs / clean's (at most 1.05 shown)")
        shares.axhline(req["min_evaluated_share"], color="tab:green", linestyle=":", linewidth=1.0)
        shares.axhline(req["min_rois_vs_clean"], color="tab:brown", linestyle=":", linewidth=1.0)
        shares.axhline(req["min_within_two_sigma"], color="tab:orange", linestyle=":", linewidth=1.0)
        shares.set_ylim(0.0, 1.05)
        shares.set_ylabel("share")
        if index == 0:
            lines = ax.get_legend_handles_labels()
            more = shares.get_legend_handles_labels()
            ax.legend(lines[0] + more[0], lines[1] + more[1], fontsize=7, loc="upper left")
    for index in range(len(faults), rows * columns):
        axes[index // columns][index % columns].axis("off")
    fig.suptitle("%s, frames %d,%d: the flight method under each fault (dotted: requirements)"
                 % (study["dataset"], study["frames"][0], study["frames"][1]), fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "faults.png"), dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
