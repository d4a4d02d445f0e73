#include "datasets/synth/render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include "tools/util/error.h"
#include "datasets/dataset.h"
#include "datasets/synth/noise.h"
#include "datasets/synth/optics.h"
#include "datasets/synth/render_internal.h"
#include "tools/util/angles.h"
#include "tools/util/parallel_for.h"
#include "tools/util/text.h"
#include "tools/util/options_check.h"

namespace hdabench::datasets::synth {

namespace {

using util::kPi;
using util::kDegToRad;

// A pair of independent standard normal deviates from two uniforms (Box-Muller).
void GaussianPair(std::uint64_t seed, std::uint64_t index, double* n1, double* n2) {
  const double u1 = 1.0 - HashUniform(seed, index, 0);  // (0, 1]
  const double u2 = HashUniform(seed, index, 1);
  const double radius = std::sqrt(-2.0 * std::log(u1));
  *n1 = radius * std::cos(2.0 * kPi * u2);
  *n2 = radius * std::sin(2.0 * kPi * u2);
}

}  // namespace

Eigen::Vector3d SunDirectionInLocal(double azimuth_deg, double elevation_deg) {
  const double azimuth_rad = azimuth_deg * kDegToRad;
  const double elevation_rad = elevation_deg * kDegToRad;
  return Eigen::Vector3d(std::sin(azimuth_rad) * std::cos(elevation_rad),
                         std::cos(azimuth_rad) * std::cos(elevation_rad), std::sin(elevation_rad));
}

double LunarLambertLimbDarkening(double phase_rad) {
  const double g_deg = phase_rad / kDegToRad;
  const double l = 1.0 + g_deg * (-0.019 + g_deg * (2.42e-4 + g_deg * -1.46e-6));
  return std::clamp(l, 0.0, 1.0);
}

double LunarLambertReflectance(double albedo, double cos_incidence, double cos_emission, double phase_rad) {
  if (!(cos_incidence > 0.0) || !(cos_emission > 0.0)) return 0.0;
  const double l = LunarLambertLimbDarkening(phase_rad);
  return albedo * (2.0 * l * cos_incidence / (cos_incidence + cos_emission) + (1.0 - l) * cos_incidence);
}

std::vector<std::string> RenderOptions::Validate() const {
  std::vector<std::string> errors;
  if (!std::isfinite(sun_azimuth_deg)) {
    errors.push_back("sun_azimuth_deg: " + util::ShortestText(sun_azimuth_deg) + " is not finite");
  }
  if (!std::isfinite(sun_elevation_deg)) {
    errors.push_back("sun_elevation_deg: " + util::ShortestText(sun_elevation_deg) +
                     " is not finite; expected in (0, 90]");
  } else if (sun_elevation_deg <= 0.0) {
    errors.push_back("sun_elevation_deg: " + util::ShortestText(sun_elevation_deg) +
                     " puts the sun at or below the horizon; expected in (0, 90]");
  } else if (sun_elevation_deg > 90.0) {
    errors.push_back("sun_elevation_deg: " + util::ShortestText(sun_elevation_deg) + " is past the zenith; expected in (0, 90]");
  }
  if (samples_per_pixel_axis < 1 || samples_per_pixel_axis > 16) {
    errors.push_back("samples_per_pixel_axis: " + std::to_string(samples_per_pixel_axis) +
                     "; expected 1 to 16");
  }
  if (adaptive_samples_per_cell_axis < 1 || adaptive_samples_per_cell_axis > 16) {
    errors.push_back("adaptive_samples_per_cell_axis: " + std::to_string(adaptive_samples_per_cell_axis) +
                     "; expected 1 to 16");
  }
  if (!(std::isfinite(fill_factor) && fill_factor > 0.0 && fill_factor <= 1.0)) {
    errors.push_back("fill_factor: " + util::ShortestText(fill_factor) + "; expected in (0, 1]");
  }
  const std::pair<const char*, double> optics[] = {
      {"f_number", f_number}, {"wavelength_um", wavelength_um}, {"pixel_pitch_um", pixel_pitch_um}};
  bool optics_usable = true;
  for (const auto& [name, value] : optics) {
    if (!(std::isfinite(value) && value > 0.0)) {
      errors.push_back(std::string(name) + ": " + util::ShortestText(value) + "; expected a finite value > 0");
      optics_usable = false;
    }
  }
  if (optics_usable) {
    // Past a blur of 10 px, as for defocus, an imager's pixels no longer matter,
    // and the PSF's taps would outgrow the render's margins.
    const double diffraction_px = DiffractionSigmaPx(wavelength_um, f_number, pixel_pitch_um);
    if (!(std::isfinite(diffraction_px) && diffraction_px <= 10.0)) {
      errors.push_back("f_number " + util::ShortestText(f_number) + ", wavelength_um " +
                       util::ShortestText(wavelength_um) + " and pixel_pitch_um " + util::ShortestText(pixel_pitch_um) +
                       " give a diffraction blur of sigma " + util::ShortestText(diffraction_px) +
                       " px; expected at most 10 px");
    }
  }
  if (!(std::isfinite(defocus_sigma_px) && defocus_sigma_px >= 0.0 && defocus_sigma_px <= 10.0)) {
    errors.push_back("defocus_sigma_px: " + util::ShortestText(defocus_sigma_px) + "; expected 0 to 10");
  }
  if (!std::isfinite(dn_per_reflectance)) {
    errors.push_back("dn_per_reflectance: " + util::ShortestText(dn_per_reflectance) +
                     " is not finite; expected > 0 (fixed exposure) or <= 0 (auto-exposure)");
  }
  if (!(std::isfinite(target_mean_dn) && target_mean_dn > 0.0)) {
    errors.push_back("target_mean_dn: " + util::ShortestText(target_mean_dn) + "; expected a finite value > 0");
  }
  if (!(gain_electrons_per_dn > 0.0 && gain_electrons_per_dn <= kMaxGainElectronsPerDn)) {
    errors.push_back("gain_electrons_per_dn: " + util::ShortestText(gain_electrons_per_dn) +
                     "; expected > 0 and at most " + util::ShortestText(kMaxGainElectronsPerDn));
  }
  if (!(std::isfinite(full_well_electrons) && full_well_electrons > 0.0)) {
    errors.push_back("full_well_electrons: " + util::ShortestText(full_well_electrons) +
                     "; expected a finite value > 0");
  }
  if (!(read_noise_dn >= 0.0 && read_noise_dn <= kMaxReadNoiseDn)) {
    errors.push_back("read_noise_dn: " + util::ShortestText(read_noise_dn) + "; expected 0 to " +
                     util::ShortestText(kMaxReadNoiseDn));
  }
  if (bit_depth != 8 && bit_depth != 16) {
    errors.push_back("bit_depth: " + std::to_string(bit_depth) + "; expected 8 or 16");
  }
  if (!(std::isfinite(ambient_reflectance) && ambient_reflectance >= 0.0)) {
    errors.push_back("ambient_reflectance: " + util::ShortestText(ambient_reflectance) +
                     "; expected a finite value >= 0");
  }
  if (threads < 1) {
    errors.push_back("threads: " + std::to_string(threads) + "; expected >= 1");
  }
  return errors;
}

double RenderOptions::PsfSigmaPx() const {
  return std::hypot(DiffractionSigmaPx(wavelength_um, f_number, pixel_pitch_um), defocus_sigma_px);
}

namespace {

void ThrowIfInvalid(const RenderOptions& options) {
  hdabench::ThrowIfInvalid("invalid render options: ", options.Validate());
}

}  // namespace

double ExposureFor(const RenderOptions& options, double mean_albedo,
                   const Eigen::Vector3d& direction_to_camera_in_local) {
  ThrowIfInvalid(options);
  const Eigen::Vector3d sun = SunDirectionInLocal(options.sun_azimuth_deg, options.sun_elevation_deg);
  const Eigen::Vector3d view = direction_to_camera_in_local.normalized();
  const double cos_incidence = sun.z();
  const double cos_emission = view.z();
  const double phase_rad = std::acos(std::clamp(sun.dot(view), -1.0, 1.0));
  const double reflectance = LunarLambertReflectance(mean_albedo, cos_incidence, cos_emission, phase_rad) +
                             options.ambient_reflectance * mean_albedo;
  if (!(reflectance > 0.0) || !std::isfinite(reflectance)) {
    throw InputError("auto-exposure: the reference patch (albedo " + util::ShortestText(mean_albedo) +
                     ", view direction z " + util::ShortestText(cos_emission) +
                     ") reflects no light; expected albedo > 0 and a camera above the horizon");
  }
  return options.target_mean_dn / reflectance;
}

CameraRays::CameraRays(const calib::CameraModel& camera, int threads)
    : width_px_(camera.WidthPx()), height_px_(camera.HeightPx()) {
  if (threads < 1) throw InputError("threads: " + std::to_string(threads) + "; expected >= 1");
  centres_.assign(static_cast<size_t>(width_px_) * height_px_, Eigen::Vector3d::Zero());
  util::ParallelFor(
      "camera rays", height_px_, threads,
      [&](int row) {
        std::vector<Eigen::Vector2d> pixels;
        pixels.reserve(static_cast<size_t>(width_px_));
        for (int col = 0; col < width_px_; ++col) pixels.emplace_back(col, row);
        std::vector<Eigen::Vector3d> bearings;
        std::vector<unsigned char> valid;
        camera.Unproject(pixels, &bearings, &valid);
        const size_t row_start = static_cast<size_t>(row) * width_px_;
        for (int col = 0; col < width_px_; ++col) {
          if (valid[static_cast<size_t>(col)]) centres_[row_start + col] = bearings[static_cast<size_t>(col)];
        }
      });
}

Eigen::Vector3d CameraRays::SampleBearing(int row, int col, double dx_px, double dy_px) const {
  double pixel_angle_rad = 0.0;
  return BearingAt(col + dx_px, row + dy_px, &pixel_angle_rad);
}

Eigen::Vector3d CameraRays::BearingAt(double x_px, double y_px, double* pixel_angle_rad) const {
  *pixel_angle_rad = 0.0;
  const int c0 = std::clamp(static_cast<int>(std::floor(x_px)), 0, std::max(0, width_px_ - 2));
  const int r0 = std::clamp(static_cast<int>(std::floor(y_px)), 0, std::max(0, height_px_ - 2));
  const int c1 = std::min(c0 + 1, width_px_ - 1);
  const int r1 = std::min(r0 + 1, height_px_ - 1);
  const double fx = x_px - c0;
  const double fy = y_px - r0;
  const Eigen::Vector3d& b00 = CentreBearing(r0, c0);
  const Eigen::Vector3d& b01 = CentreBearing(r0, c1);
  const Eigen::Vector3d& b10 = CentreBearing(r1, c0);
  const Eigen::Vector3d& b11 = CentreBearing(r1, c1);
  if (b00.squaredNorm() == 0.0 || b01.squaredNorm() == 0.0 || b10.squaredNorm() == 0.0 ||
      b11.squaredNorm() == 0.0) {
    return Eigen::Vector3d::Zero();
  }
  const Eigen::Vector3d b = (1.0 - fy) * ((1.0 - fx) * b00 + fx * b01) + fy * ((1.0 - fx) * b10 + fx * b11);
  const double norm = b.norm();
  if (!(norm > 0.0)) return Eigen::Vector3d::Zero();
  // Unit bearings: the chord between neighbours is the angle to first order.
  const double along_x = c1 != c0 ? (b01 - b00).norm() : 0.0;
  const double along_y = r1 != r0 ? (b10 - b00).norm() : along_x;
  *pixel_angle_rad = along_x > 0.0 && along_y > 0.0 ? std::sqrt(along_x * along_y) : std::max(along_x, along_y);
  return b / norm;
}

namespace internal {

Sample Shade(const FrameContext& frame, const Eigen::Vector3d& bearing_in_cam, bool shade,
             ShadowMode shadow_mode, std::int64_t* shadow_rays) {
  Sample sample;
  if (bearing_in_cam.squaredNorm() == 0.0) return sample;  // unprojectable pixel
  const Eigen::Vector3d direction = (frame.local_from_cam * bearing_in_cam).normalized();
  const double infinity = std::numeric_limits<double>::infinity();
  const bool found = shade ? frame.raycaster->Intersect(frame.camera_in_local, direction, infinity, &sample.ray_hit)
                           : frame.raycaster->IntersectGeometry(frame.camera_in_local, direction, infinity,
                                                                &sample.ray_hit);
  if (!found) return sample;
  sample.hit = true;
  const RayHit& hit = sample.ray_hit;
  const Eigen::Vector3d to_camera = -direction;
  const double cos_incidence = hit.normal_in_local.dot(frame.sun_in_local);
  const double cos_emission = hit.normal_in_local.dot(to_camera);
  double direct = 0.0;
  if (cos_incidence <= 0.0) {
    sample.shadow = 128;
  } else {
    bool blocked = shadow_mode == ShadowMode::kAssumeShadowed;
    if (shadow_mode == ShadowMode::kTrace) {
      ++*shadow_rays;
      blocked = SunBlocked(frame, hit);
    }
    if (blocked) {
      sample.shadow = 255;
    } else if (shade) {
      const double phase_rad = std::acos(std::clamp(frame.sun_in_local.dot(to_camera), -1.0, 1.0));
      direct = LunarLambertReflectance(hit.albedo, cos_incidence, cos_emission, phase_rad);
    }
  }
  if (shade) sample.reflectance = direct + frame.ambient_reflectance * hit.albedo;
  return sample;
}

bool SunBlocked(const FrameContext& frame, const RayHit& hit) {
  const Eigen::Vector3d start = hit.point_in_local_m + SceneRaycaster::kShadowRayOffsetM * hit.normal_in_local;
  return frame.shadows->Hidden(start) ||
         frame.raycaster->OccludedByRocks(start, frame.sun_in_local, std::numeric_limits<double>::infinity());
}

FrameContext MakeFrameContext(const SceneRaycaster& raycaster, const TerrainShadows& shadows,
                              const Rigid3d& cam_from_local, const RenderOptions& options) {
  const Rigid3d local_from_cam = cam_from_local.Inverse();
  FrameContext context;
  context.raycaster = &raycaster;
  context.shadows = &shadows;
  context.local_from_cam = local_from_cam.RotationMatrix();
  context.camera_in_local = local_from_cam.translation;
  context.sun_in_local = SunDirectionInLocal(options.sun_azimuth_deg, options.sun_elevation_deg);
  context.ambient_reflectance = options.ambient_reflectance;
  return context;
}

void AllocateFrame(int width, int height, int bit_depth, RenderedFrame* frame) {
  frame->image = cv::Mat(height, width, bit_depth == 8 ? CV_8UC1 : CV_16UC1);
  frame->points_in_local_m = cv::Mat(height, width, CV_32FC3);
  frame->shadow_mask = cv::Mat(height, width, CV_8UC1);
  frame->rock_index = cv::Mat(height, width, CV_32SC1);
}

// Shadow mode of the samples of pixels rows [row0, row1] x cols [col0, col1]
// (clipped to the imager): a shadow ray only where the pixel centres of the
// box disagree about cast shadow (255), else the centres' common state.
ShadowMode ShadowModeOfBox(const cv::Mat& shadow_mask, int row0, int row1, int col0, int col1) {
  const int height = shadow_mask.rows;
  const int width = shadow_mask.cols;
  bool any_cast = false;
  bool any_not_cast = false;
  for (int r = std::max(0, row0); r <= std::min(height - 1, row1); ++r) {
    const auto* mask = shadow_mask.ptr<unsigned char>(r);
    for (int c = std::max(0, col0); c <= std::min(width - 1, col1); ++c) {
      if (mask[c] == 255) {
        any_cast = true;
      } else {
        any_not_cast = true;
      }
    }
  }
  if (any_cast == any_not_cast) return ShadowMode::kTrace;  // both, or an empty box
  return any_cast ? ShadowMode::kAssumeShadowed : ShadowMode::kAssumeLit;
}

// The sensor: shot noise on the electrons, full-well clip, read noise,
// rounding and clipping to [0, max_dn]; the noise is seeded per pixel.
double SensorDn(const RenderOptions& options, double signal_dn, std::uint64_t noise_seed,
                std::uint64_t pixel_index, double max_dn) {
  double shot = 0.0, read = 0.0;
  if (options.shot_noise || options.read_noise_dn > 0.0) GaussianPair(noise_seed, pixel_index, &shot, &read);
  double electrons = signal_dn * options.gain_electrons_per_dn;
  if (options.shot_noise) electrons += std::sqrt(std::max(electrons, 0.0)) * shot;
  electrons = std::clamp(electrons, 0.0, options.full_well_electrons);
  return std::clamp(std::round(electrons / options.gain_electrons_per_dn + options.read_noise_dn * read), 0.0,
                    max_dn);
}

}  // namespace internal

namespace {

using internal::AllocateFrame;
using internal::FrameContext;
using internal::FrameProgress;
using internal::MakeFrameContext;
using internal::Sample;
using internal::SensorDn;
using internal::Shade;
using internal::ShadowMode;
using internal::ShadowModeOfBox;

// The state the passes of one RenderFrame call share: the sampling plan, the
// per-row ray counts (each row written by one worker only) and the
// reflectances the ray passes leave for the image pass.
struct FramePasses {
  FramePasses(const FrameContext& frame_context, const CameraRays& camera_rays_in,
              const RenderOptions& render_options)
      : context(frame_context),
        rays(camera_rays_in),
        options(render_options),
        width(camera_rays_in.WidthPx()),
        height(camera_rays_in.HeightPx()),
        n(render_options.samples_per_pixel_axis),
        samples_per_pixel(n * n),
        // With odd n the middle sample is the pixel centre: reuse its hit.
        centre_sample(n % 2 == 1 ? (n / 2) * n + n / 2 : -1),
        quincunx(render_options.anti_aliasing == RenderOptions::AntiAliasing::kQuincunx),
        centre_in_image(quincunx || centre_sample >= 0),
        camera_rays(static_cast<size_t>(height), 0),
        shadow_rays(static_cast<size_t>(height), 0),
        centre_reflectance(centre_in_image ? static_cast<size_t>(width) * height : 0),
        corner_reflectance(quincunx ? static_cast<size_t>(width + 1) * (height + 1) : 0) {}

