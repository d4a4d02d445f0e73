#!/usr/bin/python3
# hdabench calibration analysis: what a mrcal calibration is worth for the HDA.
#
# Compiled into the hdabench library (calib/calibration_analysis_script.cc.in)
# and run by calib::AnalyseCalibration / calib::DiffCalibrations with Debian's
# /usr/bin/python3, which sees Debian's mrcal, numpy, OpenCV and matplotlib.
#
#   analyse --json OUT.json --figures DIR --opencv-dir DIR [geometry options] MODEL...
#   diff --json OUT.json --png HEATMAP.png A B [--gridn N] [--uncertainty-of-a]
#   modes --json OUT.json MODEL
#   resolve --json OUT.json [--samples N] [--seed S] MODEL
#
# The JSON format is "hdabench-calibration-analysis" (analyse) and
# "hdabench-calibration-diff" (diff), version 1: every number is finite or
# null, figure and model paths are relative to the JSON's folder, and the same
# inputs give the same bytes (seeded noise, single-threaded numerics, numbers
# rounded to 10 significant digits so that the last bit of a sum cannot show).
#
# Exit codes: 0 done; 3 unusable input (one line on stderr, naming the file);
# 5 a module cannot be imported; anything else is a failure of this script.

import os
import sys

# One thread for BLAS and OpenMP: mrcal's sparse solver and numpy then sum in
# a fixed order, so two runs on the same inputs agree to the last bit.
for _variable in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):
    os.environ.setdefault(_variable, '1')


def _use_reference_blas():
    '''Re-runs this script with Debian's reference (netlib) BLAS and LAPACK
    ahead of the system's choice. Debian picks ATLAS when it is installed, and
    ATLAS's kernels give results that depend on the memory alignment of its
    work buffers, which changes from call to call: OpenCV's rational-model
    calibration (ill-conditioned) then differs from run to run at the 1e-7
    level. The reference libraries have no such kernels; the problems here are
    small, so their speed does not matter. Without them, the system's BLAS is
    used as it is.'''
    if os.environ.get('HDABENCH_REFERENCE_BLAS') or not os.path.isfile(sys.argv[0]):
        return  # already chosen, or not run as a script (nothing to re-run)
    import sysconfig
    multiarch = sysconfig.get_config_var('MULTIARCH') or ''
    folders = [f'/usr/lib/{multiarch}/blas', f'/usr/lib/{multiarch}/lapack']
    libraries = [os.path.join(folders[0], 'libblas.so.3'),
                 os.path.join(folders[1], 'liblapack.so.3')]
    environment = dict(os.environ, HDABENCH_REFERENCE_BLAS='unavailable')
    if multiarch and all(os.path.isfile(f) for f in libraries):
        environment['HDABENCH_REFERENCE_BLAS'] = 'yes'
        environment['LD_LIBRARY_PATH'] = ':'.join(
            folders + [p for p in os.environ.get('LD_LIBRARY_PATH', '').split(':') if p])
        sys.stdout.flush()
        sys.stderr.flush()
        os.execve(sys.executable, [sys.executable] + sys.argv, environment)
    os.environ['HDABENCH_REFERENCE_BLAS'] = 'unavailable'


_use_reference_blas()

import argparse
import copy
import hashlib
import json
import math

EXIT_INPUT = 3
EXIT_NO_MODULE = 5
MESSAGE_PREFIX = 'hdabench-calibration-analysis: '

try:
    import numpy as np
    import mrcal
    import cv2
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    import matplotlib.colors
    import matplotlib.patches
except ImportError as e:
    sys.stderr.write(f'{MESSAGE_PREFIX}cannot import {e.name} under {sys.executable}: '
                     f'install Debian\'s python3-mrcal, python3-opencv, python3-matplotlib\n')
    sys.exit(EXIT_NO_MODULE)

ANALYSIS_FORMAT = 'hdabench-calibration-analysis'
DIFF_FORMAT = 'hdabench-calibration-diff'
FORMAT_VERSION = 1

COVERAGE_CELLS = 10            # the imager is cut into COVERAGE_CELLS x COVERAGE_CELLS cells
BAND_GRID = (16, 12)           # uncertainty samples over the HDA band (x, y)
IMAGER_GRID_WIDTH = 60         # imager-wide grids: 60 points across, rows to keep them square
MAX_FAILURE_NOTES = 5          # distinct failure messages kept per Monte Carlo


class InputProblem(Exception):
    '''Unusable input: the script exits with EXIT_INPUT and this one-line message.'''


def one_line(text):
    return ' '.join(str(text).split())


# ---------------------------------------------------------------- output

