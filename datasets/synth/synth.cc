#include "datasets/synth/synth.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <map>
#include <sstream>

#include "tools/util/error.h"
#include "datasets/synth/noise.h"
#include "datasets/synth/raycast.h"
#include "datasets/synth/render.h"
#include "tools/util/options_check.h"
#include "tools/util/angles.h"
#include "tools/util/text.h"

namespace hdabench::datasets::synth {

namespace {

using util::DegToRad;
using util::kPi;

// Largest DEM the generator builds (nodes); a larger footprint needs a coarser
// dem_spacing_m. 60 M nodes of float are 240 MB.
constexpr double kMaxDemNodes = 60e6;

// Attitude of the body: x north (toward the ILS), y east, z down.
Eigen::Quaterniond LocalFromBodyRotation() {
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d(0, 1, 0);   // body x in local
  r.col(1) = Eigen::Vector3d(1, 0, 0);   // body y in local
  r.col(2) = Eigen::Vector3d(0, 0, -1);  // body z in local
  return Eigen::Quaterniond(r);
}

// Camera mount: optical axis off_nadir from body z toward body x; image right
// is body y (east), image down points back toward the vehicle.
Rigid3d CamFromBody(double off_nadir_rad) {
  const Eigen::Vector3d z_cam_in_body(std::sin(off_nadir_rad), 0.0, std::cos(off_nadir_rad));
  const Eigen::Vector3d x_cam_in_body(0.0, 1.0, 0.0);
  const Eigen::Vector3d y_cam_in_body = z_cam_in_body.cross(x_cam_in_body);
  Eigen::Matrix3d cam_from_body;
  cam_from_body.row(0) = x_cam_in_body.transpose();
  cam_from_body.row(1) = y_cam_in_body.transpose();
  cam_from_body.row(2) = z_cam_in_body.transpose();
  return Rigid3d(Eigen::Quaterniond(cam_from_body), Eigen::Vector3d::Zero());
}

calib::CameraModel DefaultCamera(const SynthOptions& o) {
  return DefaultSynthCamera(o.image_size_px, o.horizontal_fov_deg);
}

// True body position at time t (seconds from the first frame).
Eigen::Vector3d BodyPositionAt(const SynthOptions& o, double t) {
  const Eigen::Vector3d start(0.0, -o.standoff_m, o.altitude_m);
  Eigen::Vector3d direction;
  if (o.motion == Motion::kLateral) {
    direction = Eigen::Vector3d(1.0, 0.0, 0.0);  // east, across the line of sight
  } else if (o.motion == Motion::kForward) {
    direction = Eigen::Vector3d(0.0, 1.0, 0.0);  // north, level, toward the ILS
  } else if (o.motion == Motion::kVertical) {
    direction = Eigen::Vector3d(0.0, 0.0, 1.0);  // up
  } else {
    const double a = DegToRad(o.off_nadir_deg);
    direction = Eigen::Vector3d(0.0, std::sin(a), -std::cos(a));  // along the optical axis
  }
  // Centre the window on the start so the ILS stays in view throughout.
  return start + direction * o.speed_mps * (t - 0.5 * o.collection_s);
}

// A small rotation vector (radians) as a quaternion.
Eigen::Quaterniond SmallRotation(const Eigen::Vector3d& rotation_vector) {
  const double angle = rotation_vector.norm();
  if (angle == 0.0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, rotation_vector / angle));
}

// Standard normal from two hashed uniforms (Box-Muller), deterministic.
double HashNormal(std::uint64_t seed, std::uint64_t a, std::uint64_t b) {
  const double u1 = std::max(HashUniform(seed, a, b, 1), 1e-300);
  const double u2 = HashUniform(seed, a, b, 2);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

Eigen::Vector3d HashUnitVector(std::uint64_t seed, std::uint64_t a) {
  Eigen::Vector3d v(HashNormal(seed, a, 1), HashNormal(seed, a, 2), HashNormal(seed, a, 3));
  return v.norm() > 0 ? v.normalized() : Eigen::Vector3d::UnitX();
}

// Stream ids for the seeded generators, so each consumer is independent.
enum Stream : std::uint64_t { kTerrainStream = 1, kNavStream = 2, kLrfStream = 3, kRenderStream = 4 };

// Ground footprint of the frames on the plane z = 0: the bounding box of the
// points where border pixels' rays hit it. Throws when a border ray misses.
void FootprintExtent(const calib::CameraModel& camera, const std::vector<Rigid3d>& cams_from_local,
                     double* min_x, double* max_x, double* min_y, double* max_y) {
  std::vector<Eigen::Vector2d> border;
  const int w = camera.WidthPx();
  const int h = camera.HeightPx();
  const int step = std::max(1, std::min(w, h) / 32);
  for (int x = 0; x < w; x += step) {
    border.emplace_back(x, 0);
    border.emplace_back(x, h - 1);
  }
  for (int y = 0; y < h; y += step) {
    border.emplace_back(0, y);
    border.emplace_back(w - 1, y);
  }
  border.emplace_back(w - 1, h - 1);
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  camera.Unproject(border, &bearings, &valid);
  *min_x = *min_y = HUGE_VAL;
  *max_x = *max_y = -HUGE_VAL;
  for (const Rigid3d& cam_from_local : cams_from_local) {
    const Rigid3d local_from_cam = cam_from_local.Inverse();
    const Eigen::Vector3d center = local_from_cam.translation;
    for (size_t i = 0; i < border.size(); ++i) {
      const Eigen::Vector3d d = local_from_cam.rotation * bearings[i];
      // The ground must be hit well ahead: a ray within ~5 degrees of the
      // horizon (or above it) sees the sky or a footprint of unbounded size.
      if (!valid[i] || d.z() > -0.08) {
        throw InputError("the camera sees no terrain along pixel (" + std::to_string(border[i].x()) +
                         ", " + std::to_string(border[i].y()) +
                         "): its ray does not reach the ground within 85 degrees of nadir; "
                         "lower off_nadir_deg or horizontal_fov_deg");
      }
      if (center.z() <= 0.0) {
        throw InputError("the camera is at or below the ground (z = " + std::to_string(center.z()) +
                         " m); check altitude_m, speed_mps and collection_s");
      }
      const Eigen::Vector3d hit = center + d * (-center.z() / d.z());
      *min_x = std::min(*min_x, hit.x());
      *max_x = std::max(*max_x, hit.x());
      *min_y = std::min(*min_y, hit.y());
      *max_y = std::max(*max_y, hit.y());
    }
  }
}

}  // namespace

std::vector<std::string> SynthOptions::Validate() const {
  std::vector<std::string> e;
  RequireOption(image_size_px >= 16 && image_size_px <= 8192, "image_size_px", image_size_px,
          "in [16, 8192]", &e);
  RequireOption(horizontal_fov_deg > 0 && horizontal_fov_deg < 120, "horizontal_fov_deg",
          horizontal_fov_deg, "in (0, 120)", &e);
  RequireOption(altitude_m > 0, "altitude_m", altitude_m, "> 0", &e);
  RequireOption(standoff_m >= 0, "standoff_m", standoff_m, ">= 0", &e);
  RequireOption(off_nadir_deg >= 0 && off_nadir_deg < 80, "off_nadir_deg", off_nadir_deg, "in [0, 80)", &e);
  RequireOption(speed_mps >= 0, "speed_mps", speed_mps, ">= 0", &e);
  RequireOption(collection_s > 0, "collection_s", collection_s, "> 0", &e);
  RequireOption(frame_rate_hz > 0 && collection_s * frame_rate_hz >= 1 && collection_s * frame_rate_hz <= 1000,
          "frame_rate_hz", frame_rate_hz, "> 0, with 2 to 1001 frames in collection_s", &e);
  RequireOption(dem_spacing_m >= 0, "dem_spacing_m", dem_spacing_m, ">= 0 (0: automatic)", &e);
  RequireOption(terrain_scale > 0, "terrain_scale", terrain_scale, "> 0", &e);
  RequireOption(nav_rate_hz >= 1, "nav_rate_hz", nav_rate_hz, ">= 1", &e);
  RequireOption(lrf_rate_hz >= 1, "lrf_rate_hz", lrf_rate_hz, ">= 1", &e);
  RequireOption(nav_velocity_bias_mps >= 0, "nav_velocity_bias_mps", nav_velocity_bias_mps, ">= 0", &e);
  RequireOption(nav_position_noise_m >= 0, "nav_position_noise_m", nav_position_noise_m, ">= 0", &e);
  RequireOption(nav_attitude_drift_deg_per_s >= 0, "nav_attitude_drift_deg_per_s",
          nav_attitude_drift_deg_per_s, ">= 0", &e);
  RequireOption(nav_attitude_noise_deg >= 0, "nav_attitude_noise_deg", nav_attitude_noise_deg, ">= 0", &e);
  RequireOption(lrf_noise_m >= 0, "lrf_noise_m", lrf_noise_m, ">= 0", &e);
  RequireOption(std::isfinite(lrf_bias_m), "lrf_bias_m", lrf_bias_m, "a finite number", &e);
  RequireOption(threads >= 1 && threads <= 256, "threads", threads, "in [1, 256]", &e);
  for (const std::string& m : render.Validate()) e.push_back("render." + m);
  return e;
}

std::vector<std::string> SynthPresetNames() {
  return {"novac-lateral", "novac-forward", "novac-boresight", "truck", "aircraft", "helicopter"};
}

SynthOptions SynthPreset(const std::string& name) {
  SynthOptions o;
  o.preset = name;
  if (name == "novac-lateral") return o;
  if (name == "novac-forward") {
    // The approach as the paper's aircraft flew it ("constant altitude and
    // straight line trajectories, ... analogous to the planned lunar
    // trajectory"), at constant pitch: level flight toward the ILS. Same
    // place, speed and window as novac-lateral; the pair 0-6 is 31.2 m
    // apart, 22 m of it across the line of sight (31.2 cos 45 deg).
    o.motion = Motion::kForward;
    return o;
  }
  if (name == "novac-boresight") {
    o.motion = Motion::kBoresight;
    return o;
  }
  if (name == "truck") {
    // The truck campaign (paper, Truck Campaign): the Navpod on a pickup's
    // motorized lift, "camera and laser ranger point out the rear at a 45
    // degree angle", the quadtree image taken "from a height of about 4
    // meters". The lift's vertical motion is the baseline. Assumptions: 4 m
    // up at mid-window, the lift rising at 0.125 m/s, so that frames 0 and 6
    // (2.4 s) are 0.30 m apart, NOVA-C's baseline-to-range ratio at the 5.66 m
    // range. The terrain is scaled by the range's ratio to the lander's
    // (5.66 m against 566 m: 1/100), so a site is as many pixels as from the
    // lander.
    o.motion = Motion::kVertical;
    o.altitude_m = 4.0;
    o.standoff_m = 4.0;
    o.speed_mps = 0.125;
    o.terrain_scale = 1.0 / 100.0;
    o.terrain = "mare";
    o.lrf_noise_m = 0.002;
    o.nav_velocity_bias_mps = 0.0003;
    o.nav_position_noise_m = 0.0002;
    return o;
  }
  if (name == "aircraft") {
    // The aircraft campaign (paper, Aircraft Testing Campaign): "a ground
    // speed of about 80 m/s", "most commonly around 1800 meters", the camera
    // and the range finder "45 degrees off of nadir towards the nose", on
    // "constant altitude and straight line trajectories": level flight
    // toward the site. The paper scaled "the time step between images";
    // the pair is the one whose baseline-to-range ratio is NOVA-C's (frames
    // 0 and 8: 1.6 s, 128 m at 2546 m of range).
    o.motion = Motion::kForward;
    o.altitude_m = 1800.0;
    o.standoff_m = 1800.0;
    o.speed_mps = 80.0;
    o.collection_s = 2.0;
    o.frame_rate_hz = 5.0;
    o.terrain_scale = 4.0;
    o.lrf_noise_m = 0.5;
    o.nav_velocity_bias_mps = 0.1;
    o.nav_position_noise_m = 0.1;
    return o;
  }
  if (name == "helicopter") {
    // The helicopter campaign over KSC's boulder field (paper, Helicopter
    // Testing Campaign), which gives no geometry; assumptions: 150 m above
    // the ground and 150 m short of the site (the camera 45 deg off nadir,
    // as the lander's), 5 m/s sideways, so that the pair's baseline over
    // its 212 m of range is the NOVA-C ratio (0.053) within the 2.4 s
    // window. The boulders are real: the terrain at full scale.
    o.altitude_m = 150.0;
    o.standoff_m = 150.0;
    o.speed_mps = 5.0;
    o.collection_s = 2.4;
    o.terrain = "boulders";
    return o;
  }
  std::string names;
  for (const std::string& n : SynthPresetNames()) names += (names.empty() ? "" : ", ") + n;
  throw InputError("unknown preset '" + name + "'; expected one of: " + names);
}

void ScaleTerrain(double scale, TerrainOptions* t) {
  if (scale == 1.0) return;
  t->spacing_m *= scale;
  t->relief_rms_m *= scale;
  t->relief_largest_wavelength_m *= scale;
  t->crater_d_min_m *= scale;
  t->crater_d_max_m *= scale;
  t->crater_k *= std::pow(scale, -t->crater_exponent - 2.0);
  t->rock_d_min_m *= scale;
  t->rock_d_max_m *= scale;
  t->rock_k *= std::pow(scale, -t->rock_exponent - 2.0);
  t->rock_q_per_m /= scale;  // the exponential-area law: F(D) = k exp(-q D) keeps its shape
  t->albedo_finest_wavelength_m *= scale;
  t->albedo_coarsest_wavelength_m *= scale;
}

namespace {

double ParseDoubleValue(const std::string& key, const std::string& text) {
  size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::logic_error&) {
    used = std::string::npos;
  }
  if (used != text.size() || !std::isfinite(value)) {
    throw InputError("--set " + key + "=" + text + ": '" + text + "' is not a finite number");
  }
  return value;
}

// The overrides whose values are names or flags, as the unknown-key message lists them.
constexpr const char* kNamedOverrides =
    "motion attitude terrain terrain.rock_law render.anti_aliasing render.shot_noise";

// The value of `--set key=value` among `choices` (name, value), or an
// InputError listing the names.
template <typename T>
T Chosen(const std::string& key, const std::string& value,
         std::initializer_list<std::pair<const char*, T>> choices) {
  std::string names;
  size_t k = 0;
  for (const auto& [name, chosen] : choices) {
    if (value == name) return chosen;
    names += std::string(k == 0 ? "" : k + 1 == choices.size() ? " or " : ", ") + name;
    ++k;
  }
  throw InputError("--set " + key + "=" + value + ": expected " + names);
}

// Applies one of kNamedOverrides; false for any other key.
bool ApplyNamedOverride(const std::string& key, const std::string& value, SynthOptions* o, TerrainOptions* t) {
  RenderOptions& r = o->render;
  if (key == "terrain.rock_law") {
    ApplyRockLaw(value, t);
    return true;
  }
  if (key == "render.anti_aliasing") {
    using AntiAliasing = RenderOptions::AntiAliasing;
    r.anti_aliasing = Chosen<AntiAliasing>(
        key, value,
        {{"camera", AntiAliasing::kCamera}, {"quincunx", AntiAliasing::kQuincunx}, {"grid", AntiAliasing::kGrid}});
    return true;
  }
  if (key == "render.shot_noise") {
    r.shot_noise = Chosen<bool>(key, value, {{"0", false}, {"1", true}});
    return true;
  }
  if (key == "attitude") {
    o->attitude = Chosen<Attitude>(key, value, {{"fixed", Attitude::kFixed}, {"track", Attitude::kTrack}});
    return true;
  }
  if (key == "motion") {
    o->motion = Chosen<Motion>(key, value,
                               {{"lateral", Motion::kLateral},
                                {"forward", Motion::kForward},
                                {"boresight", Motion::kBoresight},
                                {"vertical", Motion::kVertical}});
    return true;
  }
  if (key == "terrain") {
    o->terrain = value;
    *t = TerrainPreset(value);
    return true;
  }
  return false;
}

}  // namespace

