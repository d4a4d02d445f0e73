// Pieces of the renderer shared by its pixel-formation modes (render.cc: the
// point-sampling modes; render_camera.cc: the camera model). Not part of the
// module's interface.
#pragma once

#include <cstdint>
#include <functional>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "calib/rigid3.h"
#include "datasets/synth/raycast.h"
#include "datasets/synth/render.h"
#include "datasets/synth/sun_shadows.h"

namespace hdabench::datasets::synth::internal {

// What one camera ray sees.
struct Sample {
  bool hit = false;
  RayHit ray_hit;
  double reflectance = 0.0;  // including the ambient term
  unsigned char shadow = 0;  // 255 cast, 128 attached, 0 lit
};

struct FrameContext {
  const SceneRaycaster* raycaster;
  const TerrainShadows* shadows;  // for sun_in_local
  Eigen::Matrix3d local_from_cam;
  Eigen::Vector3d camera_in_local;
  Eigen::Vector3d sun_in_local;
  double ambient_reflectance;
};

// How a sample learns whether the sun is blocked.
enum class ShadowMode {
  kTrace,           // cast a shadow ray
  kAssumeLit,       // the surrounding pixel centres are all unblocked: no ray
  kAssumeShadowed,  // the surrounding pixel centres are all in cast shadow: no ray
};

using FrameProgress = std::function<void(double fraction_done)>;

// Whether another surface hides the sun from `hit`: the terrain's shadow
// height at the point just above the facet (kShadowRayOffsetM along its
// normal), then a shadow ray toward the rocks.
bool SunBlocked(const FrameContext& frame, const RayHit& hit);

// Casts the camera ray of `bearing_in_cam`, then (by `shadow_mode`) its shadow
// ray. Without `shade`, only the geometry and the shadow flag (no albedo, no
// reflectance).
Sample Shade(const FrameContext& frame, const Eigen::Vector3d& bearing_in_cam, bool shade,
             ShadowMode shadow_mode, std::int64_t* shadow_rays);

// The camera pose, sun and fill light of one frame, as Shade() reads them.
// `shadows` must be for the options' sun.
FrameContext MakeFrameContext(const SceneRaycaster& raycaster, const TerrainShadows& shadows,
                              const Rigid3d& cam_from_local, const RenderOptions& options);

// Allocates the image and the per-pixel truth of a width x height frame.
void AllocateFrame(int width, int height, int bit_depth, RenderedFrame* frame);

// Shadow mode of the samples of pixels rows [row0, row1] x cols [col0, col1]
// (clipped to the imager): a shadow ray only where the pixel centres of the
// box disagree about cast shadow (255), else the centres' common state; a
// shadow ray also when the box lies wholly outside the imager.
ShadowMode ShadowModeOfBox(const cv::Mat& shadow_mask, int row0, int row1, int col0, int col1);

// The sensor: shot noise on the electrons, full-well clip, read noise,
// rounding and clipping to [0, max_dn]; the noise is seeded per pixel.
double SensorDn(const RenderOptions& options, double signal_dn, std::uint64_t noise_seed,
                std::uint64_t pixel_index, double max_dn);

// The camera model (RenderOptions::AntiAliasing::kCamera): fills frame->image
// and the truth rasters; frame->dn_per_reflectance must be set.
void RenderCameraModel(const FrameContext& context, const Scene& scene, const CameraRays& rays,
                       const RenderOptions& options, std::uint64_t noise_seed, const FrameProgress& progress,
                       RenderedFrame* frame);

}  // namespace hdabench::datasets::synth::internal