def clean(value):
    '''JSON-ready copy: numpy types to Python, floats rounded to 10 significant
    digits (so that sums in a different order cannot change the bytes), and
    every non-finite number to null.'''
    if isinstance(value, dict):
        return {str(k): clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return clean(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        value = float(value)
        if not math.isfinite(value):
            return None
        return float(f'{value:.10g}')
    return value


def write_atomically(path, write):
    '''Calls write(temporary_path), then renames: a reader never sees a half-written file.'''
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    temporary = os.path.join(folder, f'.{os.path.basename(path)}.{os.getpid()}.tmp')
    try:
        write(temporary)
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.remove(temporary)


def write_json(path, record):
    text = json.dumps(clean(record), indent=2, sort_keys=False, allow_nan=False) + '\n'

    def write(temporary):
        with open(temporary, 'w', encoding='utf-8') as f:
            f.write(text)
    write_atomically(path, write)


def save_figure(figure, path):
    # No "Software" entry: the PNG's bytes then depend on the drawing only.
    write_atomically(path, lambda temporary: figure.savefig(
        temporary, format='png', dpi=100, metadata={'Software': None}))
    plt.close(figure)


def relative_to(path, json_path):
    return os.path.relpath(os.path.abspath(path), os.path.dirname(os.path.abspath(json_path)))


def quantile(values, q):
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return float(np.quantile(values, q)) if values.size else None


def max_or_none(values):
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return float(np.max(values)) if values.size else None


def loaded_blas_lapack():
    '''File names of the BLAS/LAPACK libraries this process loaded: they
    decide the last bits of every solve, so the record names them.'''
    names = set()
    try:
        with open('/proc/self/maps', encoding='utf-8') as maps:
            for line in maps:
                path = line.split()[-1] if line.split() else ''
                name = os.path.basename(path)
                if path.startswith('/') and any(k in name for k in ('blas', 'lapack', 'atlas')) \
                        and name.startswith('lib'):
                    names.add(name)
    except OSError:
        pass
    return sorted(names)


def debian_package_version(package):
    '''The installed version of a Debian package (python3-mrcal has no
    Python package metadata), or None.'''
    try:
        with open('/var/lib/dpkg/status', encoding='utf-8', errors='replace') as status:
            current = None
            for line in status:
                if line.startswith('Package: '):
                    current = line[len('Package: '):].strip()
                elif current == package and line.startswith('Version: '):
                    return line[len('Version: '):].strip()
    except OSError:
        pass
    return None


def software_versions():
    return {'mrcal': debian_package_version('python3-mrcal'), 'numpy': np.__version__,
            'opencv': cv2.__version__, 'matplotlib': matplotlib.__version__,
            'blas_lapack': loaded_blas_lapack()}


# ---------------------------------------------------------------- models

def load_model(path, need_optimization_inputs):
    if not os.path.exists(path):
        raise InputProblem(f'{path}: no such file')
    if not os.path.isfile(path):
        raise InputProblem(f'{path}: is not a file; expected a mrcal .cameramodel')
    try:
        model = mrcal.cameramodel(path)
    except Exception as e:
        raise InputProblem(f'{path}: not a readable mrcal camera model ({one_line(e)})')
    if need_optimization_inputs and model.optimization_inputs() is None:
        raise InputProblem(
            f'{path}: the model holds no optimization_inputs; the analysis needs the model '
            f'written by mrcal-calibrate-cameras (re-saving a model elsewhere drops them)')
    return model


def imager_grid(width, height):
    '''The imager-wide grid of the heat maps: 60 points across, as many rows as
    keep the cells square (45 for 640 x 480).'''
    gridn_width = IMAGER_GRID_WIDTH
    gridn_height = max(2, int(round(gridn_width * height / width)))
    return gridn_width, gridn_height


def band_pixels(width, height, band):
    '''The HDA band in mrcal pixel coordinates. mrcal puts the centre of the
    top-left pixel at (0,0), so the imager spans [-0.5, W-0.5] and a fraction f
    of the width is at f*W - 0.5.'''
    return {'x0': band['x0'] * width - 0.5, 'x1': band['x1'] * width - 0.5,
            'y0': band['y0'] * height - 0.5, 'y1': band['y1'] * height - 0.5}


def in_band(q, band_px):
    return (q[..., 0] >= band_px['x0']) & (q[..., 0] <= band_px['x1']) & \
           (q[..., 1] >= band_px['y0']) & (q[..., 1] <= band_px['y1'])


def band_centre(band_px):
    return np.array(((band_px['x0'] + band_px['x1']) / 2., (band_px['y0'] + band_px['y1']) / 2.))


def solve_fingerprint(optimization_inputs):
    '''Models from one joint solve (camera-0 and camera-1 of a pair) share their
    optimization inputs; the Monte Carlo re-solves are then shared too.'''
    digest = hashlib.sha256()
    for key in ('observations_board', 'indices_frame_camintrinsics_camextrinsics',
                'intrinsics', 'frames_rt_toref', 'extrinsics_rt_fromref'):
        value = optimization_inputs.get(key)
        if value is not None:
            digest.update(np.ascontiguousarray(value).tobytes())
    return digest.hexdigest()


def board_residuals_px(optimization_inputs):
    '''mrcal's measurement vector and the per-corner residuals in pixels,
    shape (Nobservations, H, W, 2). mrcal scales a corner's residual by the
    corner's weight; dividing it out gives pixels.'''
    x = mrcal.optimizer_callback(**optimization_inputs, no_jacobian=True,
                                 no_factorization=True)[1]
    observations = optimization_inputs['observations_board']
    shape = observations.shape[:-1] + (2,)
    residuals = x[:int(np.prod(shape))].reshape(shape).copy()
    weight = observations[..., 2]
    inlier = weight > 0
    residuals[inlier] /= weight[inlier][:, None]
    residuals[~inlier] = np.nan
    return x, residuals


def corner_masks(observations):
    '''detected, inlier, outlier masks of the board corners.
    mrcal-calibrate-cameras stores an undetected corner as (-1, -1, -1) and
    marks a corner its outlier rejection threw out with a weight <= 0 while
    keeping its pixel coordinates (>= 0); so a corner is "detected" when its
    coordinates are not negative, an "outlier" when detected with weight <= 0.'''
    detected = (observations[..., 0] >= 0) & (observations[..., 1] >= 0)
    inlier = detected & (observations[..., 2] > 0)
    outlier = detected & ~inlier
    return detected, inlier, outlier


# ---------------------------------------------------------------- analyse: residuals and coverage

def residual_summary(model, optimization_inputs, x, residuals_px):
    icam = model.icam_intrinsics()
    observations = optimization_inputs['observations_board']
    indices = optimization_inputs['indices_frame_camintrinsics_camextrinsics']
    mine = indices[:, 1] == icam
    detected, inlier, outlier = corner_masks(observations)
    imagepaths = optimization_inputs.get('imagepaths')

    errors = np.linalg.norm(residuals_px, axis=-1)  # per corner, NaN for non-inliers
    own_inlier = inlier & mine[:, None, None]
    own_errors = errors[own_inlier]
    if own_errors.size == 0:
        raise InputProblem(
            f'{model_path_of(model)}: camera {icam} has no inlier corner in its solve')

    per_image = []
    for iobs in np.nonzero(mine)[0]:
        e = errors[iobs][inlier[iobs]]
        name = str(imagepaths[iobs]) if imagepaths is not None and iobs < len(imagepaths) \
            else f'observation {int(iobs)}'
        per_image.append({
            'image': name,
            'observation': int(iobs),
            'corners': int(np.count_nonzero(detected[iobs])),
            'inliers': int(e.size),
            'outliers': int(np.count_nonzero(outlier[iobs])),
            'rms_px': float(np.sqrt(np.mean(e * e))) if e.size else None,
            'worst_px': float(np.max(e)) if e.size else None,
        })

    own_residuals = residuals_px[own_inlier]
    return {
        # sqrt(mean(dx^2 + dy^2)) over this camera's inlier corners: the
        # reprojection error of a corner, in pixels.
        'rms_px': float(np.sqrt(np.mean(own_errors * own_errors))),
        'worst_px': float(np.max(own_errors)),
        'median_px': float(np.median(own_errors)),
        # The standard deviation of the inlier residual coordinates: the noise
        # level mrcal's uncertainty propagation assumes, and the noise the slope
        # Monte Carlo adds.
        'noise_stdev_px': float(np.std(own_residuals.ravel())),
        # mrcal-calibrate-cameras' printed "RMS error": sqrt(mean(x^2)) over the
        # whole measurement vector of the joint solve, i.e. per coordinate
        # (x and y count separately), outliers counted as 0 and the
        # regularization terms included. About rms_px / sqrt(2).
        'mrcal_rms_px': float(np.sqrt(np.mean(x * x))),
        'inliers': int(own_errors.size),
        'outliers': int(np.count_nonzero(outlier & mine[:, None, None])),
        'detected': int(np.count_nonzero(detected & mine[:, None, None])),
        'board_points': int(np.count_nonzero(mine)) * observations.shape[1] * observations.shape[2],
        'images': len(per_image),
        'per_image': per_image,
    }


def coverage_summary(points, width, height, band):
    '''Share of the imager's COVERAGE_CELLS x COVERAGE_CELLS cells holding at
    least one inlier corner. A cell belongs to the band when it overlaps the
    band by a positive area (the default band's edges fall on cell edges in y
    and through cell middles in x, so the band gets 6 x 4 cells).'''
    n = COVERAGE_CELLS
    # The imager spans [-0.5, W-0.5]: shift by half a pixel to get fractions.
    cx = np.clip(np.floor((points[:, 0] + 0.5) / width * n), 0, n - 1).astype(int)
    cy = np.clip(np.floor((points[:, 1] + 0.5) / height * n), 0, n - 1).astype(int)
    counts = np.zeros((n, n), dtype=int)
    np.add.at(counts, (cy, cx), 1)

    def overlapping(lo, hi):
        return [i for i in range(n) if min(hi, (i + 1) / n) - max(lo, i / n) > 1e-12]
    band_cells = [(iy, ix) for iy in overlapping(band['y0'], band['y1'])
                  for ix in overlapping(band['x0'], band['x1'])]
    band_covered = sum(1 for c in band_cells if counts[c] > 0)
    return {
        'cells': [n, n],
        'share': float(np.count_nonzero(counts)) / (n * n),
        'band_cells': len(band_cells),
        'band_share': band_covered / len(band_cells) if band_cells else None,
        # counts[row][column]: row 0 is the top of the image.
        'counts': counts.tolist(),
    }


def draw_band(axes, band_px, colour='red'):
    axes.add_patch(matplotlib.patches.Rectangle(
        (band_px['x0'], band_px['y0']), band_px['x1'] - band_px['x0'],
        band_px['y1'] - band_px['y0'], fill=False, edgecolor=colour, linewidth=2,
        label='HDA band'))


def imager_axes(axes, width, height, title):
    axes.set_xlim(-0.5, width - 0.5)
    axes.set_ylim(height - 0.5, -0.5)
    axes.set_aspect('equal')
    axes.set_xlabel('x (px)')
    axes.set_ylabel('y (px)')
    axes.set_title(title, fontsize=10)


def coverage_figure(path, inliers, outliers, width, height, band_px, title):
    figure, axes = plt.subplots(figsize=(8, 6.4))
    n = COVERAGE_CELLS
    for i in range(1, n):
        axes.axvline(i * width / n - 0.5, color='0.85', linewidth=0.8)
        axes.axhline(i * height / n - 0.5, color='0.85', linewidth=0.8)
    axes.plot(inliers[:, 0], inliers[:, 1], '.', color='tab:blue', markersize=3,
              label=f'{len(inliers)} inlier corners')
    if len(outliers):
        axes.plot(outliers[:, 0], outliers[:, 1], 'x', color='tab:orange', markersize=5,
                  label=f'{len(outliers)} outliers')
    draw_band(axes, band_px)
    imager_axes(axes, width, height, title)
    axes.legend(loc='upper right', fontsize=8)
    figure.tight_layout()
    save_figure(figure, path)


def heat_map_figure(path, values, width, height, band_px, title, label, log_scale,
                    points=None):
    figure, axes = plt.subplots(figsize=(8, 6.4))
    finite = values[np.isfinite(values)]
    if log_scale and finite.size and np.min(finite) > 0:
        # Uncertainty grows by orders of magnitude away from the observed
        # corners: a log scale keeps the band's structure visible.
        low = float(np.min(finite))
        norm = matplotlib.colors.LogNorm(vmin=low, vmax=max(float(np.max(finite)), low * 1.01))
    else:
        # The far corners of the imager can be many pixels off; saturate at the
        # 95th percentile so that the band's values keep their colours.
        top = float(np.quantile(finite, 0.95)) if finite.size else 1.0
        top = top if top > 0 else 1.0
        norm = matplotlib.colors.Normalize(vmin=0.0, vmax=top)
        label = f'{label}, saturated at {top:.3g}'
    image = axes.imshow(values, extent=(-0.5, width - 0.5, height - 0.5, -0.5),
                        origin='upper', interpolation='nearest', cmap='viridis', norm=norm)
    colourbar = figure.colorbar(image, ax=axes, shrink=0.85)
    colourbar.set_label(label)
    if isinstance(norm, matplotlib.colors.LogNorm):
        # Readable values, not just the decades, on the log scale.
        ticks = [t * 10.0 ** e for e in range(-3, 4) for t in (1, 2, 5)
                 if norm.vmin <= t * 10.0 ** e <= norm.vmax]
        colourbar.set_ticks(ticks)
        colourbar.set_ticklabels([f'{t:g}' for t in ticks])
        colourbar.minorticks_off()
    if points is not None and len(points):
        axes.plot(points[:, 0], points[:, 1], '.', color='white', markersize=1, alpha=0.5)
    if band_px is not None:
        draw_band(axes, band_px)
    imager_axes(axes, width, height, title)
    figure.tight_layout()
    save_figure(figure, path)


_model_paths = {}


def model_path_of(model):
    return _model_paths.get(id(model), '<model>')


# ---------------------------------------------------------------- uncertainty

def worst_stdev(model, q):
    '''mrcal's worst-direction standard deviation of the projection of the
    directions seen at pixels q, looking at infinity: at 570 m the HDA sees
    the ground at infinity compared with the few metres of the calibration
    boards, so the poses' translations do not matter, only their rotations.'''
    lensmodel, intrinsics = model.intrinsics()
    v = mrcal.unproject(np.ascontiguousarray(q, dtype=float), lensmodel, intrinsics, normalize=True)
    return mrcal.projection_uncertainty(v, model, atinfinity=True, what='worstdirection-stdev')


def band_grid_points(band_px):
    nx, ny = BAND_GRID
    xs = band_px['x0'] + (np.arange(nx) + 0.5) * (band_px['x1'] - band_px['x0']) / nx
    ys = band_px['y0'] + (np.arange(ny) + 0.5) * (band_px['y1'] - band_px['y0']) / ny
    return np.stack(np.meshgrid(xs, ys), axis=-1)


def uncertainty_summary(model, band_px, imager_q, imager_stdev):
    width, height = model.imagersize()
    band = worst_stdev(model, band_grid_points(band_px))
    centre = worst_stdev(model, np.array(((width - 1) / 2., (height - 1) / 2.)))
    at_band_centre = worst_stdev(model, band_centre(band_px))
    return {
        'what': 'worst-direction standard deviation of the projection, at infinity (mrcal)',
        'band_grid': list(BAND_GRID),
        'band_median_px': quantile(band, 0.5),
        'band_max_px': max_or_none(band),
        'band_centre_px': float(at_band_centre),
        'imager_centre_px': float(centre),
        'imager_grid': [imager_q.shape[1], imager_q.shape[0]],
        'imager_median_px': quantile(imager_stdev, 0.5),
        'imager_max_px': max_or_none(imager_stdev),
    }


# ---------------------------------------------------------------- projection difference

def rotation_fit_weights(*stdevs):
    '''Weights of the implied-rotation fit over a grid: 1/(sA*sB)^2 from the
    two models' projection uncertainties, the weighting mrcal-show-projection-diff
    uses, so that poorly constrained parts of the imager (no boards there)
    cannot drag the fit. A model without uncertainty counts as uncertain as
    the other; with none, every point weighs the same.'''
    known = [s for s in stdevs if s is not None]
    if not known:
        return None
    a = known[0]
    b = known[1] if len(known) > 1 else known[0]
    with np.errstate(divide='ignore', invalid='ignore'):
        weights = 1.0 / (a * b) ** 2
    weights[~np.isfinite(weights)] = 0.0
    return weights


def implied_rotation(q, v0, v1, weights=None, **focus):
    '''mrcal.implied_Rt10__from_unprojections at infinity (a rotation fit).
    mrcal starts that fit from a small random rotation drawn from numpy's
    global generator; seeding it before every fit makes each fit repeatable
    on its own, whatever ran before.'''
    np.random.seed(0)
    return mrcal.implied_Rt10__from_unprojections(q, v0, v1, weights=weights, atinfinity=True,
                                                  **focus)


def projection_difference(model_a, model_b, gridn_width, gridn_height, weights):
    '''Projection difference A -> B over the imager at infinity, after the
    rotation between the two camera frames that best lines them up: two
    calibrations of one lens differ by such a rotation, which the intrinsics
    cannot tell from a turn of the camera. Returns (|diff| grid, diff grid,
    pixel grid, Rt10).'''
    width, height = model_a.imagersize()
    lensmodels = [model_a.intrinsics()[0], model_b.intrinsics()[0]]
    intrinsics = [model_a.intrinsics()[1], model_b.intrinsics()[1]]
    v, q0 = mrcal.sample_imager_unproject(gridn_width, gridn_height, width, height,
                                          lensmodels, intrinsics, normalize=True)
    if weights is None:
        # Without uncertainties, fit where calibrations are usually good: a
        # circle around the centre (mrcal's own fallback).
        Rt10 = implied_rotation(
            q0, v[0], v[1],
            focus_center=np.array(((width - 1) / 2., (height - 1) / 2.)),
            focus_radius=min(width, height) / 6.)
    else:
        Rt10 = implied_rotation(q0, v[0], v[1], weights=weights)
    difflen, diff, q0, Rt10 = mrcal.projection_diff(
        (model_a, model_b), implied_Rt10=Rt10, gridn_width=gridn_width,
        gridn_height=gridn_height, use_uncertainties=False)
    return difflen, diff, q0, Rt10


def rotation_deg(Rt):
    return float(np.degrees(np.linalg.norm(mrcal.r_from_R(Rt[:3, :]))))


def difference_stats(difflen, q0, band_px=None):
    stats = {
        'median_px': quantile(difflen, 0.5),
        'p90_px': quantile(difflen, 0.9),
        'max_px': max_or_none(difflen),
        'grid': [q0.shape[1], q0.shape[0]],
        'points': int(np.count_nonzero(np.isfinite(difflen))),
    }
    if band_px is not None:
        inside = in_band(q0, band_px)
        stats['band_median_px'] = quantile(difflen[inside], 0.5)
        stats['band_max_px'] = max_or_none(difflen[inside])
        stats['band_points'] = int(np.count_nonzero(inside & np.isfinite(difflen)))
    return stats


# ---------------------------------------------------------------- OpenCV cross-check

def opencv_cross_check(model, optimization_inputs, model_out, json_path, figure_path,
                       band_px, imager_stdev, title):
    '''cv2.calibrateCamera with the rational model (OpenCV's 8 distortion
    coefficients, mrcal's LENSMODEL_OPENCV8) on every detected corner of the
    images mrcal used: OpenCV has no outlier rejection, so it gets the corners
    mrcal threw out too, as a user of OpenCV alone would.'''
    icam = model.icam_intrinsics()
    width, height = model.imagersize()
    observations = optimization_inputs['observations_board']
    indices = optimization_inputs['indices_frame_camintrinsics_camextrinsics']
    detected, inlier, _ = corner_masks(observations)
    # The same board: mrcal's reference chessboard (flat; OpenCV has no warp).
    board = mrcal.ref_calibration_object(observations.shape[2], observations.shape[1],
                                         optimization_inputs['calibration_object_spacing'])
    object_points, image_points, inlier_flags = [], [], []
    for iobs in np.nonzero(indices[:, 1] == icam)[0]:
        keep = detected[iobs]
        if np.count_nonzero(keep) < 6:
            continue  # too few for OpenCV's homography initialisation
        object_points.append(board[keep].astype(np.float32).reshape(-1, 1, 3))
        # mrcal and OpenCV both put the centre of the top-left pixel at (0,0).
        image_points.append(observations[iobs][keep][:, :2].astype(np.float32).reshape(-1, 1, 2))
        inlier_flags.append(inlier[iobs][keep])
    if len(object_points) < 3:
        return {'error': f'only {len(object_points)} image(s) with 6 or more detected corners'}
    rms, K, distortion, rvecs, tvecs = opencv_calibrate(object_points, image_points, width, height)
    intrinsics = np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2], *distortion])

    # OpenCV's rms is over every corner it got; over mrcal's inliers alone it
    # compares with the mrcal figure.
    inlier_errors = []
    for obj, img, rvec, tvec, flags in zip(object_points, image_points, rvecs, tvecs, inlier_flags):
        projected, _ = cv2.projectPoints(obj, rvec, tvec, K, distortion)
        e = np.linalg.norm(projected.reshape(-1, 2) - img.reshape(-1, 2).astype(float), axis=-1)
        inlier_errors.append(e[flags])
    inlier_errors = np.concatenate(inlier_errors)

    written = mrcal.cameramodel(intrinsics=('LENSMODEL_OPENCV8', intrinsics),
                                imagersize=np.array((width, height)))
    write_atomically(model_out, lambda temporary: written.write(
        temporary, note=f'hdabench: OpenCV calibrateCamera (CALIB_RATIONAL_MODEL) cross-check '
                        f'of camera {icam} of the mrcal solve; identity extrinsics (a mono solve)'))
    # The model as the file holds it (mrcal writes a limited number of
    # digits): the figures below then describe the file, and a later diff of
    # the file gives the same numbers.
    opencv_model = mrcal.cameramodel(model_out)
    intrinsics = opencv_model.intrinsics()[1]

    gridn_width, gridn_height = imager_grid(width, height)
    difflen, _, q0, Rt10 = projection_difference(
        model, opencv_model, gridn_width, gridn_height, rotation_fit_weights(imager_stdev, None))
    heat_map_figure(figure_path, difflen, width, height, band_px, title,
                    'projection difference mrcal vs OpenCV (px)', log_scale=False)
    diff = difference_stats(difflen, q0, band_px)
    diff['rotation_deg'] = rotation_deg(Rt10)

    # The same with mrcal's inliers only: separates what the outliers do to
    # OpenCV's solution from what the two solvers' models do (mrcal also fits
    # the board's warp, OpenCV takes it flat).
    keep = [(obj[flags], img[flags]) for obj, img, flags in
            zip(object_points, image_points, inlier_flags) if np.count_nonzero(flags) >= 6]
    inliers_only = {'error': 'fewer than 3 images with 6 or more inlier corners'}
    if len(keep) >= 3:
        rms_in, K_in, distortion_in, _, _ = opencv_calibrate(
            [k[0] for k in keep], [k[1] for k in keep], width, height)
        model_in = mrcal.cameramodel(
            intrinsics=('LENSMODEL_OPENCV8',
                        np.array([K_in[0, 0], K_in[1, 1], K_in[0, 2], K_in[1, 2], *distortion_in])),
            imagersize=np.array((width, height)))
        difflen_in, _, q0_in, Rt10_in = projection_difference(
            model, model_in, gridn_width, gridn_height, rotation_fit_weights(imager_stdev, None))
        inliers_only = {'error': None, 'corners': int(sum(len(k[0]) for k in keep)),
                        'rms_px': float(rms_in), **difference_stats(difflen_in, q0_in, band_px),
                        'rotation_deg': rotation_deg(Rt10_in)}
    return {
        'error': None,
        'model': relative_to(model_out, json_path),
        'flags': 'CALIB_RATIONAL_MODEL',
        'images': len(object_points),
        'corners': int(sum(len(p) for p in object_points)),
        # OpenCV's own figure: sqrt(mean(dx^2 + dy^2)) over every corner it got.
        'rms_px': float(rms),
        'rms_inliers_px': float(np.sqrt(np.mean(inlier_errors ** 2))),
        'intrinsics': intrinsics.tolist(),
        'diff': diff,
        'figure': relative_to(figure_path, json_path),
        'inliers_only': inliers_only,
    }


