// Ray-cast rendering of a synthetic Scene through a calibrated camera: the
// image (lunar-Lambert photometry, cast shadows, anti-aliasing, sensor noise)
// and the per-pixel truth (3-D point of each pixel-centre ray, shadow mask).
// Frames follow docs/conventions.md: local = ENU, z up; camera = OpenCV axes;
// pixel (0, 0) = centre of the top-left pixel.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "calib/camera_model.h"
#include "calib/rigid3.h"
#include "datasets/synth/raycast.h"
#include "datasets/synth/sun_shadows.h"
#include "datasets/synth/scene.h"

namespace hdabench::datasets::synth {

// Unit vector toward the sun in the local frame (ENU). Azimuth from north,
// clockwise toward east (90 = sun in the east); elevation above the local
// horizon: (sin az cos el, cos az cos el, sin el).
Eigen::Vector3d SunDirectionInLocal(double azimuth_deg, double elevation_deg);

// McEwen's limb-darkening parameter L(g) of the lunar-Lambert function, from
// the cubic fit in phase angle g (degrees)
//   L(g) = 1 - 0.019 g + 2.42e-4 g^2 - 1.46e-6 g^3
// (McEwen, "A precise lunar photometric function", LPSC XXVII, 1996, fitted to
// the L(g) values of McEwen 1991). The cubic turns negative beyond g ~ 104 deg,
// where the fit is no longer meaningful; L is clamped to [0, 1] (pure Lambert
// at large phase).
double LunarLambertLimbDarkening(double phase_rad);

// Lunar-Lambert reflectance (radiance factor I/F) after McEwen, "Photometric
// functions for photoclinometry and other applications", Icarus 92 (1991):
//   r = albedo * [ 2 L(g) cos i / (cos i + cos e) + (1 - L(g)) cos i ]
// with i the incidence angle (surface normal to sun), e the emission angle
// (normal to camera), g the phase angle (sun to camera seen from the surface)
// and L(g) = LunarLambertLimbDarkening(g). Zero when cos_incidence <= 0 or
// cos_emission <= 0 (the caller also gives zero for a point in cast shadow).
double LunarLambertReflectance(double albedo, double cos_incidence, double cos_emission, double phase_rad);

struct RenderOptions {
  // Sun. The default is a low sun as at a polar landing site.
  double sun_azimuth_deg = 90.0;         // from north, clockwise toward east, degrees
  double sun_elevation_deg = 9.0;        // above the local horizon, degrees, in (0, 90]
  // How a pixel is formed.
  //  kCamera (default): the camera model. Each pixel integrates the scene over
  //   its light-sensitive area (fill_factor), blurred by the optics' PSF
  //   (PsfSigmaPx()). The scene is sampled on a lattice of 2 points per
  //   pixel, 1/sqrt(2) px apart (the pixel centres, so the centre ray is also
  //   the truth ray, and the pixel corners); each lattice point stands for the
  //   scene averaged over its cell: the albedo texture and the terrain normal
  //   are low-passed at the cell's ground footprint (a Gaussian of the cell's
  //   variance), and where neighbouring points see a different surface or
  //   shadow state, the cell is split into adaptive_samples_per_cell_axis^2
  //   rays, each with its own shadow state (render_camera.cc). The
  //   pixel is the cells' sum weighted by the pixel response over each cell
  //   (optics.h), with the optics' Gaussian narrowed by the cell filter's
  //   variance so that the rendered blur is the configured one.
  //  kQuincunx: point sampling, 1/2 the centre ray plus 1/8 of each of its
  //   four corner rays, corners shared with the neighbours: two rays per pixel.
  //  kGrid: n x n point samples per pixel (n = samples_per_pixel_axis) at
  //   offsets ((k + 0.5) / n - 0.5) px from the centre, averaged; n = 1 is no
  //   anti-aliasing.
  // kQuincunx and kGrid have no optics blur and no pixel response: they keep
  // the datasets rendered before the camera model reproducible.
  enum class AntiAliasing { kCamera, kQuincunx, kGrid };
  AntiAliasing anti_aliasing = AntiAliasing::kCamera;
  int samples_per_pixel_axis = 2;
  int adaptive_samples_per_cell_axis = 2;  // kCamera: rays per cell side where the scene is discontinuous; 1 = none
  // Detector and optics (kCamera). Defaults: a machine-vision camera of 5.5 um
  // pixels behind an f/5.6 lens; not the values of any flight camera.
  double fill_factor = 1.0;                // light-sensitive share of the pixel area, (0, 1]
  double f_number = 5.6;                   // diffraction: Airy core as a Gaussian of 0.42 lambda N / pitch
  double wavelength_um = 0.6;              // effective wavelength of the passband, micrometres
  double pixel_pitch_um = 5.5;             // pixel pitch, micrometres
  double defocus_sigma_px = 0.4;           // defocus and aberrations: a Gaussian of this sigma, pixels
  // The optics' PSF: a Gaussian of sigma = hypot(diffraction sigma, defocus_sigma_px), pixels.
  double PsfSigmaPx() const;
  // Exposure, in DN per unit reflectance (I/F). > 0: used as is (the same
  // exposure for every frame). <= 0: auto-exposure from geometry, never from
  // image content: ExposureFor(options, scene albedo mean, -optical axis).
  double dn_per_reflectance = 0.0;
  double target_mean_dn = 110.0;         // auto-exposure: DN of the reference patch
  // Sensor. Signal electrons = DN * gain; shot noise is Gaussian with variance
  // = signal electrons (deterministic from the noise seed); then clipping at
  // the full well, read noise, rounding and clipping to the bit depth.
  bool shot_noise = true;                // add photon shot noise
  double gain_electrons_per_dn = 40.0;   // electrons per DN (8-bit default; /257 for 16-bit)
  double full_well_electrons = 10000.0;  // saturation charge, electrons
  double read_noise_dn = 0.5;            // standard deviation of the read noise, DN; 0 = none
  int bit_depth = 8;                     // 8 (CV_8UC1) or 16 (CV_16UC1)
  // Isotropic fill light (earthshine): adds ambient_reflectance * albedo to
  // every visible point, lit or in shadow. 0 = none.
  double ambient_reflectance = 0.0;
  int threads = 1;                       // worker threads; output does not depend on it

