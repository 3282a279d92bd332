#include "tools/normal_map/normal_map_gen.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <random>
#include <vector>

namespace glint::normal_map_gen {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Uniform [0, 1) and standard normal draws from the standard-fixed mt19937_64 sequence.
class Rng {
 public:
  explicit Rng(uint64_t seed) : mt_(seed) {}
  double Uniform() { return double(mt_() >> 11) * 0x1.0p-53; }
  double Normal() {  // Box-Muller
    const double u1 = 1.0 - Uniform(), u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2 * kPi * u2);
  }

 private:
  std::mt19937_64 mt_;
};

// In-place radix-2 FFT (inverse when `inverse`, unnormalised) of n = 2^k values.
void Fft(std::vector<std::complex<double>> &a, bool inverse) {
  const size_t n = a.size();
  for (size_t i = 1, j = 0; i < n; ++i) {
    size_t bit = n >> 1;
    for (; j & bit; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(a[i], a[j]);
  }
  for (size_t len = 2; len <= n; len <<= 1) {
    const double ang = 2 * kPi / double(len) * (inverse ? 1 : -1);
    const std::complex<double> wl(std::cos(ang), std::sin(ang));
    for (size_t i = 0; i < n; i += len) {
      std::complex<double> w(1);
      for (size_t k = 0; k < len / 2; ++k) {
        const auto u = a[i + k], v = a[i + k + len / 2] * w;
        a[i + k] = u + v;
        a[i + k + len / 2] = u - v;
        w *= wl;
      }
    }
  }
}

// A periodic heightfield with the Gaussian power spectrum exp(-(fx/bx)^2 - (fy/by)^2) (fx, fy
// in cycles per map) and random phases: the real part of the inverse 2D FFT of amplitude x
// e^{i phase}.
std::vector<double> SpectrumHeights(uint32_t n, double bx, double by, Rng &rng) {
  std::vector<std::complex<double>> f(size_t(n) * n);
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      const double fx = i <= n / 2 ? double(i) : double(i) - n;
      const double fy = j <= n / 2 ? double(j) : double(j) - n;
      const double amp = std::exp(-0.5 * ((fx / bx) * (fx / bx) + (fy / by) * (fy / by)));
      f[size_t(j) * n + i] = std::polar(amp, 2 * kPi * rng.Uniform());
    }
  f[0] = 0.0;  // no mean height
  std::vector<std::complex<double>> row(n);
  for (uint32_t j = 0; j < n; ++j) {
    std::copy(f.begin() + ptrdiff_t(j) * n, f.begin() + ptrdiff_t(j + 1) * n, row.begin());
    Fft(row, true);
    std::copy(row.begin(), row.end(), f.begin() + ptrdiff_t(j) * n);
  }
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t j = 0; j < n; ++j) row[j] = f[size_t(j) * n + i];
    Fft(row, true);
    for (uint32_t j = 0; j < n; ++j) f[size_t(j) * n + i] = row[j];
  }
  std::vector<double> h(f.size());
  for (size_t k = 0; k < f.size(); ++k) h[k] = f[k].real();
  return h;
}

// Normals of a periodic heightfield (height in texel units) by central differences, scaled so
// that the RMS slope is `rms_slope`.
void HeightsToNormals(uint32_t n, const std::vector<double> &h, double rms_slope,
                      DecodedNormalMap *out) {
  std::vector<double> gx(h.size()), gy(h.size());
  double sum2 = 0.0;
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      const size_t k = size_t(j) * n + i;
      gx[k] = 0.5 * (h[size_t(j) * n + (i + 1) % n] - h[size_t(j) * n + (i + n - 1) % n]);
      gy[k] = 0.5 * (h[size_t((j + 1) % n) * n + i] - h[size_t((j + n - 1) % n) * n + i]);
      sum2 += gx[k] * gx[k] + gy[k] * gy[k];
    }
  const double scale = sum2 > 0 ? rms_slope / std::sqrt(sum2 / double(h.size())) : 0.0;
  out->width = out->height = n;
  out->xyz.resize(h.size() * 3);
  for (size_t k = 0; k < h.size(); ++k) {
    const double x = -gx[k] * scale, y = -gy[k] * scale, len = std::sqrt(x * x + y * y + 1.0);
    out->xyz[3 * k] = float(x / len);
    out->xyz[3 * k + 1] = float(y / len);
    out->xyz[3 * k + 2] = float(1.0 / len);
  }
}