def opencv_calibrate(object_points, image_points, width, height):
    '''cv2.calibrateCamera with CALIB_RATIONAL_MODEL, single-threaded (so that
    it is repeatable); returns (rms, K, the 8 distortion coefficients, rvecs,
    tvecs). Raises when the result is not finite.'''
    cv2.setNumThreads(1)
    rms, K, distortion, rvecs, tvecs = cv2.calibrateCamera(
        object_points, image_points, (int(width), int(height)), None, None,
        flags=cv2.CALIB_RATIONAL_MODEL)
    distortion = np.asarray(distortion, dtype=float).ravel()[:8]
    if not (math.isfinite(rms) and np.all(np.isfinite(K)) and np.all(np.isfinite(distortion))):
        raise RuntimeError('cv2.calibrateCamera gave a non-finite result')
    return rms, K, distortion, rvecs, tvecs


# ---------------------------------------------------------------- slope Monte Carlo

def resolve_samples(optimization_inputs, noise_stdev_px, samples, seed):
    '''One entry per sample: (re-solved state, None) or (None, failure message);
    the state holds the solve's 'intrinsics' (all cameras), 'frames_rt_toref'
    and 'extrinsics_rt_fromref'.

    Why this is the calibration's own uncertainty: the inlier corners get
    Gaussian noise of the residual level the solve shows (the same level
    mrcal's analytic uncertainty assumes), and the problem is solved again from
    the nominal optimum. The spread of the re-solved intrinsics is then the
    spread a repeated calibration with this board dance would show. Outlier
    rejection is off so that every sample solves the same set of corners: a
    changing outlier set would add a different effect to the noise.'''
    rng = np.random.default_rng(seed)
    observations = optimization_inputs['observations_board']
    _, inlier, _ = corner_masks(observations)
    weight = np.where(inlier, observations[..., 2], 1.0)
    results = []
    for _ in range(samples):
        # Drawn before the solve, so that a failed sample cannot shift the
        # noise of the next ones.
        noise = rng.standard_normal(observations.shape[:-1] + (2,)) * noise_stdev_px
        trial = copy.deepcopy(optimization_inputs)
        # A corner of weight w has a residual w times its pixel error, so its
        # pixel noise is the residual level divided by w.
        trial['observations_board'][..., :2] += np.where(inlier[..., None],
                                                         noise / weight[..., None], 0.0)
        trial['do_apply_outlier_rejection'] = False
        trial['verbose'] = False
        try:
            stats = mrcal.optimize(**trial)
            intrinsics = np.array(trial['intrinsics'], dtype=float)
            if not np.all(np.isfinite(intrinsics)):
                raise RuntimeError('the re-solve gave non-finite intrinsics')
            if not math.isfinite(stats.get('rms_reproj_error__pixels', float('nan'))):
                raise RuntimeError('the re-solve gave a non-finite RMS')
            results.append(({'intrinsics': intrinsics,
                             'frames_rt_toref': np.array(trial['frames_rt_toref'], dtype=float),
                             'extrinsics_rt_fromref': np.array(trial['extrinsics_rt_fromref'],
                                                               dtype=float)}, None))
        except Exception as e:
            results.append((None, f're-solve: {one_line(e)}'))
    return results


