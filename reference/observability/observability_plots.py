# The observability study's figures, as the NOVA-C paper draws them
# (compiled into hdabench; reference/observability/CMakeLists.txt).
# Usage: observability_plots.py STUDY_DIR OUT_DIR
# Reads STUDY_DIR/settings.csv and STUDY_DIR/study.json; writes into OUT_DIR
#   slope_error_vs_baseline.png  per geometry: p95 (solid) and median (dashed)
#                                |slope error| against the baseline, one
#                                line per pixel noise, the requirement drawn
#   sigma_check.png              Monte Carlo standard deviation over the
#                                method's predicted sigma, against the
#                                baseline, per geometry and pixel noise
# Exit 3 when matplotlib is missing (the message says so).
import csv
import json
import math
import os
import sys

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("the observability plots need matplotlib (Debian: python3-matplotlib)")
    sys.exit(3)


def number(text):
    if text == "":
        return math.nan
    return float(text)


def main():
    study_dir, out_dir = sys.argv[1], sys.argv[2]
    with open(os.path.join(study_dir, "study.json")) as f:
        study = json.load(f)
    rows = []
    with open(os.path.join(study_dir, "settings.csv")) as f:
        for row in csv.DictReader(f):
            rows.append(row)
    requirement = study["requirement_deg"]
    geometries = study["geometries"]
    noises = study["pixel_noises_px"]
    points = study["points"][len(study["points"]) // 2] if study["points"] else 50
    colors = plt.cm.viridis([i / max(1, len(noises) - 1) * 0.85 for i in range(len(noises))])

    def series(geometry, noise, column):
        xs, ys = [], []
        for r in rows:
            if r["geometry"] == geometry and float(r["pixel_noise_px"]) == noise and int(r["points"]) == points:
                xs.append(float(r["baseline_m"]))
                ys.append(number(r[column]))
        return xs, ys

    fig, axes = plt.subplots(1, len(geometries), figsize=(6.0 * len(geometries), 4.2), sharey=True, squeeze=False)
    baselines = study["baselines_m"]
    for ax, geometry in zip(axes[0], geometries):
        drawn = 0
        for color, noise in zip(colors, noises):
            xs, p95 = series(geometry, noise, "p95_abs_error_deg")
            _, median = series(geometry, noise, "median_abs_error_deg")
            p95 = [y if math.isfinite(y) else math.nan for y in p95]
            median = [y if math.isfinite(y) else math.nan for y in median]
            drawn += sum(1 for y in median if math.isfinite(y))
            ax.plot(xs, p95, "-", color=color, label="%g px p95" % noise)
            ax.plot(xs, median, "--", color=color, label="%g px median" % noise)
        if drawn == 0:
            ax.text(0.5, 0.5, "fewer than half the trials fitted at any baseline:\n"
                    "the method refuses the site (too few points\nover the minimum parallax)",
                    transform=ax.transAxes, ha="center", va="center")
        if baselines:
            ax.set_xlim(min(baselines), max(baselines))
        ax.axhline(requirement, color="red", linewidth=1.0, label="requirement %g deg" % requirement)
        ax.set_yscale("log")
        ax.set_xlabel("baseline (m)")
        ax.set_title("%s motion, %d points per site" % (geometry, points))
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("|slope error| (deg)")
    axes[0][-1].legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "slope_error_vs_baseline.png"), dpi=100)
    plt.close(fig)

    fig, axes = plt.subplots(1, len(geometries), figsize=(6.0 * len(geometries), 3.6), sharey=True, squeeze=False)
    for ax, geometry in zip(axes[0], geometries):
        for color, noise in zip(colors, noises):
            xs, ratio = series(geometry, noise, "sd_over_sigma")
            ax.plot(xs, ratio, "-o", markersize=2.5, color=color, label="%g px" % noise)
        ax.axhspan(0.8, 1.2, color="green", alpha=0.12, label="within 20 %")
        ax.axhline(1.0, color="green", linewidth=0.8)
        ax.set_yscale("log")
        ax.set_xlabel("baseline (m)")
        ax.set_title("%s: Monte Carlo sd / predicted sigma" % geometry)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("sd / predicted sigma")
    axes[0][-1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "sigma_check.png"), dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    main()
