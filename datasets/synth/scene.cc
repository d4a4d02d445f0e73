#include "datasets/synth/scene.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "datasets/synth/noise.h"

namespace hdabench::datasets::synth {

namespace {

// The triangle of the cell under (x, y): its three corner nodes in local
// coordinates. Cells are split along the diagonal (r, c) -> (r+1, c+1).
bool CellTriangle(const Heightfield& dem, double x_m, double y_m, Eigen::Vector3d corners[3]) {
  if (dem.width < 2 || dem.height < 2) return false;
  const double u = (x_m - dem.origin_x_m) / dem.spacing_m;   // column coordinate
  const double v = (dem.origin_y_m - y_m) / dem.spacing_m;   // row coordinate
  if (!(u >= 0.0 && v >= 0.0 && u <= dem.width - 1 && v <= dem.height - 1)) return false;
  const int c = std::min(static_cast<int>(u), dem.width - 2);
  const int r = std::min(static_cast<int>(v), dem.height - 2);
  const double fu = u - c;
  const double fv = v - r;
  const auto node = [&](int rr, int cc) {
    return Eigen::Vector3d(dem.origin_x_m + cc * dem.spacing_m, dem.origin_y_m - rr * dem.spacing_m,
                           dem.At(rr, cc));
  };
  corners[0] = node(r, c);
  corners[1] = node(r + 1, c + 1);
  // Upper-right triangle (fu >= fv) holds node (r, c+1); the other (r+1, c).
  corners[2] = fu >= fv ? node(r, c + 1) : node(r + 1, c);
  return true;
}

}  // namespace

bool Heightfield::HeightAt(double x_m, double y_m, double* z_m) const {
  Eigen::Vector3d p[3];
  if (!CellTriangle(*this, x_m, y_m, p)) return false;
  // The plane through the triangle, evaluated at (x, y).
  const Eigen::Vector3d n = (p[1] - p[0]).cross(p[2] - p[0]);
  *z_m = p[0].z() - (n.x() * (x_m - p[0].x()) + n.y() * (y_m - p[0].y())) / n.z();
  return true;
}

bool Heightfield::NormalAt(double x_m, double y_m, Eigen::Vector3d* normal) const {
  Eigen::Vector3d p[3];
  if (!CellTriangle(*this, x_m, y_m, p)) return false;
  Eigen::Vector3d n = (p[1] - p[0]).cross(p[2] - p[0]).normalized();
  if (n.z() < 0.0) n = -n;
  *normal = n;
  return true;
}

bool Heightfield::HeightAtGrid(double u, double v, double* z_m) const {
  if (width < 2 || height < 2 || !(u >= 0.0 && v >= 0.0 && u <= width - 1 && v <= height - 1)) return false;
  const int c = std::min(static_cast<int>(u), width - 2);
  const int r = std::min(static_cast<int>(v), height - 2);
  const double fu = u - c;
  const double fv = v - r;
  *z_m = CellSurfaceHeight(At(r, c), At(r, c + 1), At(r + 1, c), At(r + 1, c + 1), fu, fv);
  return true;
}

bool Heightfield::MeanNormalAt(double x_m, double y_m, double half_width_m, Eigen::Vector3d* normal) const {
  double east = 0.0, west = 0.0, north = 0.0, south = 0.0;
  const double u = (x_m - origin_x_m) / spacing_m;
  const double v = (origin_y_m - y_m) / spacing_m;
  const double h = half_width_m / spacing_m;
  if (!(h > 0.0) || !HeightAtGrid(u + h, v, &east) || !HeightAtGrid(u - h, v, &west) ||
      !HeightAtGrid(u, v - h, &north) || !HeightAtGrid(u, v + h, &south)) {
    return NormalAt(x_m, y_m, normal);
  }
  const double dz_dx = (east - west) / (2.0 * half_width_m);
  const double dz_dy = (north - south) / (2.0 * half_width_m);
  *normal = Eigen::Vector3d(-dz_dx, -dz_dy, 1.0).normalized();
  return true;
}

double AlbedoField::At(double x_m, double y_m, double filter_sigma_m) const {
  double variation = 0.0;  // [-1, 1]
  if (edge) {
    const double d = edge_normal.dot(Eigen::Vector2d(x_m, y_m)) - edge_offset_m;
    variation = filter_sigma_m > 0.0 ? std::erf(d / (std::sqrt(2.0) * filter_sigma_m)) : (d > 0.0 ? 1.0 : -1.0);
  } else {
    variation = FractalNoise(seed, x_m, y_m, finest_wavelength_m, coarsest_wavelength_m, 0.5, filter_sigma_m);
  }
  return std::clamp(mean * (1.0 + relative_variation * variation), 1e-3, 1.0);
}

}  // namespace hdabench::datasets::synth