def hda_geometry(model, band_px, geometry):
    '''The HDA viewing geometry in the camera frame of the first position: the
    line of sight through the band centre (the site is centred on it at the
    slant range, square and perpendicular to it), and the baseline, the first
    position moved perpendicular to the line of sight along the image's x
    direction, with the same orientation (one camera, two frames). The site
    itself, and the flight method's fit to it, are the bench's
    (reference::MakeHdaGeometrySite).'''
    lensmodel, intrinsics = model.intrinsics()
    q_centre = band_centre(band_px)
    sight = mrcal.unproject(q_centre, lensmodel, intrinsics, normalize=True)
    along_x = np.array((1.0, 0.0, 0.0)) - sight[0] * sight
    along_x /= np.linalg.norm(along_x)
    return {'q_centre': q_centre, 'sight': sight, 'baseline': geometry['baseline_m'] * along_x}


def board_rotation(optimization_inputs, trial, icam):
    """Rotation from the nominal to a re-solved camera frame as the board poses
    see it: the chordal mean over the boards of R_cam_board(re-solved) *
    R_cam_board(nominal)^T. mrcal's analytic uncertainty ties the camera frame
    to the boards the same way (to first order), so the spread of projections
    compensated this way is the like-for-like check of mrcal's figure."""
    icam_extrinsics = mrcal.corresponding_icam_extrinsics(icam, **optimization_inputs)

    def cam_from_boards(inputs):
        R_cam_ref = np.eye(3) if icam_extrinsics < 0 else \
            mrcal.R_from_r(inputs['extrinsics_rt_fromref'][icam_extrinsics][:3])
        return [R_cam_ref @ mrcal.R_from_r(rt[:3]) for rt in inputs['frames_rt_toref']]
    mean = np.mean([a @ b.T for a, b in zip(cam_from_boards(trial),
                                             cam_from_boards(optimization_inputs))], axis=0)
    u, _, vt = np.linalg.svd(mean)
    rotation = u @ vt
    if np.linalg.det(rotation) < 0:
        rotation = u @ np.diag((1.0, 1.0, -1.0)) @ vt
    return rotation


