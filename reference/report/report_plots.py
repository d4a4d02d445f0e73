# The plots of `hdabench report` (reference/report/report.h, docs/report.md), drawn
# with matplotlib's Agg backend from the files of a run or compare folder.
#
#   report_plots.py run|compare RUN_DIR OUT_DIR SERIES_JSON
#
# SERIES_JSON holds the slopes to draw, already decided by the bench
# (reference/report/report.cc PlotSeriesJson, with the one rule of
# reference/flight/slope_statistics.h): {"min_points": N, "series": [{"method",
# "samples": [{"roi", "slope_deg", "truth_deg", "sigma_deg", "num_points",
# "counts"}]}]}, "counts" true for a slope that enters the statistics. This
# script applies no rule of its own. It reads timings.json (run), or
# compare_timings.json and flight/timings.json (compare). Writes one PNG per
# plot that has data into OUT_DIR and OUT_DIR/plots.json, the list of the
# plots written in page order: [{"file", "title", "caption"}]. A plot without
# data is left out, never drawn empty. The PNGs are deterministic: fixed size
# and dpi, default style, no metadata but the format's own.
#
# The bench embeds this file into the hdabench binary at build time and runs
# it with Debian's python3 (ReportOptions::python). Exit codes: 0 every plot
# written; 3 an input file is missing or malformed; 5 matplotlib or numpy
# cannot be imported or used. The last line on stderr says what went wrong.
import json
import math
import os
import sys

EXIT_INPUT = 3
EXIT_NO_MATPLOTLIB = 5

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
except Exception as error:  # ImportError, or a broken or foreign matplotlib
    sys.stderr.write("matplotlib and numpy are needed for the report's plots (Debian: "
                     "python3-matplotlib) and cannot be used by %s: %s: %s\n"
                     % (sys.executable, type(error).__name__, error))
    sys.exit(EXIT_NO_MATPLOTLIB)

DPI = 100                 # pixels per inch of every PNG
FIG_SIZE_IN = (8.0, 5.0)  # width, height of a plot, inches (800 x 500 px)
PNG_METADATA = {"Software": None}  # no matplotlib version in the file


def fail_input(message):
    sys.stderr.write(message + "\n")
    sys.exit(EXIT_INPUT)