void ApplyOverride(const std::string& key, const std::string& value, SynthOptions* o,
                   TerrainOptions* t) {
  std::map<std::string, double*> doubles = {
      {"horizontal_fov_deg", &o->horizontal_fov_deg},
      {"altitude_m", &o->altitude_m},
      {"standoff_m", &o->standoff_m},
      {"off_nadir_deg", &o->off_nadir_deg},
      {"speed_mps", &o->speed_mps},
      {"collection_s", &o->collection_s},
      {"frame_rate_hz", &o->frame_rate_hz},
      {"dem_spacing_m", &o->dem_spacing_m},
      {"terrain_scale", &o->terrain_scale},
      {"nav_rate_hz", &o->nav_rate_hz},
      {"lrf_rate_hz", &o->lrf_rate_hz},
      {"nav_velocity_bias_mps", &o->nav_velocity_bias_mps},
      {"nav_position_noise_m", &o->nav_position_noise_m},
      {"nav_attitude_drift_deg_per_s", &o->nav_attitude_drift_deg_per_s},
      {"nav_attitude_noise_deg", &o->nav_attitude_noise_deg},
      {"lrf_noise_m", &o->lrf_noise_m},
      {"lrf_bias_m", &o->lrf_bias_m},
      {"terrain.relief_rms_m", &t->relief_rms_m},
      {"terrain.relief_hurst", &t->relief_hurst},
      {"terrain.relief_largest_wavelength_m", &t->relief_largest_wavelength_m},
      {"terrain.regional_slope_deg", &t->regional_slope_deg},
      {"terrain.regional_slope_downhill_azimuth_deg", &t->regional_slope_downhill_azimuth_deg},
      {"terrain.crater_k", &t->crater_k},
      {"terrain.crater_exponent", &t->crater_exponent},
      {"terrain.crater_d_min_m", &t->crater_d_min_m},
      {"terrain.crater_d_max_m", &t->crater_d_max_m},
      {"terrain.crater_depth_to_diameter", &t->crater_depth_to_diameter},
      {"terrain.crater_depth_to_diameter_spread", &t->crater_depth_to_diameter_spread},
      {"terrain.crater_rim_height_to_diameter", &t->crater_rim_height_to_diameter},
      {"terrain.crater_ejecta_extent_radii", &t->crater_ejecta_extent_radii},
      {"terrain.rock_k", &t->rock_k},
      {"terrain.rock_exponent", &t->rock_exponent},
      {"terrain.rock_area_fraction", &t->rock_area_fraction},
      {"terrain.rock_q_per_m", &t->rock_q_per_m},
      {"terrain.rock_d_min_m", &t->rock_d_min_m},
      {"terrain.rock_d_max_m", &t->rock_d_max_m},
      {"terrain.rock_protrusion_min", &t->rock_protrusion_min},
      {"terrain.rock_protrusion_max", &t->rock_protrusion_max},
      {"terrain.rock_albedo", &t->rock_albedo},
      {"terrain.rock_albedo_spread", &t->rock_albedo_spread},
      {"terrain.albedo_mean", &t->albedo_mean},
      {"terrain.albedo_relative_variation", &t->albedo_relative_variation},
      {"terrain.albedo_finest_wavelength_m", &t->albedo_finest_wavelength_m},
      {"terrain.albedo_coarsest_wavelength_m", &t->albedo_coarsest_wavelength_m},
  };
  RenderOptions& r = o->render;
  doubles.insert({{"render.sun_azimuth_deg", &r.sun_azimuth_deg},
                  {"render.sun_elevation_deg", &r.sun_elevation_deg},
                  {"render.dn_per_reflectance", &r.dn_per_reflectance},
                  {"render.target_mean_dn", &r.target_mean_dn},
                  {"render.gain_electrons_per_dn", &r.gain_electrons_per_dn},
                  {"render.full_well_electrons", &r.full_well_electrons},
                  {"render.read_noise_dn", &r.read_noise_dn},
                  {"render.ambient_reflectance", &r.ambient_reflectance},
                  {"render.fill_factor", &r.fill_factor},
                  {"render.f_number", &r.f_number},
                  {"render.wavelength_um", &r.wavelength_um},
                  {"render.pixel_pitch_um", &r.pixel_pitch_um},
                  {"render.defocus_sigma_px", &r.defocus_sigma_px}});
  std::map<std::string, int*> ints = {{"image_size_px", &o->image_size_px},
                                      {"threads", &o->threads},
                                      {"render.samples_per_pixel_axis", &r.samples_per_pixel_axis},
                                      {"render.adaptive_samples_per_cell_axis", &r.adaptive_samples_per_cell_axis},
                                      {"render.bit_depth", &r.bit_depth}};
  if (key == "terrain.rock_k" || key == "terrain.rock_exponent" || key == "terrain.rock_area_fraction" ||
      key == "terrain.rock_q_per_m") {
    t->rock_law = "custom";
  }
  if (ApplyNamedOverride(key, value, o, t)) return;
  if (const auto it = doubles.find(key); it != doubles.end()) {
    *it->second = ParseDoubleValue(key, value);
    return;
  }
  if (const auto it = ints.find(key); it != ints.end()) {
    const double v = ParseDoubleValue(key, value);
    if (v != std::floor(v) || std::abs(v) > 1e9) {
      throw InputError("--set " + key + "=" + value + ": expected a whole number");
    }
    *it->second = static_cast<int>(v);
    return;
  }
  std::string known;
  for (const auto& [name, unused] : doubles) known += " " + name;
  for (const auto& [name, unused] : ints) known += " " + name;
  throw InputError("--set " + key + "=" + value + ": unknown parameter '" + key +
                   "'; known: " + kNamedOverrides + known);
}