def resolved_rotation(lensmodel, intrinsics_resolved, q_grid, v_grid_nominal, weights):
    '''The implied rotation Rt10 (nominal frame -> re-solved) of a re-solved
    model, fitted over the imager grid q_grid (nominal directions
    v_grid_nominal) with `weights`.'''
    v_grid = mrcal.unproject(q_grid, lensmodel, intrinsics_resolved, normalize=True)
    if not np.all(np.isfinite(v_grid)):
        raise RuntimeError('unprojection with the re-solved model failed')
    return implied_rotation(q_grid, v_grid_nominal, v_grid, weights=weights)


def resolved_frame(model, intrinsics_resolved, geometry_frame, q_grid, v_grid_nominal, weights):
    '''What one re-solved calibration does to the projections: the rotation
    between the nominal and re-solved camera frames, fitted over the imager
    (weighted by the nominal uncertainty, as mrcal.projection_diff does), which
    the camera-to-lander alignment (calibrated separately) absorbs, and the
    projection offset at the band centre after it: where the re-solved model
    puts the direction the nominal model sees there. The slope error it causes
    is the bench's (the flight method's steps on the HDA site, in C++).
    Returns (band-centre offset in px (2,), Rt10: nominal frame -> re-solved).'''
    lensmodel, _ = model.intrinsics()
    Rt10 = resolved_rotation(lensmodel, intrinsics_resolved, q_grid, v_grid_nominal, weights)
    moved = mrcal.project(Rt10[:3, :] @ geometry_frame['sight'], lensmodel, intrinsics_resolved)
    return moved - geometry_frame['q_centre'], Rt10


def spread_stats(offsets):
    """RMS of 2-D projection offsets (px), and the square root of the larger
    eigenvalue of their second moment: the like-for-like figure beside mrcal's
    worst-direction standard deviation."""
    if len(offsets) < 2:
        return {'rms_px': None, 'worst_direction_stdev_px': None}
    offsets = np.array(offsets)
    moment = offsets.T @ offsets / len(offsets)
    return {'rms_px': float(np.sqrt(np.mean(np.sum(offsets ** 2, axis=-1)))),
            'worst_direction_stdev_px': float(np.sqrt(np.max(np.linalg.eigvalsh(moment))))}


def slope_summary(model, resolved, band_px, geometry, imager_q, imager_v, imager_stdev,
                  noise_stdev_px, seed):
    '''The re-solves of the slope Monte Carlo: each re-solved camera's
    intrinsics and implied rotation ("solved", for the bench to fit the HDA
    site with; it then adds the slope statistics and drops the list), and the
    projection spreads at the band centre.'''
    icam = model.icam_intrinsics()
    optimization_inputs = model.optimization_inputs()
    lensmodel, _ = model.intrinsics()
    frame = hda_geometry(model, band_px, geometry)
    weights = rotation_fit_weights(imager_stdev, None)
    record = {
        'error': None,
        'samples': len(resolved),
        'ok': 0,
        'failed': 0,
        'failures': [],
        'seed': seed,
        'noise_stdev_px': noise_stdev_px,
        'geometry': {
            'range_m': geometry['range_m'],
            'baseline_m': geometry['baseline_m'],
            'site_m': geometry['site_m'],
            'band_centre_px': frame['q_centre'],
            'line_of_sight': frame['sight'],
            'baseline_direction': frame['baseline'] / np.linalg.norm(frame['baseline']),
            'convergence_deg': float(np.degrees(math.atan2(geometry['baseline_m'],
                                                           geometry['range_m']))),
        },
    }
    solved, fitted_offsets, board_offsets, rotations = [], [], [], []
    for state, failure in resolved:
        if failure is None:
            try:
                intrinsics = state['intrinsics'][icam]
                offset, Rt10 = resolved_frame(model, intrinsics, frame, imager_q, imager_v, weights)
                R = board_rotation(optimization_inputs, state, icam)
                board_offset = mrcal.project(R @ frame['sight'], lensmodel, intrinsics) - \
                    frame['q_centre']
                rotation = mrcal.r_from_R(Rt10[:3, :])
                if not (np.all(np.isfinite(offset)) and np.all(np.isfinite(board_offset)) and
                        np.all(np.isfinite(rotation))):
                    raise RuntimeError('non-finite projection or rotation')
                solved.append({'intrinsics': intrinsics, 'rotation_rad': rotation})
                fitted_offsets.append(offset)
                board_offsets.append(board_offset)
                rotations.append(rotation_deg(Rt10))
                continue
            except Exception as e:
                failure = f'evaluation: {one_line(e)}'
        record['failed'] += 1
        if failure not in record['failures'] and len(record['failures']) < MAX_FAILURE_NOTES:
            record['failures'].append(failure)
    record['ok'] = len(solved)
    record['solved'] = solved
    record['rotation_fit_median_deg'] = quantile(rotations, 0.5)
    # The empirical projection spread at the band centre, two ways:
    # - after the fitted rotation (what the slope error sees; smaller, since
    #   the fit takes out every rotation the intrinsics can hide);
    # - after the board-pose rotation (mrcal's convention): to set beside
    #   mrcal's analytic worst-direction stdev, which it should match.
    record['band_centre_spread'] = {
        'fitted_rotation': spread_stats(fitted_offsets),
        'board_rotation': spread_stats(board_offsets),
    }
    return record


# ---------------------------------------------------------------- intrinsics modes

MODES_FORMAT = 'hdabench-calibration-modes'
RESOLVED_FORMAT = 'hdabench-calibration-resolved'
MODES_ENERGY = 0.999           # share of the compensated projection variance the modes keep
MAX_MODES = 40                 # at most this many modes