def read_json(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as error:
        fail_input("%s: cannot be read (%s)" % (path, error.strerror))
    except ValueError as error:
        fail_input("%s: not valid JSON (%s)" % (path, error))


def read_json_if_present(path):
    return read_json(path) if os.path.isfile(path) else None


def finite(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


class Sample:
    """One ROI of one method with a fitted slope, degrees, its number of points, and whether the
    bench counts it in the statistics."""

    def __init__(self, record):
        self.roi_id = record.get("roi")
        self.slope_deg = record["slope_deg"]
        truth, sigma = record.get("truth_deg"), record.get("sigma_deg")
        self.truth_deg = truth if finite(truth) else None    # None without truth
        self.sigma_deg = sigma if finite(sigma) else None    # None when not predicted or infinite
        self.num_points = record.get("num_points") or 0
        self.counts = record.get("counts") is True

    def error_deg(self):
        return None if self.truth_deg is None else self.slope_deg - self.truth_deg


def read_series(path):
    """({method: [Sample]} in the file's order, min_points) from the bench's series file."""
    data = read_json(path)
    try:
        series = {entry["method"]: [Sample(r) for r in entry["samples"] if finite(r.get("slope_deg"))]
                  for entry in data["series"]}
        return series, int(data["min_points"])
    except (KeyError, TypeError, ValueError) as error:
        fail_input("%s: not a series file of the bench (%s: %s)" % (path, type(error).__name__, error))


def method_colours(names):
    # tab10 while it lasts (the common case), tab20 beyond ten methods, so
    # that no two methods share a colour.
    cycle = plt.get_cmap("tab10" if len(names) <= 10 else "tab20").colors
    return {name: cycle[i % len(cycle)] for i, name in enumerate(names)}


class Plots:
    def __init__(self, out_dir):
        self.out_dir = out_dir
        self.written = []

    def save(self, fig, name, title, caption):
        fig.tight_layout()
        fig.savefig(os.path.join(self.out_dir, name), dpi=DPI, format="png",
                    metadata=PNG_METADATA)
        plt.close(fig)
        self.written.append({"file": name, "title": title, "caption": caption})


def new_axes():
    fig = plt.figure(figsize=FIG_SIZE_IN, dpi=DPI)
    return fig, fig.add_subplot(1, 1, 1)


def marker_sets(samples):
    """Samples split into those the statistics count and the others."""
    return [s for s in samples if s.counts], [s for s in samples if not s.counts]


def plot_slope_scatter(plots, series, colours, min_points):
    with_truth = {m: [s for s in ss if s.truth_deg is not None] for m, ss in series.items()}
    if not any(with_truth.values()):
        return
    fig, ax = new_axes()
    top = 0.0
    for method, samples in with_truth.items():
        if not samples:
            continue
        full, few = marker_sets(samples)
        colour = colours[method]
        if full:
            ax.scatter([s.truth_deg for s in full], [s.slope_deg for s in full], s=28,
                       color=colour, label="%s (%d)" % (method, len(full)))
        if few:
            ax.scatter([s.truth_deg for s in few], [s.slope_deg for s in few], s=28,
                       facecolors="none", edgecolors=colour,
                       label="%s, not counted (%d)" % (method, len(few)))
        top = max(top, max(max(s.truth_deg, s.slope_deg) for s in samples))
    top = max(1.0, top * 1.05)
    ax.plot([0.0, top], [0.0, top], color="black", linewidth=1.0, linestyle="--", label="y = x")
    ax.set_xlim(0.0, top)
    ax.set_ylim(0.0, top)
    ax.set_xlabel("true slope (deg)")
    ax.set_ylabel("estimated slope (deg)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    plots.save(fig, "slope_scatter.png", "Estimated against true slope",
               "One point per ROI with a fitted plane and truth, one colour per method; hollow "
               "markers: left out of the statistics (fewer than %d points, or a status without a "
               "slope the method stands by); dashed: y = x." % min_points)


def plot_error_histograms(plots, series, colours):
    errors = {m: [s.error_deg() for s in ss if s.truth_deg is not None] for m, ss in series.items()}
    errors = {m: e for m, e in errors.items() if e}
    if not errors:
        return
    every = [e for es in errors.values() for e in es]
    # Bins span zero and at least 1 deg, so that a single error still reads.
    low, high = min(min(every), 0.0), max(max(every), 0.0)
    if high - low < 1.0:
        middle = 0.5 * (low + high)
        low, high = middle - 0.5, middle + 0.5
    bins = np.linspace(low, high, 26)
    fig, ax = new_axes()
    for method, values in errors.items():
        ax.hist(values, bins=bins, histtype="step", linewidth=1.6, color=colours[method],
                label="%s (%d)" % (method, len(values)))
    ax.axvline(0.0, color="black", linewidth=0.8)
    ax.set_xlabel("slope error: estimated - true (deg)")
    ax.set_ylabel("number of ROIs")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    plots.save(fig, "slope_error_histogram.png", "Slope errors",
               "Histogram of estimated minus true slope per method, every ROI with a fit and "
               "truth (25 common bins).")


def scatter_abs_errors(ax, data, colours, x_of):
    """One scatter per method of |slope error| against x_of(sample); returns the largest x and
    the largest |error| drawn (0 when nothing is)."""
    top_x = top_error = 0.0
    for method, samples in data.items():
        if samples:
            ax.scatter([x_of(s) for s in samples], [abs(s.error_deg()) for s in samples],
                       s=24, color=colours[method], label=method)
            top_x = max(top_x, max(x_of(s) for s in samples))
            top_error = max(top_error, max(abs(s.error_deg()) for s in samples))
    return top_x, top_error


def plot_error_vs_points(plots, series, colours, min_points):
    data = {m: [s for s in ss if s.truth_deg is not None] for m, ss in series.items()}
    if not any(data.values()):
        return
    fig, ax = new_axes()
    _, top = scatter_abs_errors(ax, data, colours, lambda s: s.num_points)
    ax.axvline(min_points, color="grey", linewidth=1.0, linestyle=":",
               label="%d points (statistics)" % min_points)
    ax.set_xlabel("number of points in the plane fit")
    ax.set_ylabel("|slope error| (deg)")
    ax.set_xlim(left=0.0)
    ax.set_ylim(0.0, max(0.1, top * 1.1))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    plots.save(fig, "error_vs_points.png", "Slope error against number of points",
               "|estimated - true slope| of every ROI with a fit and truth against the number "
               "of points of its plane; dotted: the statistics' minimum.")


def plot_error_vs_sigma(plots, series, colours):
    data = {m: [s for s in ss if s.truth_deg is not None and s.sigma_deg is not None]
            for m, ss in series.items()}
    if not any(data.values()):
        return
    fig, ax = new_axes()
    top, worst = scatter_abs_errors(ax, data, colours, lambda s: s.sigma_deg)
    top = max(0.1, top * 1.05)
    ax.plot([0.0, top], [0.0, top], color="black", linewidth=1.0, linestyle="--",
            label="1 sigma")
    ax.plot([0.0, top], [0.0, 2.0 * top], color="black", linewidth=1.0, linestyle=":",
            label="2 sigma")
    ax.set_xlim(0.0, top)
    ax.set_ylim(0.0, max(0.1, worst * 1.1))
    ax.set_xlabel("predicted slope sigma (deg)")
    ax.set_ylabel("|slope error| (deg)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    plots.save(fig, "error_vs_sigma.png", "Slope error against predicted sigma",
               "|estimated - true slope| against the slope's predicted 1-sigma, every ROI with "
               "a fit, truth and a finite sigma; a consistent prediction keeps about 95 % of "
               "the points under the 2-sigma line.")


def plot_calibration_check(plots, check):
    """The calibration check of a run (hdabench run --calibration-check):
    each ROI's slope spread over the re-solved calibrations against its
    predicted calibration sigma."""
    if not check or not check.get("rois"):
        return
    fixed = [(r["predicted_slope_deg"], r["fixed_slope_rms_deg"]) for r in check["rois"]
             if finite(r.get("predicted_slope_deg")) and finite(r.get("fixed_slope_rms_deg"))
             and r["predicted_slope_deg"] > 0 and r["fixed_slope_rms_deg"] > 0]
    rerun = [(r["predicted_slope_deg"], r["rerun_slope_rms_deg"]) for r in check["rois"]
             if finite(r.get("predicted_slope_deg")) and finite(r.get("rerun_slope_rms_deg"))
             and r["predicted_slope_deg"] > 0 and r["rerun_slope_rms_deg"] > 0]
    if not fixed and not rerun:
        return
    fig, ax = new_axes()
    values = [v for pair in fixed + rerun for v in pair]
    low, high = min(values) / 1.5, max(values) * 1.5
    ax.plot([low, high], [low, high], color="black", linewidth=1.0, label="empirical = predicted")
    for factor, style in ((0.8, ":"), (1.25, ":")):
        ax.plot([low, high], [low * factor, high * factor], color="grey", linewidth=1.0, linestyle=style)
    if fixed:
        ax.scatter([p for p, _ in fixed], [e for _, e in fixed], s=14, color="tab:blue",
                   label="matches fixed")
    if rerun:
        ax.scatter([p for p, _ in rerun], [e for _, e in rerun], s=14, marker="x", color="tab:orange",
                   label="method re-run")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(low, high)
    ax.set_ylim(low, high)
    ax.set_xlabel("predicted calibration slope sigma (deg)")
    ax.set_ylabel("slope RMS over the re-solved calibrations (deg)")
    ax.grid(True, alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="best")
    plots.save(fig, "calibration_check.png", "Calibration sigma against the re-solved spread",
               f"Each ROI's slope spread over {check.get('solved')} re-solves of the calibration "
               f"against its predicted calibration sigma; dotted lines at 0.8 and 1.25 times.")


STAGES = [("convert_s", "convert"), ("quadtree_s", "quadtree"), ("prediction_s", "prediction"),
          ("matching_s", "matching"), ("rejection_s", "rejection"), ("plane_s", "plane fit"),
          ("ranking_s", "ranking"), ("total_s", "total")]


def plot_stage_timings(plots, timings):
    if not isinstance(timings, dict) or not isinstance(timings.get("stages"), dict):
        return
    stages = timings["stages"]
    rows = [(label, stages[key]) for key, label in STAGES if finite(stages.get(key))]
    if not rows:
        return
    budget = timings.get("budget_s")
    fig, ax = new_axes()
    x = np.arange(len(rows))
    colours = ["#55a868" if label == "total" else "#4c72b0" for label, _ in rows]
    ax.bar(x, [v for _, v in rows], color=colours)
    for i, (_, value) in enumerate(rows):
        ax.annotate("%.3f" % value, (i, value), ha="center", va="bottom", fontsize=8)
    if finite(budget):
        ax.axhline(budget, color="#c44e52", linewidth=1.5, linestyle="--",
                   label="budget %.2f s" % budget)
        ax.legend(fontsize=8, loc="upper left")
    ax.set_xticks(x)
    ax.set_xticklabels([label for label, _ in rows])
    ax.set_ylabel("wall time (s)")
    ax.grid(True, axis="y", alpha=0.3)
    exhausted = " The budget ran out: some ROIs were not evaluated." \
        if timings.get("budget_exhausted") else ""
    plots.save(fig, "stage_timings.png", "Flight method: time per stage against the budget",
               "Wall seconds of each stage of the flight method on this machine (timings.json; "
               "not deterministic); dashed: the time budget." + exhausted)


def plot_method_timings(plots, compare_timings, colours):
    if not isinstance(compare_timings, dict):
        return
    rows = [(m.get("name"), m.get("seconds")) for m in compare_timings.get("methods", [])
            if finite(m.get("seconds"))]
    if not rows:
        return
    fig, ax = new_axes()
    y = np.arange(len(rows))
    ax.barh(y, [v for _, v in rows], color=[colours.get(n, "#4c72b0") for n, _ in rows])
    for i, (_, value) in enumerate(rows):
        ax.annotate(" %.3f s" % value, (value, i), ha="left", va="center", fontsize=8)
    ax.set_yticks(y)
    ax.set_yticklabels([n for n, _ in rows])
    ax.invert_yaxis()
    ax.set_xlabel("wall time (s)")
    ax.set_xlim(0.0, max(v for _, v in rows) * 1.25 + 1e-9)
    ax.grid(True, axis="x", alpha=0.3)
    plots.save(fig, "method_timings.png", "Time per method",
               "Wall seconds of each method (compare_timings.json; not deterministic).")


def main(argv):
    if len(argv) != 5 or argv[1] not in ("run", "compare"):
        sys.stderr.write("usage: report_plots.py run|compare RUN_DIR OUT_DIR SERIES_JSON\n")
        return 2
    kind, run_dir, out_dir = argv[1], argv[2], argv[3]
    plt.style.use("default")
    plt.rcParams["svg.hashsalt"] = "hdabench"
    plots = Plots(out_dir)
    series, min_points = read_series(argv[4])
    if kind == "run":
        timings = read_json_if_present(os.path.join(run_dir, "timings.json"))
        compare_timings = None
    else:
        timings = read_json_if_present(os.path.join(run_dir, "flight", "timings.json"))
        compare_timings = read_json_if_present(os.path.join(run_dir, "compare_timings.json"))
    colours = method_colours(list(series.keys()))
    plot_slope_scatter(plots, series, colours, min_points)
    plot_error_histograms(plots, series, colours)
    plot_error_vs_points(plots, series, colours, min_points)
    plot_error_vs_sigma(plots, series, colours)
    plot_stage_timings(plots, timings)
    plot_method_timings(plots, compare_timings, colours)
    if kind == "run":
        plot_calibration_check(plots, read_json_if_present(os.path.join(run_dir, "calibration_check.json")))
    with open(os.path.join(out_dir, "plots.json"), "w", encoding="utf-8") as f:
        json.dump(plots.written, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
