#include "reference/direct/cubic_spline.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace hdabench::reference {

namespace {

// The cubic B-spline and its derivative at x.
double BSpline3(double x) {
  const double t = std::abs(x);
  if (t < 1.0) return 2.0 / 3.0 - t * t + 0.5 * t * t * t;
  if (t < 2.0) return (2.0 - t) * (2.0 - t) * (2.0 - t) / 6.0;
  return 0.0;
}
double BSpline3Derivative(double x) {
  const double t = std::abs(x);
  const double sign = x < 0.0 ? -1.0 : 1.0;
  if (t < 1.0) return sign * (-2.0 * t + 1.5 * t * t);
  if (t < 2.0) return -sign * 0.5 * (2.0 - t) * (2.0 - t);
  return 0.0;
}

// The weights of samples i-1 .. i+2 at i + t, t in [0, 1), and their
// derivatives in t.
void Weights(double t, double w[4], double dw[4]) {
  for (int k = 0; k < 4; ++k) {
    w[k] = BSpline3(t - (k - 1));
    dw[k] = BSpline3Derivative(t - (k - 1));
  }
}

// In place: samples to the coefficients of the cubic B-spline that
// interpolates them (the causal and anti-causal recursions of pole
// sqrt(3) - 2, mirror boundaries).
void Prefilter(double* c, int n, int stride) {
  if (n < 2) return;
  const double z = std::sqrt(3.0) - 2.0;
  const auto at = [&](int i) -> double& { return c[static_cast<ptrdiff_t>(i) * stride]; };
  for (int i = 0; i < n; ++i) at(i) *= 6.0;  // (1 - z)(1 - 1/z)
  const int horizon = std::min(n, 30);     // |z|^30 < 1e-17
  double sum = at(0), zk = z;
  for (int k = 1; k < horizon; ++k, zk *= z) sum += zk * at(k);
  at(0) = sum;
  for (int i = 1; i < n; ++i) at(i) += z * at(i - 1);
  at(n - 1) = (z / (z * z - 1.0)) * (at(n - 1) + z * at(n - 2));
  for (int i = n - 2; i >= 0; --i) at(i) = z * (at(i + 1) - at(i));
}

}  // namespace

cv::Mat CubicSplineRowCoefficients(const cv::Mat& image) {
  cv::Mat c;
  image.convertTo(c, CV_64F);
  for (int r = 0; r < c.rows; ++r) Prefilter(c.ptr<double>(r), c.cols, 1);
  return c;
}

cv::Mat CubicSplineCoefficients(const cv::Mat& image) {
  cv::Mat c = CubicSplineRowCoefficients(image);
  for (int col = 0; col < c.cols; ++col) {
    Prefilter(c.ptr<double>(0) + col, c.rows, static_cast<int>(c.step1()));
  }
  return c;
}

SplineSample SampleCubicSpline(const cv::Mat& coefficients, double x, double y) {
  const int c = static_cast<int>(std::floor(x));
  const int r = static_cast<int>(std::floor(y));
  double kx[4], dkx[4], ky[4], dky[4];
  Weights(x - c, kx, dkx);
  Weights(y - r, ky, dky);
  SplineSample s;
  for (int j = 0; j < 4; ++j) {
    const double* row = coefficients.ptr<double>(r - 1 + j);
    double v = 0.0, d = 0.0;
    for (int i = 0; i < 4; ++i) {
      v += row[c - 1 + i] * kx[i];
      d += row[c - 1 + i] * dkx[i];
    }
    s.value += v * ky[j];
    s.dx += d * ky[j];
    s.dy += v * dky[j];
  }
  return s;
}

bool InsideSpline(const cv::Mat& coefficients, double x, double y) {
  return x >= 1.0 && y >= 1.0 && x < coefficients.cols - 2 && y < coefficients.rows - 2;
}

double SampleCubicSplineRow(const cv::Mat& row_coefficients, int row, double x, double* dx) {
  const int c = static_cast<int>(std::floor(x));
  double k[4], dk[4];
  Weights(x - c, k, dk);
  const double* coefficients = row_coefficients.ptr<double>(row);
  const int last = row_coefficients.cols - 1;
  double value = 0.0;
  *dx = 0.0;
  for (int i = 0; i < 4; ++i) {
    const double sample = coefficients[std::clamp(c - 1 + i, 0, last)];
    value += k[i] * sample;
    *dx += dk[i] * sample;
  }
  return value;
}

}  // namespace hdabench::reference