std::string SynthSummary::Summary() const {
  std::ostringstream s;
  s.precision(4);
  s << frames << " frames";
  if (static_cast<int>(rendered_frames.size()) != frames) s << " (images for " << util::JoinInts(rendered_frames) << ")";
  s << ", DEM " << dem_width << " x " << dem_height << " nodes at " << dem_spacing_m
    << " m, " << craters << " craters, " << rocks << " rocks; pair " << pair_frames.first << "-"
    << pair_frames.second << " baseline " << pair_baseline_m << " m; terrain " << terrain_s
    << " s, rendering " << render_s << " s";
  return s.str();
}

namespace {

// Throws InputError listing every problem of the options, one per line.
void ThrowIfInvalid(const SynthOptions& options) {
  hdabench::ThrowIfInvalid("invalid synthetic dataset options:\n  ", options.Validate(), "\n  ");
}

// Passes a stage's progress on when the caller asked for it.
void Report(const SynthProgress& progress, const std::string& stage, double fraction) {
  if (progress) progress(stage, fraction);
}

// The dataset's camera, name, description and fixed geometry, with no data yet.
Dataset EmptyDataset(const calib::CameraModel& camera, const SynthOptions& options, std::uint64_t seed) {
  Dataset dataset(camera);
  dataset.name = options.preset + "-" + options.terrain + "-seed" + std::to_string(seed);
  dataset.description = std::string(kSyntheticSceneDescription) + " preset " + options.preset + ", terrain " +
                        options.terrain + ", seed " + std::to_string(seed) + ".";
  dataset.cam_from_body = CamFromBody(DegToRad(options.off_nadir_deg));
  dataset.gravity_in_local_mps2 = Eigen::Vector3d(0.0, 0.0, -1.62);
  dataset.ils_in_local_m = Eigen::Vector3d::Zero();
  return dataset;
}

// True body pose at time t (seconds from the first frame). With
// Attitude::kTrack the fixed attitude is turned by the smallest rotation that
// takes its optical axis onto the line from the body to the ILS (the origin).
Rigid3d TrueLocalFromBody(const SynthOptions& options, double t) {
  const Eigen::Vector3d position = BodyPositionAt(options, t);
  const Eigen::Quaterniond fixed = LocalFromBodyRotation();
  if (options.attitude == Attitude::kFixed) return Rigid3d(fixed, position);
  const Eigen::Vector3d axis_in_body =
      CamFromBody(DegToRad(options.off_nadir_deg)).rotation.inverse() * Eigen::Vector3d::UnitZ();
  const Eigen::Quaterniond turn = Eigen::Quaterniond::FromTwoVectors(fixed * axis_in_body, -position);
  return Rigid3d((turn * fixed).normalized(), position);
}

// Frame times and the true camera poses at them.
struct FrameTrajectory {
  std::vector<double> times_s;
  std::vector<Rigid3d> cams_from_local;
};

// The frames of the collection window at frame_rate_hz, first at t = 0.
FrameTrajectory TrueFrames(const SynthOptions& options, const Rigid3d& cam_from_body) {
  const int num_frames = static_cast<int>(std::floor(options.collection_s * options.frame_rate_hz + 1e-9)) + 1;
  FrameTrajectory frames;
  for (int i = 0; i < num_frames; ++i) {
    const double t = i / options.frame_rate_hz;
    frames.times_s.push_back(t);
    frames.cams_from_local.push_back(cam_from_body * TrueLocalFromBody(options, t).Inverse());
  }
  return frames;
}

// Slant range from the start position to the ILS, metres.
double SlantRangeM(const SynthOptions& options) { return std::hypot(options.altitude_m, options.standoff_m); }

// The terrain options over the footprint of every frame, padded, at the DEM
// spacing (given, or half the ground size of a centre pixel). Throws
// InputError when the DEM would exceed kMaxDemNodes.
TerrainOptions TerrainOverFootprint(const SynthOptions& options, const TerrainOptions& terrain_options,
                                    const calib::CameraModel& camera,
                                    const std::vector<Rigid3d>& cams_from_local) {
  double min_x = 0, max_x = 0, min_y = 0, max_y = 0;
  FootprintExtent(camera, cams_from_local, &min_x, &max_x, &min_y, &max_y);
  TerrainOptions terrain = terrain_options;
  const double slant_m = SlantRangeM(options);
  const double focal_px = camera.HasCore() ? camera.Intrinsics()[0] : camera.WidthPx();
  const double spacing = options.dem_spacing_m > 0 ? options.dem_spacing_m : 0.5 * slant_m / focal_px;
  const double pad = 0.05 * std::max(max_x - min_x, max_y - min_y) + 10.0 * spacing;
  terrain.min_x_m = min_x - pad;
  terrain.max_x_m = max_x + pad;
  terrain.min_y_m = min_y - pad;
  terrain.max_y_m = max_y + pad;
  terrain.spacing_m = spacing;
  const double nodes = ((terrain.max_x_m - terrain.min_x_m) / spacing + 1) *
                       ((terrain.max_y_m - terrain.min_y_m) / spacing + 1);
  if (nodes > kMaxDemNodes) {
    std::ostringstream m;
    m << "the footprint (" << terrain.max_x_m - terrain.min_x_m << " x "
      << terrain.max_y_m - terrain.min_y_m << " m) at dem_spacing_m " << spacing << " needs "
      << nodes / 1e6 << " M DEM nodes, over the limit of " << kMaxDemNodes / 1e6
      << " M; set a larger dem_spacing_m";
    throw InputError(m.str());
  }
  return terrain;
}

// Generates the scene between the "terrain" progress reports; *seconds gets its wall time.
Scene TimedScene(const TerrainOptions& terrain, std::uint64_t seed, int threads, const SynthProgress& progress,
                 double* seconds) {
  Report(progress, "terrain", 0.0);
  const auto t_terrain = std::chrono::steady_clock::now();
  Scene scene = GenerateScene(terrain, Mix64(seed ^ kTerrainStream), threads);
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_terrain).count();
  Report(progress, "terrain", 1.0);
  return scene;
}

