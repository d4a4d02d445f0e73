// Synthetic chessboard views seen through a known camera model, for testing
// camera calibration end to end: render views, detect the corners, calibrate,
// and compare the solved model with the one the views were rendered through.
//
// Board frame (mrcal's and OpenCV's object-point convention): inner corner
// (i, j) is at (i * spacing_m, j * spacing_m, 0), i = 0 .. corners_x - 1 along
// x, j = 0 .. corners_y - 1 along y; z is the board normal, pointing away from
// the camera that sees the printed side. Pixels follow docs/conventions.md:
// the centre of the top-left pixel is (0, 0).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "calib/camera_model.h"
#include "calib/rigid3.h"

namespace hdabench::datasets::synth {

// A printed chessboard. It has (corners_x + 1) x (corners_y + 1) squares; the
// square diagonally outside inner corner (0, 0) is black. Around the squares
// runs a white margin margin_squares squares wide.
struct ChessboardBoard {
  int corners_x = 9;            // inner corners per row (OpenCV's patternSize.width), >= 2
  int corners_y = 6;            // rows of inner corners (patternSize.height), >= 2
  double spacing_m = 0.03;      // side of a square = distance between neighbouring corners, metres, > 0
  double margin_squares = 1.0;  // white margin around the squares, in squares, >= 0

  // One message per problem ("field = value: expected ..."); empty when usable.
  std::vector<std::string> Validate() const;
};

struct ChessboardViewsOptions {
  int views = 20;          // number of views, >= 1
  std::uint64_t seed = 1;  // poses, background gradients and noise all derive from it

  // Sensor and rendering.
  double noise_sigma = 2.0;  // standard deviation of the additive Gaussian noise, grey levels (of 255), >= 0
  int supersampling = 4;     // sub-pixel samples per pixel along each axis (n x n per pixel), 1 .. 16
  // Optics: standard deviation of a Gaussian point-spread function applied
  // to the noise-free image, pixels, [0, 10]; 0 = none (pixel integration
  // only, edges as sharp as the sensor allows).
  double blur_sigma_px = 0.0;
  double black = 30.0;   // grey level of a black square, [0, 255]
  double white = 220.0;  // grey level of a white square and of the margin, [0, 255], > black
  // Beyond the board: a mid-grey wall whose level changes linearly across the
  // imager by background_gradient (grey levels, end to end) in a direction
  // drawn per view, so the background is never flat.
  double background = 128.0;          // grey level at the imager centre, [0, 255]
  double background_gradient = 24.0;  // grey levels across the imager, >= 0

  // Distances. By default they follow from the apparent size of the board: at
  // fill 1 a face-on board at the imager centre, with its min_border_squares
  // border, just fits the imager; views spread evenly over
  // [min_fill, max_fill]. Setting both distances (metres, 0 < min <= max)
  // uses the range [min_distance_m, max_distance_m] instead (the distance is
  // from the camera centre to the centre of the inner corners).
  double min_fill = 0.35;       // (0, 1]
  double max_fill = 0.85;       // [min_fill, 1]
  double min_distance_m = 0.0;  // 0 (unused) or > 0
  double max_distance_m = 0.0;  // 0 (unused) or >= min_distance_m

  // Orientation. Tilt: angle between the board normal and the line of sight
  // to the board centre, about an axis in the board plane drawn uniformly.
  // Roll: rotation of the board about its normal, uniform in +-max_roll_deg.
  double min_tilt_deg = 10.0;  // [0, 80)
  double max_tilt_deg = 45.0;  // [min_tilt_deg, 80)
  double max_roll_deg = 20.0;  // [0, 180]