void Flakes(uint32_t n, double alpha, Rng &rng, DecodedNormalMap *out) {
  // Poisson-disk centres by dart throwing (periodic), minimum distance r, on a grid of r / sqrt2.
  const double r = std::max(2.0, double(n) / 48.0);
  const double cell = r / std::sqrt(2.0);
  const int g = std::max(1, int(double(n) / cell));
  const double gc = double(n) / g;
  std::vector<int> grid(size_t(g) * g, -1);
  std::vector<std::pair<double, double>> pts;
  auto wrap = [&](double d) { return d - double(n) * std::round(d / double(n)); };
  const int tries = 30 * g * g;
  for (int t = 0; t < tries; ++t) {
    const double x = rng.Uniform() * n, y = rng.Uniform() * n;
    const int cx = std::min(g - 1, int(x / gc)), cy = std::min(g - 1, int(y / gc));
    bool ok = grid[size_t(cy) * g + cx] < 0;
    for (int dy = -2; ok && dy <= 2; ++dy)
      for (int dx = -2; ok && dx <= 2; ++dx) {
        const int p = grid[size_t((cy + dy + g) % g) * g + size_t((cx + dx + g) % g)];
        if (p >= 0) {
          const double ex = wrap(pts[size_t(p)].first - x), ey = wrap(pts[size_t(p)].second - y);
          ok = ex * ex + ey * ey >= r * r;
        }
      }
    if (!ok) continue;
    grid[size_t(cy) * g + cx] = int(pts.size());
    pts.push_back({x, y});
  }
  // One Beckmann normal per cell: slope = alpha sqrt(-ln u) (cos phi, sin phi) (Walter et al.
  // 2007 Eq. 28 in slope form).
  std::vector<std::array<float, 3>> normal(pts.size());
  for (auto &nm : normal) {
    const double m = alpha * std::sqrt(-std::log(1.0 - rng.Uniform())),
                 phi = 2 * kPi * rng.Uniform();
    const double x = -m * std::cos(phi), y = -m * std::sin(phi), len = std::sqrt(x * x + y * y + 1);
    nm = {float(x / len), float(y / len), float(1 / len)};
  }
  out->width = out->height = n;
  out->xyz.resize(size_t(n) * n * 3);
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      const double x = i + 0.5, y = j + 0.5;
      const int cx = std::min(g - 1, int(x / gc)), cy = std::min(g - 1, int(y / gc));
      int best = 0;
      double bd = 1e300;
      for (int dy = -3; dy <= 3; ++dy)
        for (int dx = -3; dx <= 3; ++dx) {
          const int p = grid[size_t((cy + dy + g) % g) * g + size_t((cx + dx + g) % g)];
          if (p < 0) continue;
          const double ex = wrap(pts[size_t(p)].first - x), ey = wrap(pts[size_t(p)].second - y);
          if (ex * ex + ey * ey < bd) bd = ex * ex + ey * ey, best = p;
        }
      std::copy(normal[size_t(best)].begin(), normal[size_t(best)].end(),
                out->xyz.begin() + ptrdiff_t((size_t(j) * n + i) * 3));
    }
}

void Scratches(uint32_t n, double rms_slope, Rng &rng, DecodedNormalMap *out) {
  std::vector<double> h(size_t(n) * n, 0.0);
  auto wrap = [&](double d) { return d - double(n) * std::round(d / double(n)); };
  // Grooves: a Gaussian cross-section of width w and depth d along a segment.
  const int scratches = int(n / 4);
  for (int s = 0; s < scratches; ++s) {
    const double x0 = rng.Uniform() * n, y0 = rng.Uniform() * n;
    const double ang = 2 * kPi * rng.Uniform(), len = (0.1 + 0.6 * rng.Uniform()) * n;
    const double w = 0.7 + 1.5 * rng.Uniform(), depth = 0.5 + rng.Uniform();
    const double dx = std::cos(ang), dy = std::sin(ang);
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) {
        const double ex = wrap(i + 0.5 - x0), ey = wrap(j + 0.5 - y0);
        const double along = ex * dx + ey * dy, across = -ex * dy + ey * dx;
        if (along < 0 || along > len || std::fabs(across) > 4 * w) continue;
        h[size_t(j) * n + i] -= depth * std::exp(-0.5 * across * across / (w * w));
      }
  }
  // Dents: round Gaussian pits.
  const int dents = int(n / 32) + 1;
  for (int s = 0; s < dents; ++s) {
    const double x0 = rng.Uniform() * n, y0 = rng.Uniform() * n;
    const double w = n / 64.0 * (1 + 2 * rng.Uniform()), depth = 2 * w * rng.Uniform();
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) {
        const double ex = wrap(i + 0.5 - x0), ey = wrap(j + 0.5 - y0), r2 = ex * ex + ey * ey;
        if (r2 < 16 * w * w) h[size_t(j) * n + i] -= depth * std::exp(-0.5 * r2 / (w * w));
      }
  }
  HeightsToNormals(n, h, rms_slope, out);
}

}  // namespace

bool Generate(const Options &o, DecodedNormalMap *out, std::string *error) {
  *out = DecodedNormalMap();
  if (o.size < 4 || o.size > 8192) {
    *error = "--size " + std::to_string(o.size) + ": expected 4 to 8192";
    return false;
  }
  const bool pow2 = (o.size & (o.size - 1)) == 0;
  Rng rng(o.seed);
  if (o.kind == "bumpy" || o.kind == "brushed") {
    if (!pow2) {
      *error = "--size " + std::to_string(o.size) + ": " + o.kind +
               " is made by FFT; expected a power of two";
      return false;
    }
    const double n = o.size;
    // Spectrum widths in cycles per map, so that features have a fixed size in texels
    // (correlation length ~ n / (2 pi b)): bumpy ~4 texels; brushed ~64 texels along u and
    // ~2 along v.
    const std::vector<double> h = o.kind == "bumpy"
                                      ? SpectrumHeights(o.size, n / 24.0, n / 24.0, rng)
                                      : SpectrumHeights(o.size, n / 400.0 + 0.5, n / 12.0, rng);
    HeightsToNormals(o.size, h, o.roughness, out);
    return true;
  }
  if (o.kind == "flakes") {
    Flakes(o.size, o.roughness, rng, out);
    return true;
  }
  if (o.kind == "scratches") {
    Scratches(o.size, o.roughness, rng, out);
    return true;
  }
  *error = "'" + o.kind + "' is not one of bumpy, flakes, brushed, scratches";
  return false;
}

}  // namespace glint::normal_map_gen