// The render options of the sequence. One exposure for the whole sequence:
// the auto-exposure of a flat patch of the mean albedo at the ILS seen from
// the middle of the window.
RenderOptions SequenceRenderOptions(const SynthOptions& options, double albedo_mean,
                                    const Eigen::Vector3d& ils_in_local_m) {
  RenderOptions render = options.render;
  render.threads = options.threads;
  if (render.dn_per_reflectance <= 0.0) {
    const Eigen::Vector3d to_camera =
        (BodyPositionAt(options, 0.5 * options.collection_s) - ils_in_local_m).normalized();
    render.dn_per_reflectance = ExposureFor(render, albedo_mean, to_camera);
  }
  return render;
}

// Appends a record of every frame, with its time and image path and no image.
void AddFrameRecords(const FrameTrajectory& frames, Dataset* dataset) {
  for (int i = 0; i < static_cast<int>(frames.times_s.size()); ++i) {
    FrameRecord frame;
    frame.index = i;
    frame.time_s = frames.times_s[static_cast<size_t>(i)];
    char name[64];
    std::snprintf(name, sizeof(name), "images/frame_%06d.png", i);
    frame.image_path = name;
    dataset->frames.push_back(frame);
  }
}

// The frames options.frames_to_render picks (every frame without it),
// ascending; InputError for an index out of range, a repeated one or fewer
// than two.
std::vector<int> FramesToRender(const SynthOptions& options, const Dataset& dataset) {
  const int num_frames = static_cast<int>(dataset.frames.size());
  std::vector<int> chosen;
  if (!options.frames_to_render) {
    for (int i = 0; i < num_frames; ++i) chosen.push_back(i);
    return chosen;
  }
  chosen = options.frames_to_render(dataset);
  std::sort(chosen.begin(), chosen.end());
  for (size_t k = 0; k < chosen.size(); ++k) {
    if (chosen[k] < 0 || chosen[k] >= num_frames) {
      throw InputError("frame " + std::to_string(chosen[k]) + " is not a frame of the scene, which has frames 0.." +
                       std::to_string(num_frames - 1));
    }
    if (k > 0 && chosen[k] == chosen[k - 1]) {
      throw InputError("frame " + std::to_string(chosen[k]) + " is given twice");
    }
  }
  if (chosen.size() < 2) {
    throw InputError("render at least 2 frames (a run needs two views); " + std::to_string(chosen.size()) +
                     " given");
  }
  return chosen;
}

