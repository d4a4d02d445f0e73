#include "datasets/synth/optics.h"

#include <algorithm>
#include <cmath>

namespace hdabench::datasets::synth {

namespace {

// Antiderivative of the standard normal cumulative distribution:
// integral of Phi from -infinity to u = u Phi(u) + phi(u).
double IntegralOfPhi(double u) {
  const double phi = std::exp(-0.5 * u * u) * 0.3989422804014327;  // 1 / sqrt(2 pi)
  const double cdf = 0.5 * std::erfc(-u / std::sqrt(2.0));
  return u * cdf + phi;
}

}  // namespace

double DiffractionSigmaPx(double wavelength_um, double f_number, double pixel_pitch_um) {
  return 0.42 * wavelength_um * f_number / pixel_pitch_um;
}

double PixelResponse1d::EdgeSpread(double t_px) const {
  const double half = 0.5 * aperture_px;
  if (sigma_px < 1e-9) return std::clamp((t_px + half) / aperture_px, 0.0, 1.0);
  // Integral over s < t of [Phi((s + half) / sigma) - Phi((s - half) / sigma)] / aperture.
  const double value =
      sigma_px / aperture_px * (IntegralOfPhi((t_px + half) / sigma_px) - IntegralOfPhi((t_px - half) / sigma_px));
  return std::clamp(value, 0.0, 1.0);
}

double PixelResponse1d::CellWeight(double t_px, double width_px) const {
  return EdgeSpread(t_px + 0.5 * width_px) - EdgeSpread(t_px - 0.5 * width_px);
}

double PixelResponse1d::SupportRadiusPx() const { return 0.5 * aperture_px + 6.1 * sigma_px; }

}  // namespace hdabench::datasets::synth