  const FrameContext& context;
  const CameraRays& rays;
  const RenderOptions& options;
  const int width;
  const int height;
  const int n;
  const int samples_per_pixel;
  const int centre_sample;
  const bool quincunx;
  const bool centre_in_image;
  std::vector<std::int64_t> camera_rays;
  std::vector<std::int64_t> shadow_rays;
  std::vector<double> centre_reflectance;  // per pixel, when the centre is also an image sample
  std::vector<double> corner_reflectance;  // per pixel corner, quincunx only
};

// Pass 1, the truth: every pixel-centre ray with its own shadow ray, into the
// frame's points, shadow mask and rock index (progress 0 to 0.2).
void TraceCentres(FramePasses& passes, const FrameProgress& progress, RenderedFrame* frame) {
  const int width = passes.width;
  const int height = passes.height;
  const auto trace_centres = [&](int row) {
    std::int64_t row_shadow_rays = 0;
    auto* points = frame->points_in_local_m.ptr<cv::Vec3f>(row);
    auto* mask = frame->shadow_mask.ptr<unsigned char>(row);
    auto* rock = frame->rock_index.ptr<std::int32_t>(row);
    for (int col = 0; col < width; ++col) {
      // Its albedo only matters when it is also an image sample.
      const Sample centre = Shade(passes.context, passes.rays.CentreBearing(row, col), passes.centre_in_image,
                                  ShadowMode::kTrace, &row_shadow_rays);
      if (centre.hit) {
        const Eigen::Vector3f p = centre.ray_hit.point_in_local_m.cast<float>();
        points[col] = cv::Vec3f(p.x(), p.y(), p.z());
      } else {
        const float nan = std::numeric_limits<float>::quiet_NaN();
        points[col] = cv::Vec3f(nan, nan, nan);
      }
      mask[col] = centre.shadow;
      rock[col] = centre.hit ? centre.ray_hit.rock_index : -1;
      if (passes.centre_in_image) {
        passes.centre_reflectance[static_cast<size_t>(row) * width + col] = centre.reflectance;
      }
    }
    passes.camera_rays[static_cast<size_t>(row)] = width;
    passes.shadow_rays[static_cast<size_t>(row)] = row_shadow_rays;
  };
  util::ParallelFor("render rows", height, passes.options.threads, trace_centres, [&](int rows_done) {
    if (progress && (rows_done % 16 == 0)) progress(0.2 * rows_done / height);
  });
}

// Quincunx corners (progress 0.2 to 0.9): corner (r, c) is the pixel corner
// at x = c - 0.5, y = r - 0.5; its shadow mode comes from the 4 x 4 pixel
// centres around it (the 2 x 2 pixels that share it, grown by one, as for
// grid samples). Needs pass 1 complete.
void TraceCorners(FramePasses& passes, const cv::Mat& shadow_mask, const FrameProgress& progress) {
  const int width = passes.width;
  const int height = passes.height;
  const auto trace_corners = [&](int r) {
    std::int64_t row_shadow_rays = 0;
    const int rr = std::min(r, height - 1);
    for (int c = 0; c <= width; ++c) {
      const int cc = std::min(c, width - 1);
      const double dx_px = (c - 0.5) - cc;
      const double dy_px = (r - 0.5) - rr;
      passes.corner_reflectance[static_cast<size_t>(r) * (width + 1) + c] =
          Shade(passes.context, passes.rays.SampleBearing(rr, cc, dx_px, dy_px), true,
                ShadowModeOfBox(shadow_mask, r - 2, r + 1, c - 2, c + 1), &row_shadow_rays)
              .reflectance;
    }
    passes.camera_rays[static_cast<size_t>(std::min(r, height - 1))] += width + 1;
    passes.shadow_rays[static_cast<size_t>(std::min(r, height - 1))] += row_shadow_rays;
  };
  // Corner rows 0..height-1 in the workers (each writes its own row's
  // counters), then the bottom corner row here, adding to the last row's.
  util::ParallelFor("render rows", height, passes.options.threads, trace_corners, [&](int rows_done) {
    if (progress && (rows_done % 16 == 0)) progress(0.2 + 0.7 * rows_done / height);
  });
  trace_corners(height);
}

// Sum over the pixel's samples of their reflectance, in units of one sample:
// the quincunx weights of centre and corners, or the grid samples (casting
// the sub-pixel rays, counted in *row_camera_rays and *row_shadow_rays).
double PixelReflectanceSum(const FramePasses& passes, int row, int col, ShadowMode shadow_mode,
                           std::int64_t* row_shadow_rays, std::int64_t* row_camera_rays) {
  const int width = passes.width;
  const int n = passes.n;
  double reflectance_sum = 0.0;
  if (passes.quincunx) {
    const size_t stride = static_cast<size_t>(width) + 1;
    const size_t top_left = static_cast<size_t>(row) * stride + col;
    const std::vector<double>& corner = passes.corner_reflectance;
    reflectance_sum = passes.samples_per_pixel *
                      (0.5 * passes.centre_reflectance[static_cast<size_t>(row) * width + col] +
                       0.125 * (corner[top_left] + corner[top_left + 1] + corner[top_left + stride] +
                                corner[top_left + stride + 1]));
  }
  for (int k = 0; !passes.quincunx && k < passes.samples_per_pixel; ++k) {
    if (k == passes.centre_sample) {
      reflectance_sum += passes.centre_reflectance[static_cast<size_t>(row) * width + col];
      continue;
    }
    const double dx_px = (k % n + 0.5) / n - 0.5;
    const double dy_px = (k / n + 0.5) / n - 0.5;
    reflectance_sum += Shade(passes.context, passes.rays.SampleBearing(row, col, dx_px, dy_px), true, shadow_mode,
                             row_shadow_rays)
                           .reflectance;
    ++*row_camera_rays;
  }
  return reflectance_sum;
}

// Pass 2, the image: the sub-pixel samples, then the sensor. Their shadow
// rays are cast only near shadow edges, where the 3x3 pixel centres around
// the pixel disagree about cast shadow (255); elsewhere every sample takes the
// centres' state. Pass 1 (and the corners) are complete, so this depends on
// nothing but its inputs: the output stays the same for any thread count.
void RenderImage(FramePasses& passes, std::uint64_t noise_seed, const FrameProgress& progress,
                 RenderedFrame* frame) {
  const RenderOptions& options = passes.options;
  const int width = passes.width;
  const int height = passes.height;
  const double max_dn = options.bit_depth == 8 ? 255.0 : 65535.0;
  const auto render_row = [&](int row) {
    std::int64_t row_shadow_rays = 0;
    std::int64_t row_camera_rays = 0;
    for (int col = 0; col < width; ++col) {
      const ShadowMode shadow_mode = ShadowModeOfBox(frame->shadow_mask, row - 1, row + 1, col - 1, col + 1);
      // Image: the weighted mean reflectance of the pixel's rays.
      const double reflectance_sum =
          PixelReflectanceSum(passes, row, col, shadow_mode, &row_shadow_rays, &row_camera_rays);
      const double signal_dn = frame->dn_per_reflectance * reflectance_sum / passes.samples_per_pixel;
      const std::uint64_t pixel_index = static_cast<std::uint64_t>(row) * static_cast<std::uint64_t>(width) +
                                        static_cast<std::uint64_t>(col);
      const double dn = SensorDn(options, signal_dn, noise_seed, pixel_index, max_dn);
      if (options.bit_depth == 8) {
        frame->image.ptr<std::uint8_t>(row)[col] = static_cast<std::uint8_t>(dn);
      } else {
        frame->image.ptr<std::uint16_t>(row)[col] = static_cast<std::uint16_t>(dn);
      }
    }
    passes.camera_rays[static_cast<size_t>(row)] += row_camera_rays;
    passes.shadow_rays[static_cast<size_t>(row)] += row_shadow_rays;
  };
  // Progress: centres 0-0.2, quincunx corners 0.2-0.9, then this pass to 1.
  const double pass2_start = passes.quincunx ? 0.9 : 0.2;
  util::ParallelFor("render rows", height, options.threads, render_row, [&](int rows_done) {
    if (progress && (rows_done % 16 == 0)) {
      progress(pass2_start + (1.0 - pass2_start) * rows_done / height);
    }
  });
}

}  // namespace

RenderedFrame RenderFrame(const SceneRaycaster& raycaster, const Scene& scene, const calib::CameraModel& camera,
                          const Rigid3d& cam_from_local, const RenderOptions& options,
                          std::uint64_t noise_seed, const std::function<void(double fraction_done)>& progress) {
  ThrowIfInvalid(options);
  const auto start = std::chrono::steady_clock::now();
  const CameraRays rays(camera, options.threads);
  RenderedFrame frame = RenderFrame(raycaster, scene, rays, cam_from_local, options, noise_seed, progress);
  frame.stats.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return frame;
}

RenderedFrame RenderFrame(const SceneRaycaster& raycaster, const Scene& scene, const CameraRays& rays,
                          const Rigid3d& cam_from_local, const RenderOptions& options,
                          std::uint64_t noise_seed, const std::function<void(double fraction_done)>& progress,
                          const TerrainShadows* shadows) {
  ThrowIfInvalid(options);
  if (&scene != &raycaster.GetScene()) {
    throw InputError("RenderFrame: the scene is not the one the raycaster was built from");
  }
  if (rays.WidthPx() < 1 || rays.HeightPx() < 1) throw InputError("RenderFrame: the camera rays are empty");
  const Eigen::Vector3d sun_in_local = SunDirectionInLocal(options.sun_azimuth_deg, options.sun_elevation_deg);
  if (shadows != nullptr && (shadows->Sun() != sun_in_local || &shadows->Dem() != &scene.dem)) {
    throw InputError("RenderFrame: the terrain shadows are for another sun or DEM than the options' and the scene's");
  }
  const auto start = std::chrono::steady_clock::now();
  std::optional<TerrainShadows> own_shadows;
  if (shadows == nullptr) shadows = &own_shadows.emplace(scene.dem, sun_in_local);
  const FrameContext context = MakeFrameContext(raycaster, *shadows, cam_from_local, options);

  RenderedFrame frame;
  frame.dn_per_reflectance =
      options.dn_per_reflectance > 0.0
          ? options.dn_per_reflectance
          : ExposureFor(options, scene.albedo.mean, -(context.local_from_cam * Eigen::Vector3d::UnitZ()));
  if (options.anti_aliasing == RenderOptions::AntiAliasing::kCamera) {
    AllocateFrame(rays.WidthPx(), rays.HeightPx(), options.bit_depth, &frame);
    internal::RenderCameraModel(context, scene, rays, options, noise_seed, progress, &frame);
  } else {
    FramePasses passes(context, rays, options);
    AllocateFrame(passes.width, passes.height, options.bit_depth, &frame);
    TraceCentres(passes, progress, &frame);
    if (passes.quincunx) TraceCorners(passes, frame.shadow_mask, progress);
    RenderImage(passes, noise_seed, progress, &frame);
    for (int row = 0; row < passes.height; ++row) {
      frame.stats.camera_rays += passes.camera_rays[static_cast<size_t>(row)];
      frame.stats.shadow_rays += passes.shadow_rays[static_cast<size_t>(row)];
    }
  }
  if (progress) progress(1.0);
  frame.stats.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return frame;
}

}  // namespace hdabench::datasets::synth