// Renders the frames `chosen` into the dataset's records (the image and the
// truth points), between the "render" progress reports; the other frames lose
// their image path. Each frame's noise depends on its index only. Returns the
// wall time, seconds.
double RenderFrames(const SceneRaycaster& raycaster, const Scene& scene, const calib::CameraModel& camera,
                    const FrameTrajectory& frames, const RenderOptions& render, const std::vector<int>& chosen,
                    int threads, std::uint64_t seed, const SynthProgress& progress, Dataset* dataset) {
  const int num_chosen = static_cast<int>(chosen.size());
  Report(progress, "render", 0.0);
  const auto t_render = std::chrono::steady_clock::now();
  const CameraRays rays(camera, threads);
  const TerrainShadows shadows(scene.dem, SunDirectionInLocal(render.sun_azimuth_deg, render.sun_elevation_deg));
  for (int k = 0; k < num_chosen; ++k) {
    const int i = chosen[static_cast<size_t>(k)];
    const RenderedFrame rendered = RenderFrame(
        raycaster, scene, rays, frames.cams_from_local[static_cast<size_t>(i)], render,
        Mix64(seed ^ kRenderStream) + static_cast<std::uint64_t>(i),
        [&](double fraction) { Report(progress, "render", (k + fraction) / num_chosen); }, &shadows);
    dataset->frames[static_cast<size_t>(i)].image = rendered.image;
    TruthPoints points;
    points.frame = i;
    char name[64];
    std::snprintf(name, sizeof(name), "truth/points_%06d.npy", i);
    points.file = name;
    points.points_in_local_m = rendered.points_in_local_m;
    dataset->truth.points.push_back(points);
  }
  for (FrameRecord& frame : dataset->frames) {
    if (frame.image.empty()) frame.image_path.clear();
  }
  Report(progress, "render", 1.0);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t_render).count();
}