def intrinsics_covariance(model):
    '''Covariance of the optimized intrinsics of the model's camera, by
    mrcal's own propagation of the calibration's noise (the residual level
    of the solve, as mrcal.projection_uncertainty takes it) through the
    solve: Var(F) for F = the intrinsics. Returns (covariance (N, N) over
    every intrinsic, zero rows for those not optimized, noise stdev px).'''
    import mrcal.model_analysis as model_analysis
    oi = model.optimization_inputs()
    lensmodel, _ = model.intrinsics()
    icam = model.icam_intrinsics()
    _, x, jacobian, factorization = mrcal.optimizer_callback(**oi)
    if factorization is None:
        raise InputProblem(f'{model_path_of(model)}: mrcal cannot factorize the solve\'s '
                           f'J^T J, so the calibration has no uncertainty')
    count = mrcal.lensmodel_num_params(lensmodel)
    has_core = mrcal.lensmodel_metadata_and_config(lensmodel)['has_core']
    first = 0 if oi.get('do_optimize_intrinsics_core') or not has_core else 4
    last = count if oi.get('do_optimize_intrinsics_distortions') else (4 if has_core else 0)
    covariance = np.zeros((count, count))
    noise = float(np.std(mrcal.residuals_chessboard(oi, residuals=x).ravel()))
    if last <= first:
        return covariance, noise
    state = mrcal.state_index_intrinsics(icam, **oi)
    optimized = last - first
    dF_db = np.zeros((optimized, jacobian.shape[-1]))
    dF_db[:, state:state + optimized] = np.eye(optimized)
    mrcal.unpack_state(dF_db, **oi)  # the state is in the denominator
    boards = mrcal.num_measurements_boards(**oi)
    if boards == mrcal.num_measurements(**oi):
        boards = None
    covariance[first:last, first:last] = model_analysis._propagate_calibration_uncertainty(
        dF_db, factorization, jacobian, boards, noise, 'covariance')
    return 0.5 * (covariance + covariance.T), noise