  // One message per problem, each starting with the field name; empty when
  // the options are usable.
  std::vector<std::string> Validate() const;
};

// Auto-exposure: the DN per unit reflectance at which a flat horizontal patch
// of albedo `mean_albedo` under the options' sun, seen from
// `direction_to_camera_in_local` (unit, pointing up from the patch to the
// camera), gets options.target_mean_dn. Calling it once with a reference
// geometry (e.g. nadir, +z) and passing the result as dn_per_reflectance
// gives a whole sequence the same exposure. Throws InputError when the
// options are invalid or the reference patch gets no light (camera below the
// horizon, albedo <= 0).
double ExposureFor(const RenderOptions& options, double mean_albedo,
                   const Eigen::Vector3d& direction_to_camera_in_local);

// Unit bearings, in the camera frame, of the rays RenderFrame casts through a
// camera. libmrcal's iterative unprojection is the costliest step of a render,
// so build this once per camera and reuse it for every frame.
// Pixel centres are unprojected exactly (CameraModel::Unproject). A sub-pixel
// anti-aliasing ray is the normalised bilinear interpolation of the unit
// bearings of the 2 x 2 pixel centres around it (extrapolated at the border):
// for a lens whose bearing field is smooth at the pixel scale (every mrcal
// model, splined ones included: knots are tens of pixels apart) the error is
// second order, ~0.1 / focal_px px (1e-4 px at f = 1000 px). Pixels libmrcal
// cannot unproject get a zero bearing (no hit), as do samples next to them.
class CameraRays {
 public:
  // Unprojects the width x height pixel centres with `threads` workers.
  // Throws InputError when threads < 1; UnsupportedError for CAHVORE.
  explicit CameraRays(const calib::CameraModel& camera, int threads = 1);