// Nav and LRF sample times: the frames' span, extended this far at each end, seconds.
constexpr double kSensorMarginS = 0.2;

// Navigation over [t0, t1]: truth at nav_rate_hz, measured = truth with
// IMU-like errors relative to the first frame (bias drift plus white noise).
void AddNavigation(const SynthOptions& options, std::uint64_t seed, double first_frame_s, double t0, double t1,
                   Dataset* dataset) {
  const std::uint64_t nav_seed = Mix64(seed ^ kNavStream);
  const Eigen::Vector3d velocity_bias = HashUnitVector(nav_seed, 1) * options.nav_velocity_bias_mps;
  const Eigen::Vector3d drift_axis = HashUnitVector(nav_seed, 2);
  const int num_nav = static_cast<int>(std::ceil((t1 - t0) * options.nav_rate_hz)) + 1;
  const double sigma_att_rad = DegToRad(options.nav_attitude_noise_deg);
  for (int k = 0; k < num_nav; ++k) {
    const double t = std::min(t0 + k / options.nav_rate_hz, t1);
    NavSample truth;
    truth.time_s = t;
    truth.local_from_body = TrueLocalFromBody(options, t);
    const Eigen::Vector3d velocity =
        (BodyPositionAt(options, t + 1e-3) - BodyPositionAt(options, t - 1e-3)) / 2e-3;
    truth.velocity_in_local_mps = velocity;
    dataset->truth.navigation.push_back(truth);

    NavSample measured = truth;
    const double dt = t - first_frame_s;
    const Eigen::Vector3d position_noise(HashNormal(nav_seed, 10, static_cast<std::uint64_t>(k) * 3),
                                         HashNormal(nav_seed, 10, static_cast<std::uint64_t>(k) * 3 + 1),
                                         HashNormal(nav_seed, 10, static_cast<std::uint64_t>(k) * 3 + 2));
    measured.local_from_body.translation += velocity_bias * dt + position_noise * options.nav_position_noise_m;
    const Eigen::Vector3d attitude_noise(HashNormal(nav_seed, 20, static_cast<std::uint64_t>(k) * 3),
                                         HashNormal(nav_seed, 20, static_cast<std::uint64_t>(k) * 3 + 1),
                                         HashNormal(nav_seed, 20, static_cast<std::uint64_t>(k) * 3 + 2));
    const Eigen::Vector3d rotation_error_in_body =
        drift_axis * DegToRad(options.nav_attitude_drift_deg_per_s) * dt + attitude_noise * sigma_att_rad;
    measured.local_from_body.rotation =
        (truth.local_from_body.rotation * SmallRotation(rotation_error_in_body)).normalized();
    measured.velocity_in_local_mps = velocity + velocity_bias;
    measured.sigma_position_in_local_m =
        Eigen::Vector3d::Constant(std::hypot(options.nav_position_noise_m,
                                             options.nav_velocity_bias_mps * std::abs(dt)));
    measured.sigma_attitude_in_body_rad = Eigen::Vector3d::Constant(
        std::hypot(sigma_att_rad, DegToRad(options.nav_attitude_drift_deg_per_s) * std::abs(dt)));
    dataset->nav.push_back(measured);
  }
  dataset->nav_has_velocity = true;
  dataset->nav_has_sigmas = true;
  dataset->truth.navigation_file = "truth/nav_truth.csv";
}

