// The camera's response to light in the image plane, as the renderer's camera
// model applies it: each pixel integrates the image over its light-sensitive
// area (a centred square of side sqrt(fill factor) pixels), blurred by the
// optics' point-spread function (a Gaussian standing for diffraction plus
// defocus and aberrations). The response is separable: the 2-D pixel response
// is the product of the 1-D one along x and along y.
#pragma once

namespace hdabench::datasets::synth {

// Standard deviation, in pixels, of the Gaussian that best fits the core of
// the Airy pattern of a circular aperture: 0.42 * wavelength * f-number /
// pixel pitch (Zhang, Zerubia and Olivo-Marin, "Gaussian approximations of
// fluorescence microscope point-spread function models", Applied Optics 46,
// 2007: sigma = 0.21 lambda / NA, NA = 1 / (2 N)).
double DiffractionSigmaPx(double wavelength_um, double f_number, double pixel_pitch_um);

// The 1-D pixel response k(t) = box(aperture_px) (*) N(0, sigma_px^2), t in
// pixels from the pixel centre; it integrates to 1. sigma_px = 0 is the box.
struct PixelResponse1d {
  double aperture_px = 1.0;  // side of the light-sensitive square, pixels: sqrt(fill factor)
  double sigma_px = 0.0;     // Gaussian blur, pixels (>= 0)

  // Integral of k from -infinity to t: the edge-spread function, the value a
  // pixel centred at 0 takes on a unit step rising at -t (0 to 1).
  double EdgeSpread(double t_px) const;
  // Integral of k over [t - width/2, t + width/2].
  double CellWeight(double t_px, double width_px) const;
  // Half-width beyond which k is below 1e-9 of its integral.
  double SupportRadiusPx() const;
};

}  // namespace hdabench::datasets::synth