  // Placement. Each view aims at one of nine anchors (the imager's four
  // corners, four points along its edges and one near its centre; corners
  // first, each round of nine in a seeded order) and the board slides from
  // the imager centre toward its anchor as far as the border rule lets it.
  // For a corner or edge anchor six orientations are drawn and the one whose
  // corners come nearest to the anchor is kept. coverage scales the anchors
  // toward the centre: 1 reaches the whole imager, less gives a poorer set.
  double coverage = 1.0;  // (0, 1]
  // The part of the imager the boards stay in, as fractions of its width (x)
  // and height (y, 0 the top edge): every inner corner keeps the border rule
  // from this region's edges, the anchors and the fill are the region's, and
  // the rest of the imager sees no board (a calibration that leaves part of
  // the imager uncovered). 0 <= x0 < x1 <= 1, the same in y.
  double region_x0 = 0.0;
  double region_x1 = 1.0;
  double region_y0 = 0.0;
  double region_y1 = 1.0;
  // Border rule: every inner corner stays at least this many local square
  // sizes (its largest distance to a neighbouring corner, pixels) from the
  // imager's edge, so the outer squares and part of the margin are in view.
  double min_border_squares = 1.5;  // >= 1 (the outer squares must be seen)
  // Random poses drawn per view before giving up with InputError.
  int max_attempts = 1000;  // >= 1

  int threads = 0;  // render workers; 0 = every core this process may use (util::AvailableCores). Output does not depend on it.

  // One message per problem ("field = value: expected ..."); empty when usable.
  std::vector<std::string> Validate() const;
};

struct ChessboardView {
  cv::Mat image;  // CV_8UC1, camera.HeightPx() x camera.WidthPx()
  // Project() of the inner corners, pixels: row-major, corners_x per row,
  // corners_y rows, corner (0, 0) first, i.e. index = j * corners_x + i.
  std::vector<Eigen::Vector2d> true_corners_px;
  Rigid3d cam_from_board;            // board pose in the camera frame, metres
  double distance_m = 0.0;           // camera centre to the centre of the inner corners, metres
  double tilt_deg = 0.0;             // board normal to the line of sight, degrees
  bool all_corners_visible = false;  // every corner projects inside the imager (always so here)
};

// Renders options.views views of `board` through `camera` (any lens model
// libmrcal can unproject; CAHVORE throws UnsupportedError).
//
// Each pixel is the mean of supersampling x supersampling samples at offsets
// ((k + 0.5) / n - 0.5) px from its centre. Each sample's bearing solves
// camera.Project(bearing) = sample pixel to 1e-9 px. The bearings are solved
// once per call (the sample grid is the same for every view): Newton steps on
// the model's own projection, starting from libmrcal unprojections on an 8 px
// lattice, with libmrcal's unprojection wherever that does not converge (a
// whole 640 x 480 x 16 grid through libmrcal alone takes ~8 s). The ray meets the
// board plane and takes the colour of the square (or margin, or background)
// it hits. Then the optional blur (blur_sigma_px), Gaussian noise of
// noise_sigma, clamping to [0, 255] and rounding; noise is a hash of
// (seed, view, pixel), so the bytes are the same for any thread count.
//
// Poses are drawn from a generator seeded by options.seed: distance, tilt,
// tilt axis and roll at random (distances stratified over the range), the
// placement as described at `coverage`. A draw whose board breaks the border
// rule at the imager centre, or that is not wholly in front of the camera
// (z > 0 for every point of the printed board), is redrawn from the same
// generator. Deterministic for a given seed, camera and board; the poses do
// not depend on supersampling, blur, noise, grey levels or threads.
//
// Throws InputError listing every problem of the board and the options, or
// when no pose fits after max_attempts draws (the board is too large for the
// imager at the requested distances).
std::vector<ChessboardView> RenderChessboardViews(const calib::CameraModel& camera,
                                                  const ChessboardBoard& board,
                                                  const ChessboardViewsOptions& options);

// Writes `views` into folder `dir` (created if missing):
//   <stem>NN.png  each image (8-bit grey), NN = 01, 02, ... (at least two
//                 digits, more when there are 100 views or more)
//   truth.csv     view,corner,x_px,y_px: every true corner, view = NN as a
//                 number, corner = j * corners_x + i
//   poses.csv     view,image,qw,qx,qy,qz,tx_m,ty_m,tz_m,distance_m,tilt_deg:
//                 cam_from_board per view (Hamilton quaternion, w first)
// Numbers are written as the shortest decimal that reads back identical. Each
// file goes to a temporary name and is then renamed, so a reader never sees a
// partial file. Throws InputError naming the path when the folder or a file
// cannot be written, when `stem` contains '/' (it names files, not folders),
// or when `views` is empty.
void WriteChessboardViews(const std::vector<ChessboardView>& views, const std::string& dir,
                          const std::string& stem);

}  // namespace hdabench::datasets::synth