// LRF over [t0, t1] at lrf_rate_hz: co-boresighted with the camera, from the
// body origin; the true range is cast against the scene, then noise and bias
// are added. Throws InputError when the beam misses the terrain.
void AddLrf(const SynthOptions& options, std::uint64_t seed, const SceneRaycaster& raycaster, double t0,
            double t1, Dataset* dataset) {
  const Eigen::Vector3d boresight_in_body =
      dataset->cam_from_body.rotation.conjugate() * Eigen::Vector3d::UnitZ();
  const std::uint64_t lrf_seed = Mix64(seed ^ kLrfStream);
  const int num_lrf = static_cast<int>(std::ceil((t1 - t0) * options.lrf_rate_hz)) + 1;
  for (int k = 0; k < num_lrf; ++k) {
    const double t = std::min(t0 + k / options.lrf_rate_hz, t1);
    const Rigid3d local_from_body = TrueLocalFromBody(options, t);
    const Eigen::Vector3d origin = local_from_body * dataset->lrf_origin_in_body_m;
    const Eigen::Vector3d direction = local_from_body.rotation * boresight_in_body;
    RayHit hit;
    if (!raycaster.Intersect(origin, direction, 1e7, &hit)) {
      throw InputError("the LRF beam at t = " + std::to_string(t) +
                       " s does not hit the terrain; the ILS must be inside the DEM");
    }
    LrfSample sample;
    sample.time_s = t;
    sample.range_m = std::max(1e-3, hit.distance_m + options.lrf_bias_m +
                                        options.lrf_noise_m * HashNormal(lrf_seed, 1, static_cast<std::uint64_t>(k)));
    sample.boresight_in_body = boresight_in_body;
    dataset->lrf.push_back(sample);
  }
}