  int WidthPx() const { return width_px_; }
  int HeightPx() const { return height_px_; }
  // Bearing of pixel centre (row, col); zero when not unprojectable.
  const Eigen::Vector3d& CentreBearing(int row, int col) const {
    return centres_[static_cast<size_t>(row) * width_px_ + col];
  }
  // Bearing through pixel (col + dx_px, row + dy_px), |dx|, |dy| <= 0.5, by
  // interpolation as above; zero when a pixel of the stencil has none.
  Eigen::Vector3d SampleBearing(int row, int col, double dx_px, double dy_px) const;
  // Bearing through any image point (x_px, y_px), extrapolated from the
  // nearest 2 x 2 pixel centres outside the imager (the camera model's
  // margin); *pixel_angle_rad receives the angle between neighbouring pixel
  // centres there (geometric mean of the two axes). Zero bearing as above.
  Eigen::Vector3d BearingAt(double x_px, double y_px, double* pixel_angle_rad) const;

 private:
  int width_px_ = 0;
  int height_px_ = 0;
  std::vector<Eigen::Vector3d> centres_;
};

struct RenderStats {
  std::int64_t camera_rays = 0;  // rays cast from the camera (pixel centres + sub-pixel samples)
  std::int64_t shadow_rays = 0;  // sun queries: the terrain's shadow heights, then a shadow ray through the rocks
  std::int64_t split_cells = 0;  // kCamera: lattice cells split for discontinuities
  double wall_s = 0.0;          // wall-clock time of RenderFrame (incl. CameraRays if built there)
};

struct RenderedFrame {
  cv::Mat image;              // CV_8UC1 or CV_16UC1 (bit_depth), height x width
  // CV_32FC3: hit of each pixel-centre ray in the local frame, metres; NaN
  // where the ray hits nothing (sky, outside the DEM, unprojectable pixel).
  cv::Mat points_in_local_m;
  // CV_8UC1 per pixel-centre hit: 255 = cast shadow (faces the sun, sun
  // blocked), 128 = attached shadow (faces away from the sun, cos i <= 0),
  // 0 = lit or no hit.
  cv::Mat shadow_mask;
  // CV_32SC1: index into Scene::rocks of the pixel-centre hit; -1 for terrain
  // or no hit.
  cv::Mat rock_index;
  double dn_per_reflectance = 0.0;  // exposure used (fixed or auto)
  RenderStats stats;
};

// Renders one frame of `scene` (which `raycaster` must have been built from)
// seen by `camera` at pose cam_from_local. The camera centre is
// cam_from_local.Inverse().translation. Each pixel is the mean of its n x n
// sub-pixel rays: reflectance LunarLambertReflectance (0 in cast shadow: the
// terrain's by its shadow heights, TerrainShadows, the rocks' by a shadow ray;
// both from SceneRaycaster::kShadowRayOffsetM along the normal) plus
// the ambient term, times the exposure, then sensor noise seeded by
// HashUniform(noise_seed, pixel index). Every pixel is a pure function of its
// inputs, so the output is byte-identical for any options.threads. `progress`
// gets the fraction of rows done, rising, from one thread at a time (the one
// that finished the row: util::ParallelFor's done callback).
// Throws InputError when options.Validate() fails or the scene is not the
// raycaster's.
RenderedFrame RenderFrame(const SceneRaycaster& raycaster, const Scene& scene, const calib::CameraModel& camera,
                          const Rigid3d& cam_from_local, const RenderOptions& options,
                          std::uint64_t noise_seed,
                          const std::function<void(double fraction_done)>& progress = {});

// The same with bearings built beforehand, and the terrain's shadows for the
// options' sun (made here when null): faster for a sequence of frames, which
// can share both. Throws InputError also when `rays` is empty (0 x 0), or
// `shadows` is for another sun or DEM.
RenderedFrame RenderFrame(const SceneRaycaster& raycaster, const Scene& scene, const CameraRays& rays,
                          const Rigid3d& cam_from_local, const RenderOptions& options,
                          std::uint64_t noise_seed,
                          const std::function<void(double fraction_done)>& progress = {},
                          const TerrainShadows* shadows = nullptr);

}  // namespace hdabench::datasets::synth