def rotation_compensation(model, q, v, weights):
    '''The linear map M (3, N) from an intrinsics change d to the rotation
    r = M d (radians, Rodrigues, nominal frame -> perturbed frame) that best
    lines up the perturbed projections with the nominal ones over the pixels
    q (directions v), weighted: implied_rotation()'s fit to first order. A
    direction p then projects, with the rotation taken out, at
    q + (dq/dintrinsics + dq/dp (-[p]x) M) d. Returns (M, dq/dintrinsics
    (n, 2, N), dq/dr (n, 2, 3)) over the n pixels.'''
    lensmodel, intrinsics = model.intrinsics()
    _, dq_dp, dq_di = mrcal.project(v, lensmodel, intrinsics, get_gradients=True)
    skew = np.zeros(v.shape[:-1] + (3, 3))
    skew[..., 0, 1], skew[..., 0, 2], skew[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    skew[..., 1, 0], skew[..., 2, 0], skew[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    dq_dr = -np.einsum('...ij,...jk->...ik', dq_dp, skew).reshape(-1, 2, 3)
    dq_di = dq_di.reshape(-1, 2, dq_di.shape[-1])
    w = np.ones(len(dq_dr)) if weights is None else np.asarray(weights, dtype=float).ravel()
    normal = np.einsum('n,nij,nik->jk', w, dq_dr, dq_dr)
    right = np.einsum('n,nij,nik->jk', w, dq_dr, dq_di)
    return -np.linalg.solve(normal, right), dq_di, dq_dr


def intrinsics_modes(model):
    '''The calibration's uncertainty as a few independent modes: intrinsics
    changes d_k (1 sigma each, uncorrelated: Cov = sum d_k d_k^T, restricted
    to what moves a projection) with the implied rotation r_k = M d_k each
    brings. Ordered by how far they move the projections over the imager
    once the rotation is taken out, and kept until MODES_ENERGY of that
    variance (at most MAX_MODES). The rotation fit is weighted as the slope
    Monte Carlo's is: 1/stdev^4 of mrcal's projection uncertainty.'''
    covariance, noise = intrinsics_covariance(model)
    lensmodel, intrinsics = model.intrinsics()
    width, height = (int(v) for v in model.imagersize())
    gridn_width, gridn_height = imager_grid(width, height)
    v, q = mrcal.sample_imager_unproject(gridn_width, gridn_height, width, height,
                                         lensmodel, intrinsics, normalize=True)
    stdev = mrcal.projection_uncertainty(v, model, atinfinity=True, what='worstdirection-stdev')
    M, dq_di, dq_dr = rotation_compensation(model, q, v, rotation_fit_weights(stdev, None))
    compensated = dq_di + np.einsum('nij,jk->nik', dq_dr, M)            # (n, 2, N)
    values, vectors = np.linalg.eigh(covariance)
    root = vectors * np.sqrt(np.clip(values, 0.0, None))  # covariance = root root^T
    # Each grid point counts alike, however uncertain it is: its rows are
    # scaled by its own compensated stdev, so that the modes kept hold
    # MODES_ENERGY of the variance of the average point, not of the
    # imager's corners alone (where an unconstrained distortion dominates).
    per_point = np.einsum('nij,jk->nik', compensated, root)
    spread = np.sqrt(np.sum(per_point ** 2, axis=(1, 2)))
    scale = np.where(spread > 0, 1.0 / np.where(spread > 0, spread, 1.0), 0.0)
    _, singular, vt = np.linalg.svd((per_point * scale[:, None, None]).reshape(-1, root.shape[1]),
                                    full_matrices=False)
    energy = singular ** 2
    total = float(np.sum(energy))
    keep = 0
    while keep < min(MAX_MODES, len(energy)) and energy[keep] > 0 and \
            (keep == 0 or np.sum(energy[:keep]) < MODES_ENERGY * total):
        keep += 1
    modes = []
    for k in range(keep):
        d = root @ vt[k]
        # A fixed sign, so that the same model gives the same bytes.
        if d[np.argmax(np.abs(d))] < 0:
            d = -d
        moved = np.einsum('nij,j->ni', compensated, d)
        modes.append({'intrinsics_delta': d, 'rotation_rad': M @ d,
                      'projection_rms_px': float(np.sqrt(np.mean(np.sum(moved ** 2, axis=1))))})
    worst = np.sqrt([np.max(np.linalg.eigvalsh(c)) for c in
                     np.einsum('nij,jk,nlk->nil', compensated, covariance, compensated)])
    return {
        'lensmodel': lensmodel,
        'intrinsics': intrinsics,
        'imager_size': [width, height],
        'noise_stdev_px': noise,
        'intrinsics_stdev': np.sqrt(np.clip(np.diag(covariance), 0.0, None)),
        'imager_grid': [gridn_width, gridn_height],
        'imager_worst_stdev_median_px': quantile(stdev, 0.5),
        'compensated_worst_stdev_median_px': quantile(worst, 0.5),
        'variance_kept': float(np.sum(energy[:keep]) / total) if total > 0 else 1.0,
        'modes': modes,
    }


def modes(args):
    model = load_model(args.model, need_optimization_inputs=True)
    _model_paths[id(model)] = args.model
    record = {'format': MODES_FORMAT, 'format_version': FORMAT_VERSION,
              'software': software_versions(), 'model': args.model}
    record.update(intrinsics_modes(model))
    write_json(args.json, record)


def resolved_models(args):
    '''The calibration re-solved from perturbed corners (resolve_samples, as
    the slope Monte Carlo of analyse does), each re-solved camera's
    intrinsics with the implied rotation from the nominal frame fitted over
    the imager (weighted as the modes' linear fit is). For the bench's check
    of its predicted calibration sigmas against the spread the re-solves
    give.'''
    model = load_model(args.model, need_optimization_inputs=True)
    _model_paths[id(model)] = args.model
    if args.samples < 1:
        raise InputProblem(f'samples = {args.samples}: expected >= 1')
    oi = model.optimization_inputs()
    icam = model.icam_intrinsics()
    lensmodel, intrinsics = model.intrinsics()
    width, height = (int(v) for v in model.imagersize())
    gridn_width, gridn_height = imager_grid(width, height)
    v_nominal, q_grid = mrcal.sample_imager_unproject(gridn_width, gridn_height, width, height,
                                                      lensmodel, intrinsics, normalize=True)
    stdev = mrcal.projection_uncertainty(v_nominal, model, atinfinity=True,
                                         what='worstdirection-stdev')
    weights = rotation_fit_weights(stdev, None)
    x = mrcal.optimizer_callback(**oi, no_jacobian=True, no_factorization=True)[1]
    noise = float(np.std(mrcal.residuals_chessboard(oi, residuals=x).ravel()))
    samples = []
    failures = []
    for state, failure in resolve_samples(oi, noise, args.samples, args.seed):
        if failure is None:
            try:
                resolved = state['intrinsics'][icam]
                Rt10 = resolved_rotation(lensmodel, resolved, q_grid, v_nominal, weights)
                rotation = mrcal.r_from_R(Rt10[:3, :])
                if not (np.all(np.isfinite(resolved)) and np.all(np.isfinite(rotation))):
                    raise RuntimeError('non-finite intrinsics or rotation')
                samples.append({'intrinsics': resolved, 'rotation_rad': rotation})
                continue
            except Exception as e:
                failure = f'rotation fit: {one_line(e)}'
        samples.append(None)
        failures.append(failure)
    write_json(args.json, {
        'format': RESOLVED_FORMAT, 'format_version': FORMAT_VERSION,
        'software': software_versions(), 'model': args.model,
        'lensmodel': lensmodel, 'intrinsics': intrinsics,
        'noise_stdev_px': noise, 'seed': args.seed,
        'samples': samples, 'failures': failures[:MAX_FAILURE_NOTES],
        'failed': len(failures),
    })


# ---------------------------------------------------------------- analyse

def relative_pose(model0, model1):
    '''Pose of camera 1 relative to camera 0 from the models' extrinsics
    (rt_fromref), meaningful only when both come from one joint solve.'''
    Rt10 = mrcal.compose_Rt(model1.extrinsics_Rt_fromref(), model0.extrinsics_Rt_toref())
    Rt01 = mrcal.invert_Rt(Rt10)
    return {
        # Camera 1's centre in camera 0's frame, in board units (the
        # calibration object spacing's unit).
        'translation': Rt01[3, :],
        'baseline': float(np.linalg.norm(Rt01[3, :])),
        'rotation_deg': rotation_deg(Rt10),
    }


def analysis_settings(args):
    '''The HDA geometry and band of the arguments, checked: (geometry, band).'''
    geometry = {'range_m': args.range_m, 'baseline_m': args.baseline_m, 'site_m': args.site_m}
    band = {'x0': args.band_x0, 'x1': args.band_x1, 'y0': args.band_y0, 'y1': args.band_y1}
    problems = []
    if not (0.0 <= band['x0'] < band['x1'] <= 1.0):
        problems.append(f'band x {band["x0"]}..{band["x1"]}: expected 0 <= x0 < x1 <= 1')
    if not (0.0 <= band['y0'] < band['y1'] <= 1.0):
        problems.append(f'band y {band["y0"]}..{band["y1"]}: expected 0 <= y0 < y1 <= 1')
    for key, value in geometry.items():
        if not (math.isfinite(value) and value > 0):
            problems.append(f'{key} = {value}: expected > 0')
    if args.samples < 0:
        problems.append(f'samples = {args.samples}: expected >= 0')
    if problems:
        raise InputProblem('; '.join(problems))
    return geometry, band


def own_corners(model, oi):
    '''The inlier and outlier corners (pixels) of the model's own camera.'''
    icam = model.icam_intrinsics()
    mine = oi['indices_frame_camintrinsics_camextrinsics'][:, 1] == icam
    _, inlier, outlier = corner_masks(oi['observations_board'])
    return (oi['observations_board'][inlier & mine[:, None, None]][:, :2],
            oi['observations_board'][outlier & mine[:, None, None]][:, :2])


def camera_coverage(name, inliers, outliers, width, height, band, band_px, args):
    coverage = coverage_summary(inliers, width, height, band)
    coverage_png = os.path.join(args.figures, f'coverage-{name}.png')
    coverage_figure(coverage_png, inliers, outliers, width, height, band_px,
                    f'{name}: observed corners, {COVERAGE_CELLS} x {COVERAGE_CELLS} cells, '
                    f'{coverage["share"] * 100:.0f} % covered')
    coverage['figure'] = relative_to(coverage_png, args.json)
    return coverage


def camera_uncertainty(name, model, band_px, imager_v, imager_q, inliers, args):
    '''mrcal's projection uncertainty over the imager grid (the heat map, and
    the weights of the rotation fits): (summary, stdev grid or None).'''
    width, height = (int(v) for v in model.imagersize())
    try:
        imager_stdev = mrcal.projection_uncertainty(imager_v, model, atinfinity=True,
                                                    what='worstdirection-stdev')
        uncertainty = uncertainty_summary(model, band_px, imager_q, imager_stdev)
        uncertainty['error'] = None
        uncertainty_png = os.path.join(args.figures, f'uncertainty-{name}.png')
        heat_map_figure(uncertainty_png, imager_stdev, width, height, band_px,
                        f'{name}: projection uncertainty at infinity '
                        f'(worst direction, 1 sigma)',
                        'stdev (px), log scale', log_scale=True, points=inliers)
        uncertainty['figure'] = relative_to(uncertainty_png, args.json)
        return uncertainty, imager_stdev
    except Exception as e:
        return {'error': f'mrcal.projection_uncertainty: {one_line(e)}'}, None


def camera_slope(model, oi, x, band_px, geometry, imager_q, imager_v, imager_stdev, uncertainty,
                 args, resolved):
    '''The slope Monte Carlo of one camera; the re-solves are shared by the
    cameras of one joint solve (`resolved`, by solve fingerprint).'''
    if args.samples == 0:
        return {'error': 'skipped (0 samples asked for)', 'samples': 0, 'ok': 0, 'failed': 0}
    if imager_stdev is None:
        return {'error': 'needs the projection uncertainty (for the rotation fit), which failed',
                'samples': args.samples, 'ok': 0, 'failed': 0}
    # The noise level of the whole solve, as mrcal's uncertainty propagation
    # takes it: the stdev of every inlier residual coordinate (weighted, as
    # the solver sees them).
    solve_noise = float(np.std(mrcal.residuals_chessboard(oi, residuals=x).ravel()))
    key = solve_fingerprint(oi)
    if key not in resolved:
        resolved[key] = resolve_samples(oi, solve_noise, args.samples, args.seed)
    try:
        slope = slope_summary(model, resolved[key], band_px, geometry, imager_q, imager_v,
                              imager_stdev, solve_noise, args.seed)
        slope['mrcal_band_centre_stdev_px'] = uncertainty.get('band_centre_px')
        return slope
    except Exception as e:
        return {'error': f'slope Monte Carlo: {one_line(e)}', 'samples': args.samples,
                'ok': 0, 'failed': args.samples}


def camera_record(index, path, model, geometry, band, args, resolved):
    '''Everything the analysis says of one camera.'''
    oi = model.optimization_inputs()
    width, height = (int(v) for v in model.imagersize())
    lensmodel, intrinsics = model.intrinsics()
    band_px = band_pixels(width, height, band)
    name = f'camera-{index}'
    x, residuals_px = board_residuals_px(oi)
    inliers, outliers = own_corners(model, oi)
    # The imager-wide grid: heat map, rotation-fit weights of the OpenCV
    # diff and of the Monte Carlo.
    gridn_width, gridn_height = imager_grid(width, height)
    imager_v, imager_q = mrcal.sample_imager_unproject(gridn_width, gridn_height, width, height,
                                                       lensmodel, intrinsics, normalize=True)
    record = {
        'index': index,
        'name': name,
        'model': path,
        'icam_intrinsics': int(model.icam_intrinsics()),
        'lensmodel': lensmodel,
        'imager_size': [width, height],
        'band_px': band_px,
        'residuals': residual_summary(model, oi, x, residuals_px),
        'coverage': camera_coverage(name, inliers, outliers, width, height, band, band_px, args),
    }
    uncertainty, imager_stdev = camera_uncertainty(name, model, band_px, imager_v, imager_q,
                                                   inliers, args)
    record['uncertainty'] = uncertainty
    record['slope_error'] = camera_slope(model, oi, x, band_px, geometry, imager_q, imager_v,
                                         imager_stdev, uncertainty, args, resolved)
    try:
        record['opencv'] = opencv_cross_check(
            model, oi, os.path.join(args.opencv_dir, f'{name}.cameramodel'), args.json,
            os.path.join(args.figures, f'opencv-diff-{name}.png'), band_px, imager_stdev,
            f'{name}: projection difference mrcal vs OpenCV, after the implied rotation')
    except Exception as e:
        record['opencv'] = {'error': f'OpenCV cross-check: {one_line(e)}'}
    return record


def relative_poses(models):
    '''Cameras 1.. relative to camera 0, where they come from one solve.'''
    poses = []
    for index in range(1, len(models)):
        same_solve = solve_fingerprint(models[0].optimization_inputs()) == \
            solve_fingerprint(models[index].optimization_inputs())
        entry = {'camera': index, 'relative_to': 0, 'same_solve': same_solve}
        if same_solve:
            entry.update(relative_pose(models[0], models[index]))
        else:
            entry['note'] = \
                'the models come from different solves: their extrinsics are not related'
        poses.append(entry)
    return poses


ANALYSIS_DEFINITIONS = {
    'rms_px': 'sqrt(mean(dx^2 + dy^2)) over the camera\'s inlier corners: per corner',
    'mrcal_rms_px': 'mrcal-calibrate-cameras\' printed RMS: sqrt(mean(x^2)) over the joint '
                    'solve\'s measurement vector, per coordinate, outliers as 0, '
                    'regularization included; about rms_px / sqrt(2)',
    'uncertainty': 'mrcal.projection_uncertainty, worst-direction stdev, at infinity',
    'slope_error': 'angle between the plane the flight method\'s steps fit to the HDA site '
                   '(hda::EvaluateMatchedSite) and the site\'s true normal, from calibration '
                   'noise alone, after taking out the implied rotation of each re-solved '
                   'camera frame',
    'projection_diff': 'mrcal.projection_diff at infinity after the implied-rotation fit '
                       'weighted 1/(sA*sB)^2 by the projection uncertainties',
}


def analyse(args):
    geometry, band = analysis_settings(args)
    models = []
    for path in args.models:
        model = load_model(path, need_optimization_inputs=True)
        _model_paths[id(model)] = path
        models.append(model)
    resolved = {}  # solve fingerprint -> Monte Carlo re-solves
    cameras = [camera_record(index, path, model, geometry, band, args, resolved)
               for index, (path, model) in enumerate(zip(args.models, models))]
    write_json(args.json, {
        'format': ANALYSIS_FORMAT,
        'format_version': FORMAT_VERSION,
        'software': software_versions(),
        'settings': {
            'band': band,
            'geometry': geometry,
            'slope_samples': args.samples,
            'seed': args.seed,
            'coverage_cells': [COVERAGE_CELLS, COVERAGE_CELLS],
        },
        'definitions': ANALYSIS_DEFINITIONS,
        'cameras': cameras,
        'relative_poses': relative_poses(models),
    })


# ---------------------------------------------------------------- diff

def diff(args):
    model_a = load_model(args.models[0], need_optimization_inputs=args.uncertainty_of_a)
    model_b = load_model(args.models[1], need_optimization_inputs=False)
    size_a = [int(v) for v in model_a.imagersize()]
    size_b = [int(v) for v in model_b.imagersize()]
    if size_a != size_b:
        raise InputProblem(
            f'{args.models[1]}: imager {size_b[0]} x {size_b[1]} differs from '
            f'{args.models[0]}: {size_a[0]} x {size_a[1]}; the projection difference needs equal '
            f'imager sizes')
    if args.gridn < 2:
        raise InputProblem(f'gridn = {args.gridn}: expected >= 2')
    width, height = size_a
    gridn_width = args.gridn
    gridn_height = max(2, int(round(gridn_width * height / width)))

    # Both models' uncertainties weigh the rotation fit where they exist.
    def stdev_grid(model):
        if model.optimization_inputs() is None:
            return None
        lensmodel, intrinsics = model.intrinsics()
        v, _ = mrcal.sample_imager_unproject(gridn_width, gridn_height, width, height,
                                             lensmodel, intrinsics, normalize=True)
        try:
            return mrcal.projection_uncertainty(v, model, atinfinity=True,
                                                what='worstdirection-stdev')
        except Exception:
            return None
    stdev_a = stdev_grid(model_a)
    if args.uncertainty_of_a and stdev_a is None:
        raise InputProblem(f'{args.models[0]}: mrcal cannot compute its projection uncertainty')
    stdev_b = stdev_grid(model_b)
    difflen, _, q0, Rt10 = projection_difference(model_a, model_b, gridn_width, gridn_height,
                                                 rotation_fit_weights(stdev_a, stdev_b))
    record = {
        'format': DIFF_FORMAT,
        'format_version': FORMAT_VERSION,
        'software': software_versions(),
        'a': args.models[0],
        'b': args.models[1],
        'imager_size': size_a,
        'rotation_fit': 'uncertainty-weighted' if (stdev_a is not None or stdev_b is not None)
                        else 'centre circle of radius min(W,H)/6',
    }
    record.update(difference_stats(difflen, q0))
    record['rotation_deg'] = rotation_deg(Rt10)
    # The implied rotation itself (Rodrigues, A's frame -> B's), which the
    # bench's slope comparison at the HDA geometry takes out.
    record['rotation_rad'] = mrcal.r_from_R(Rt10[:3, :])
    if args.uncertainty_of_a:
        finite = np.isfinite(difflen) & np.isfinite(stdev_a)
        within = {}
        for k in (1, 2, 3):
            inside = np.count_nonzero(difflen[finite] <= k * stdev_a[finite])
            within[f'within_{k}_sigma'] = inside / np.count_nonzero(finite) \
                if np.count_nonzero(finite) else None
        record['uncertainty_of_a'] = {
            'what': 'worst-direction stdev of A\'s projection at infinity (mrcal), same grid',
            'median_px': quantile(stdev_a, 0.5),
            'max_px': max_or_none(stdev_a),
            'points': int(np.count_nonzero(finite)),
            **within,
        }
    heat_map_figure(args.png, difflen, width, height, None,
                    f'projection difference {os.path.basename(args.models[0])} -> '
                    f'{os.path.basename(args.models[1])}, after the implied rotation',
                    'projection difference (px)', log_scale=False)
    record['figure'] = relative_to(args.png, args.json)
    write_json(args.json, record)


# ---------------------------------------------------------------- main

def main():
    parser = argparse.ArgumentParser(prog='calibration_analysis.py')
    commands = parser.add_subparsers(dest='command', required=True)

    a = commands.add_parser('analyse', help='analyse the cameras of mrcal calibrations')
    a.add_argument('--json', required=True)
    a.add_argument('--figures', required=True)
    a.add_argument('--opencv-dir', required=True)
    a.add_argument('--band-x0', type=float, default=0.25)
    a.add_argument('--band-x1', type=float, default=0.75)
    a.add_argument('--band-y0', type=float, default=0.40)
    a.add_argument('--band-y1', type=float, default=0.80)
    a.add_argument('--range-m', type=float, default=570.0)
    a.add_argument('--baseline-m', type=float, default=30.0)
    a.add_argument('--site-m', type=float, default=10.0)
    a.add_argument('--samples', type=int, default=30)
    a.add_argument('--seed', type=int, default=1)
    a.add_argument('models', nargs='+')

    d = commands.add_parser('diff', help='projection difference between two calibrations')
    d.add_argument('--json', required=True)
    d.add_argument('--png', required=True)
    d.add_argument('--gridn', type=int, default=IMAGER_GRID_WIDTH)
    d.add_argument('--uncertainty-of-a', action='store_true',
                   help='add the projection uncertainty of A on the same grid and the share of '
                        'points whose difference is within 1, 2, 3 times it')
    d.add_argument('models', nargs=2)

    m = commands.add_parser('modes', help='the intrinsics uncertainty of a calibration as '
                                          'independent modes, with their implied rotations')
    m.add_argument('--json', required=True)
    m.add_argument('model')

    r = commands.add_parser('resolve', help='re-solve a calibration from perturbed corners: each '
                                            're-solved model\'s intrinsics and implied rotation')
    r.add_argument('--json', required=True)
    r.add_argument('--samples', type=int, default=30)
    r.add_argument('--seed', type=int, default=1)
    r.add_argument('model')

    args = parser.parse_args()
    try:
        if args.command == 'analyse':
            analyse(args)
        elif args.command == 'modes':
            modes(args)
        elif args.command == 'resolve':
            resolved_models(args)
        else:
            diff(args)
    except InputProblem as e:
        sys.stderr.write(MESSAGE_PREFIX + one_line(e) + '\n')
        sys.exit(EXIT_INPUT)


if __name__ == '__main__':
    main()