// Truth DEM and rocks of the scene.
void AddTruthDemAndRocks(const Scene& scene, Dataset* dataset) {
  TruthDem dem;
  dem.file = "truth/dem.npy";
  dem.origin_in_local_m = Eigen::Vector2d(scene.dem.origin_x_m, scene.dem.origin_y_m);
  dem.spacing_m = scene.dem.spacing_m;
  dem.width_cells = scene.dem.width;
  dem.height_cells = scene.dem.height;
  dem.height_in_local_m = cv::Mat(scene.dem.height, scene.dem.width, CV_32FC1,
                                  const_cast<float*>(scene.dem.height_m.data()))
                              .clone();
  dataset->truth.dem = std::move(dem);
  dataset->truth.rocks_file = "truth/rocks.csv";
  for (const Rock& rock : scene.rocks) {
    TruthRock r;
    r.center_in_local_m = rock.center_in_local_m;
    r.diameter_m = 2.0 * rock.radius_m;
    r.height_above_ground_m = rock.height_above_ground_m;
    dataset->truth.rocks.push_back(r);
  }
}

// The frame pair whose true baseline-to-range ratio is closest to NOVA-C's
// 30 m at 566 m, into the summary.
void ChooseSummaryPair(const SynthOptions& options, const std::vector<double>& frame_times,
                       SynthSummary* summary) {
  const int num_frames = static_cast<int>(frame_times.size());
  const double target = 30.0 / 566.0 * SlantRangeM(options);
  double best = HUGE_VAL;
  for (int j = 1; j < num_frames; ++j) {
    const double baseline =
        (BodyPositionAt(options, frame_times[j]) - BodyPositionAt(options, frame_times[0])).norm();
    if (std::abs(baseline - target) < best) {
      best = std::abs(baseline - target);
      summary->pair_frames = {0, j};
      summary->pair_baseline_m = baseline;
    }
  }
}

}  // namespace

Dataset GenerateSynthDataset(const SynthOptions& options, const TerrainOptions& terrain_options,
                             std::uint64_t seed, const SynthProgress& progress,
                             SynthSummary* summary) {
  ThrowIfInvalid(options);
  calib::CameraModel camera = options.camera_model.has_value()     ? *options.camera_model
                              : options.camera_model_file.empty() ? DefaultCamera(options)
                                                                  : calib::CameraModel::Load(options.camera_model_file);
  Dataset dataset = EmptyDataset(camera, options, seed);
  const FrameTrajectory frames = TrueFrames(options, dataset.cam_from_body);

  const TerrainOptions terrain = TerrainOverFootprint(options, terrain_options, camera, frames.cams_from_local);
  double terrain_s = 0.0;
  const Scene scene = TimedScene(terrain, seed, options.threads, progress, &terrain_s);
  const SceneRaycaster raycaster(scene);

  AddFrameRecords(frames, &dataset);
  const double t0 = frames.times_s.front() - kSensorMarginS;
  const double t1 = frames.times_s.back() + kSensorMarginS;
  AddNavigation(options, seed, frames.times_s.front(), t0, t1, &dataset);
  AddLrf(options, seed, raycaster, t0, t1, &dataset);
  const std::vector<int> chosen = FramesToRender(options, dataset);

  const RenderOptions render = SequenceRenderOptions(options, terrain.albedo_mean, dataset.ils_in_local_m);
  const double render_s = RenderFrames(raycaster, scene, camera, frames, render, chosen, options.threads, seed,
                                       progress, &dataset);
  AddTruthDemAndRocks(scene, &dataset);
  TruthImaging imaging;
  imaging.sun_in_local = SunDirectionInLocal(render.sun_azimuth_deg, render.sun_elevation_deg);
  imaging.gain_electrons_per_dn = render.shot_noise ? render.gain_electrons_per_dn : 0.0;
  imaging.read_noise_dn = render.read_noise_dn;
  dataset.truth.imaging = imaging;

  if (summary != nullptr) {
    summary->frames = static_cast<int>(frames.times_s.size());
    summary->rendered_frames = chosen;
    summary->rocks = static_cast<int>(scene.rocks.size());
    summary->craters = static_cast<int>(scene.craters.size());
    summary->dem_spacing_m = terrain.spacing_m;
    summary->dem_width = scene.dem.width;
    summary->dem_height = scene.dem.height;
    summary->terrain_s = terrain_s;
    summary->render_s = render_s;
    ChooseSummaryPair(options, frames.times_s, summary);
  }
  return dataset;
}

calib::CameraModel DefaultSynthCamera(int image_size_px, double horizontal_fov_deg) {
  const double n = image_size_px;
  const double f = 0.5 * n / std::tan(0.5 * DegToRad(horizontal_fov_deg));
  const double c = 0.5 * (n - 1.0);
  // Mild barrel distortion: about 1.5 px at the corners of a 1024 imager.
  return calib::CameraModel("LENSMODEL_OPENCV8", {f, f, c, c, -0.02, 0.005, 1e-5, -1e-5, 0.0, 0.0, 0.0, 0.0},
                            image_size_px, image_size_px);
}

}  // namespace hdabench::datasets::synth
