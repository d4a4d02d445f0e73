# The sensor-fault study's figure (compiled into hdabench;
# reference/faults/CMakeLists.txt).
# Usage: faults_plots.py STUDY_DIR OUT_DIR
# Reads STUDY_DIR/faults.json; writes OUT_DIR/faults.png: one panel per fault
# with a magnitude, against it: the slope error median and 90th percentile
# (degrees, left axis, with their requirements) and the share of ROIs with a
# slope, the share within 2 predicted sigmas and the ROIs against the clean
# run's (right axis, with theirs); the clean run where the fault does nothing
# (magnitude 0, a gain of 1). The faults without a magnitude (lrf-absent, a
# repeated or dropped frame) share one more panel, beside the clean run: the
# errors as bars, the shares as markers. A case without a result is a cross
# at the bottom of its panel.
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


# The marker of the panel of the faults without a magnitude.
WITHOUT = object()


def requirement_lines(ax, shares, req):
    ax.axhline(req["max_slope_error_median_deg"], color="tab:blue", linestyle=":", linewidth=1.0)
    ax.axhline(req["max_slope_error_p90_deg"], color="tab:purple", linestyle=":", linewidth=1.0)
    shares.axhline(req["min_evaluated_share"], color="tab:green", linestyle=":", linewidth=1.0)
    shares.axhline(req["min_rois_vs_clean"], color="tab:brown", linestyle=":", linewidth=1.0)
    shares.axhline(req["min_within_two_sigma"], color="tab:orange", linestyle=":", linewidth=1.0)


def without_panel(ax, study, clean, names, req):
    """The clean run and each fault without a magnitude, side by side."""
    cases = [clean]
    for name in names:
        cases += [c for c in study["cases"] if c["fault"] == name]
    xs = list(range(len(cases)))
    ax.bar([x - 0.18 for x in xs], [value(c, "slope_error_median_deg") for c in cases], 0.36,
           color="tab:blue", alpha=0.7)
    ax.bar([x + 0.18 for x in xs], [value(c, "slope_error_p90_deg") for c in cases], 0.36,
           color="tab:purple", alpha=0.7)
    failed = [x for x, c in zip(xs, cases) if not c["ran"] or not c["applied"]]
    if failed:
        ax.plot(failed, [0.0] * len(failed), "x", color="red", markersize=8)
    ax.set_ylim(bottom=0.0)
    ax.set_xticks(xs)
    ax.set_xticklabels([c["case"] for c in cases], fontsize=7, rotation=20)
    ax.set_xlabel("faults without a magnitude")
    ax.set_ylabel("slope error (deg)")
    ax.grid(True, axis="y", alpha=0.3)
    shares = ax.twinx()
    shares.plot(xs, [value(c, "evaluated_share") for c in cases], "^", color="tab:green")
    shares.plot(xs, [value(c, "within_two_sigma") for c in cases], "v", color="tab:orange")
    shares.plot(xs, [min(value(c, "rois_vs_clean"), 1.05) for c in cases], "d", color="tab:brown")
    requirement_lines(ax, shares, req)
    shares.set_ylim(0.0, 1.05)
    shares.set_ylabel("share")


def main():
    study_dir, out_dir = sys.argv[1], sys.argv[2]
    with open(os.path.join(study_dir, "faults.json")) as f:
        study = json.load(f)
    req = study["requirements"]
    clean = next(c for c in study["cases"] if c["fault"] is None)
    faults = []
    without = []  # the faults without a magnitude: one panel together
    for c in study["cases"]:
        if c["fault"] is None:
            continue
        group = faults if c["unit"] else without
        if c["fault"] not in group:
            group.append(c["fault"])
    panels = faults + ([WITHOUT] if without else [])
    if not panels:
        panels = [None]
    columns = min(4, len(panels))
    rows = (len(panels) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.2 * rows), squeeze=False)
    for index, name in enumerate(panels):
        ax = axes[index // columns][index % columns]
        if name is None:
            ax.axis("off")
            ax.text(0.5, 0.5, "no fault in this study", ha="center", va="center")
            continue
        if name is WITHOUT:
            without_panel(ax, study, clean, without, req)
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
        requirement_lines(ax, shares, req)
        shares.set_ylim(0.0, 1.05)
        shares.set_ylabel("share")
        if index == 0:
            lines = ax.get_legend_handles_labels()
            more = shares.get_legend_handles_labels()
            ax.legend(lines[0] + more[0], lines[1] + more[1], fontsize=7, loc="upper left")
    for index in range(len(panels), rows * columns):
        axes[index // columns][index % columns].axis("off")
    fig.suptitle("%s, frames %d,%d:\nthe flight method under each fault (dotted: requirements)"
                 % (study["dataset"], study["frames"][0], study["frames"][1]), fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "faults.png"), dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
