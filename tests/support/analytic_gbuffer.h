// An analytic G-buffer for the tests of glint render (tests/preview/gbuffer_test.cpp,
// tests/client/render_e2e_test.cpp), built independently of client/preview: the documented
// preview cameras (preview_scene.h), a geometric ray / sphere and ray / plane intersection,
// the documented uv maps, written with OpenEXR's own API; and the documented footprint rule
// (gbuffer.h) evaluated on it.
#pragma once

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <half.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "client/preview/preview_scene.h"

namespace glint::test {

using glint::client::kPlaneCamera;
using glint::client::kPlaneHalfSize;
using glint::client::kPlaneUvScale;
using glint::client::kSphereCamera;
using glint::client::kSphereUScale;
using glint::client::kSphereVScale;
using glint::client::PreviewCamera;
using glint::client::PreviewCameraFor;
using glint::client::PreviewShape;

inline constexpr double kPi = std::numbers::pi;

struct V3 {
  double x, y, z;
};
inline V3 Add(V3 a, V3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline V3 Sub(V3 a, V3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline V3 Mul(double s, V3 a) {
  return {s * a.x, s * a.y, s * a.z};
}
inline double Dot(V3 a, V3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline V3 Unit(V3 a) {
  return Mul(1.0 / std::sqrt(Dot(a, a)), a);
}
inline V3 Cross(V3 a, V3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// The documented pinhole camera (preview_scene.h).
struct RefCamera {
  V3 eye, forward, right, up;
  double tan_half_v, aspect;
  int width, height;
  RefCamera(const PreviewCamera &c, int w, int h) : width(w), height(h) {
    eye = {c.eye[0], c.eye[1], c.eye[2]};
    forward = Unit(Sub({c.look_at[0], c.look_at[1], c.look_at[2]}, eye));
    right = Unit(Cross(forward, {c.up[0], c.up[1], c.up[2]}));
    up = Cross(right, forward);
    tan_half_v = std::tan(c.vertical_fov_deg * kPi / 360.0);
    aspect = static_cast<double>(w) / h;
  }
  V3 Ray(double px, double py) const {
    const double sx = (px / width - 0.5) * 2.0 * tan_half_v * aspect;
    const double sy = (0.5 - py / height) * 2.0 * tan_half_v;
    return Unit(Add(forward, Add(Mul(sx, right), Mul(sy, up))));
  }
};

struct Hit {
  V3 p, n, t;
  double u, v;
};

// Geometric ray / unit-sphere intersection: closest approach, then back along the ray.
inline std::optional<Hit> SphereHit(const RefCamera &cam, double px, double py) {
  const V3 d = cam.Ray(px, py);
  const double tc = -Dot(cam.eye, d);
  const V3 c = Add(cam.eye, Mul(tc, d));
  const double h2 = 1.0 - Dot(c, c);
  if (h2 < 0.0) return std::nullopt;
  const V3 p = Unit(Add(cam.eye, Mul(tc - std::sqrt(h2), d)));
  const double phi = std::atan2(p.x, -p.y);
  const double theta = std::atan2(std::hypot(p.x, p.y), p.z);
  return Hit{p,
             p,
             {std::cos(phi), std::sin(phi), 0.0},
             (phi / (2.0 * kPi) + 0.5) * kSphereUScale,
             (1.0 - theta / kPi) * kSphereVScale};
}

inline std::optional<Hit> PlaneHit(const RefCamera &cam, double px, double py) {
  const V3 d = cam.Ray(px, py);
  if (!(d.z < 0.0)) return std::nullopt;
  const V3 p = Add(cam.eye, Mul(-cam.eye.z / d.z, d));
  if (std::abs(p.x) > kPlaneHalfSize || std::abs(p.y) > kPlaneHalfSize) return std::nullopt;
  return Hit{p, {0, 0, 1}, {1, 0, 0}, p.x * kPlaneUvScale, p.y * kPlaneUvScale};
}

// The analytic G-buffer as float planes, plus the double uv (for truncation bounds).
struct Analytic {
  int w = 0, h = 0;
  std::vector<char> covered;
  std::vector<float> P, N, T, uv;        // interleaved 3, 3, 3, 2
  std::vector<double> u_exact, v_exact;  // at pixel centres, NaN off the surface
};

// The plane's position is written as uv / kPlaneUvScale (exact in float: a power of two), so
// that P is linear in uv to the last bit and the tangent derived from P and uv is exact.
inline Analytic BuildAnalytic(PreviewShape shape, int w, int h) {
  const RefCamera cam(PreviewCameraFor(shape), w, h);
  Analytic a;
  a.w = w;
  a.h = h;
  const size_t n = static_cast<size_t>(w) * h;
  a.covered.assign(n, 0);
  a.P.assign(3 * n, 0.0f);
  a.N.assign(3 * n, 0.0f);
  a.T.assign(3 * n, 0.0f);
  a.uv.assign(2 * n, 0.0f);
  a.u_exact.assign(n, std::numeric_limits<double>::quiet_NaN());
  a.v_exact = a.u_exact;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const auto hit = shape == PreviewShape::kSphere ? SphereHit(cam, x + 0.5, y + 0.5)
                                                      : PlaneHit(cam, x + 0.5, y + 0.5);
      if (!hit) continue;
      const size_t i = static_cast<size_t>(y) * w + x;
      a.covered[i] = 1;
      a.uv[2 * i] = static_cast<float>(hit->u);
      a.uv[2 * i + 1] = static_cast<float>(hit->v);
      a.u_exact[i] = hit->u;
      a.v_exact[i] = hit->v;
      const V3 p = shape == PreviewShape::kSphere
                       ? hit->p
                       : V3{a.uv[2 * i] / kPlaneUvScale, a.uv[2 * i + 1] / kPlaneUvScale, 0.0};
      const double pv[3] = {p.x, p.y, p.z}, nv[3] = {hit->n.x, hit->n.y, hit->n.z},
                   tv[3] = {hit->t.x, hit->t.y, hit->t.z};
      for (int c = 0; c < 3; ++c) {
        a.P[3 * i + c] = static_cast<float>(pv[c]);
        a.N[3 * i + c] = static_cast<float>(nv[c]);
        a.T[3 * i + c] = static_cast<float>(tv[c]);
      }
    }
  }
  return a;
}

// Writes interleaved planes under the given channel names with OpenEXR's own API.
struct Layer {
  std::vector<std::string> names;
  const std::vector<float> *data;
  Imf::PixelType type = Imf::FLOAT;
  int sampling = 1;
};
inline void WriteExr(const std::string &path, int w, int h, const std::vector<Layer> &layers) {
  Imf::Header header(w, h);
  Imf::FrameBuffer fb;
  std::vector<std::vector<float>> planes;
  std::vector<std::vector<Imath::half>> halves;
  planes.reserve(32);
  halves.reserve(32);
  for (const Layer &l : layers) {
    const size_t k = l.names.size();
    for (size_t c = 0; c < k; ++c) {
      std::vector<float> plane(static_cast<size_t>(w) * h);
      for (size_t p = 0; p < plane.size(); ++p) plane[p] = (*l.data)[p * k + c];
      header.channels().insert(l.names[c], Imf::Channel(l.type, l.sampling, l.sampling));
      if (l.type == Imf::HALF) {
        halves.emplace_back(plane.begin(), plane.end());
        fb.insert(l.names[c],
                  Imf::Slice(Imf::HALF, reinterpret_cast<char *>(halves.back().data()),
                             sizeof(Imath::half), sizeof(Imath::half) * w, l.sampling, l.sampling));
      } else {
        planes.push_back(std::move(plane));
        fb.insert(l.names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char *>(planes.back().data()),
                                         sizeof(float), sizeof(float) * w, l.sampling, l.sampling));
      }
    }
  }
  Imf::OutputFile file(path.c_str(), header);
  file.setFrameBuffer(fb);
  file.writePixels(h);
}

// The documented footprint rule along one axis, from the float uv, in double.
inline void ExpectedDerivative(const Analytic &a, int x, int y, bool along_x, double out[2]) {
  const int mx = along_x ? x - 1 : x, my = along_x ? y : y - 1;
  const int qx = along_x ? x + 1 : x, qy = along_x ? y : y + 1;
  auto cov = [&](int xx, int yy) {
    return xx >= 0 && yy >= 0 && xx < a.w && yy < a.h &&
           a.covered[static_cast<size_t>(yy) * a.w + xx];
  };
  auto uv = [&](int xx, int yy, int c) -> double {
    return a.uv[2 * (static_cast<size_t>(yy) * a.w + xx) + c];
  };
  const bool m = cov(mx, my), q = cov(qx, qy);
  for (int c = 0; c < 2; ++c) out[c] = 0.0;
  if (m && q) {
    const double dm[2] = {uv(x, y, 0) - uv(mx, my, 0), uv(x, y, 1) - uv(mx, my, 1)};
    const double dq[2] = {uv(qx, qy, 0) - uv(x, y, 0), uv(qx, qy, 1) - uv(x, y, 1)};
    const double lm = std::hypot(dm[0], dm[1]), lq = std::hypot(dq[0], dq[1]);
    if (std::hypot(dq[0] - dm[0], dq[1] - dm[1]) > std::max(lm, lq)) {
      for (int c = 0; c < 2; ++c) out[c] = lm <= lq ? dm[c] : dq[c];
    } else {
      for (int c = 0; c < 2; ++c) out[c] = 0.5 * (uv(qx, qy, c) - uv(mx, my, c));
    }
  } else if (m) {
    for (int c = 0; c < 2; ++c) out[c] = uv(x, y, c) - uv(mx, my, c);
  } else if (q) {
    for (int c = 0; c < 2; ++c) out[c] = uv(qx, qy, c) - uv(x, y, c);
  }
}

}  // namespace glint::test
