// G-buffer EXR -> glint queries. Geometry in double, rounded to float once when written to the
// batch (as preview_scene.cpp does), so the differences of neighbouring uv lose no digits.
#include "client/preview/gbuffer.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

namespace glint::client {
namespace {

struct V3 {
  double x = 0.0, y = 0.0, z = 0.0;
};
V3 operator-(V3 a, V3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
V3 operator*(double s, V3 a) {
  return {s * a.x, s * a.y, s * a.z};
}
double Dot(V3 a, V3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
V3 Load3(const std::vector<float> &plane, size_t pixel) {
  const float *p = &plane[3 * pixel];
  return {p[0], p[1], p[2]};
}

// `v` as written when it is unit to float rounding, else normalised in double; nullopt when
// it has no direction.
std::optional<V3> UnitOrNormalised(V3 v) {
  const double len = std::sqrt(Dot(v, v));
  if (!(len > 0.0) || !std::isfinite(len)) return std::nullopt;
  if (std::abs(len - 1.0) <= kGBufferUnitSlack) return v;
  return (1.0 / len) * v;
}

// t made orthogonal to the unit n and unit; nullopt when (nearly) parallel to n.
std::optional<V3> OrthoUnit(V3 t, V3 n) {
  const double len = std::sqrt(Dot(t, t));
  if (!(len > 0.0) || !std::isfinite(len)) return std::nullopt;
  const double along = Dot(t, n) / len;
  // Already a unit vector orthogonal to n to float rounding: keep it bit for bit.
  if (std::abs(len - 1.0) <= kGBufferUnitSlack && std::abs(along) <= kGBufferUnitSlack) return t;
  if (std::abs(along) > 1.0 - 1e-6) return std::nullopt;  // parallel: no tangent direction
  const V3 o = t - Dot(t, n) * n;
  return (1.0 / std::sqrt(Dot(o, o))) * o;
}

// The channel names of `layer` with one of the suffix sets (upper or lower case), or {} if
// none is complete. `partial` gets the first channel found of an incomplete set.
std::vector<std::string> FindLayer(const ExrHeaderInfo &header, const std::string &layer,
                                   const std::vector<std::vector<std::string>> &suffix_sets,
                                   std::string *partial) {
  auto has = [&](const std::string &name) {
    for (const auto &c : header.channels) {
      if (c.name == name) return true;
    }
    return false;
  };
  for (const auto &set : suffix_sets) {
    for (bool lower : {false, true}) {
      std::vector<std::string> names;
      int found = 0;
      for (const std::string &s : set) {
        std::string suffix = s;
        if (lower) {
          for (char &c : suffix) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        }
        const std::string name = layer.empty() ? suffix : layer + "." + suffix;
        names.push_back(name);
        if (has(name)) {
          ++found;
          if (partial->empty()) *partial = name;
        }
      }
      if (found == static_cast<int>(set.size())) {
        partial->clear();
        return names;
      }
    }
  }
  return {};
}

std::string Join(const std::vector<std::string> &names, const char *sep = ",") {
  std::string out;
  for (const auto &n : names) {
    if (!out.empty()) out += sep;
    out += n;
  }
  return out;
}

std::string ChannelList(const ExrHeaderInfo &header) {
  std::vector<std::string> names;
  for (const auto &c : header.channels) names.push_back(c.name);
  return names.empty() ? "(no channels)" : Join(names, ", ");
}

const std::vector<std::vector<std::string>> kVectorSuffixes = {{"X", "Y", "Z"}, {"R", "G", "B"}};
const std::vector<std::vector<std::string>> kUvSuffixes = {{"U", "V"}, {"X", "Y"}, {"R", "G"}};

// Interleaves component planes into one plane of `planes.size()` components per pixel.
std::vector<float> Interleave(const std::vector<std::vector<float>> &planes, size_t first,
                              size_t count, size_t pixels) {
  std::vector<float> out(pixels * count);
  for (size_t p = 0; p < pixels; ++p) {
    for (size_t c = 0; c < count; ++c) out[p * count + c] = planes[first + c][p];
  }
  return out;
}

// Which neighbours a footprint difference uses along one axis.
enum class Stencil { kCentral, kMinus, kPlus, kNone };

}  // namespace

bool ParseLayerMapping(const std::string &text, GBufferLayers *layers, std::string *error) {
  std::map<std::string, std::string *> keys = {{"P", &layers->position},
                                               {"N", &layers->normal},
                                               {"T", &layers->tangent},
                                               {"uv", &layers->uv},
                                               {"V", &layers->view},
                                               {"A", &layers->alpha},
                                               {"footprint", &layers->footprint}};
  std::map<std::string, bool> seen;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    const std::string item = text.substr(start, end - start);
    const size_t eq = item.find('=');
    if (eq == std::string::npos) {
      *error = "'" + item + "' is not KEY=NAME";
      return false;
    }
    const std::string key = item.substr(0, eq);
    auto it = keys.find(key);
    if (it == keys.end()) {
      *error = "unknown key '" + key + "' (keys: P, N, T, uv, V, A, footprint)";
      return false;
    }
    if (seen[key]) {
      *error = "key '" + key + "' given twice";
      return false;
    }
    seen[key] = true;
    *it->second = item.substr(eq + 1);
    start = end + 1;
  }
  return true;
}

GBuffer ReadGBuffer(const std::string &path, const GBufferLayers &layers) {
  const ExrHeaderInfo header = ReadExrHeader(path);
  if (header.parts != 1) {
    throw std::runtime_error(path + ": a multi-part EXR (" + std::to_string(header.parts) +
                             " parts); glint render reads single-part files with all layers in "
                             "one part");
  }
  GBuffer g;
  g.source = path;
  std::vector<std::string> names;
  auto require = [&](const std::string &what, const std::string &layer,
                     const std::vector<std::vector<std::string>> &sets, bool required,
                     std::string *listed) -> bool {
    std::string partial;
    std::vector<std::string> found = FindLayer(header, layer, sets, &partial);
    if (found.empty()) {
      std::vector<std::string> options;
      for (const auto &set : sets) {
        std::vector<std::string> full;
        for (const auto &s : set) full.push_back(layer + "." + s);
        options.push_back(Join(full));
      }
      if (!partial.empty()) {
        throw std::runtime_error(path + ": layer '" + layer + "' (" + what +
                                 ") is incomplete: has " + partial + " but not all of " +
                                 Join(options, " or ") +
                                 "; channels in the file: " + ChannelList(header));
      }
      if (required) {
        throw std::runtime_error(
            path + ": no layer '" + layer + "' (" + what + "): expected " + Join(options, " or ") +
            " (rename with --channels); channels in the file: " + ChannelList(header));
      }
      return false;
    }
    *listed = Join(found);
    names.insert(names.end(), found.begin(), found.end());
    return true;
  };
  require("world position", layers.position, kVectorSuffixes, true, &g.position_channels);
  require("shading normal", layers.normal, kVectorSuffixes, true, &g.normal_channels);
  require("uv", layers.uv, kUvSuffixes, true, &g.uv_channels);
  const bool has_t =
      require("tangent", layers.tangent, kVectorSuffixes, false, &g.tangent_channels);
  const bool has_v = require("view vector", layers.view, kVectorSuffixes, false, &g.view_channels);
  bool has_fp = false;
  {
    const std::string prefix = layers.footprint.empty() ? "" : layers.footprint + ".";
    std::vector<std::string> fp = {prefix + "dudx", prefix + "dvdx", prefix + "dudy",
                                   prefix + "dvdy"};
    int found = 0;
    for (const auto &n : fp) {
      for (const auto &c : header.channels) found += c.name == n;
    }
    if (found != 0 && found != 4) {
      throw std::runtime_error(path + ": footprint channels are incomplete: expected all of " +
                               Join(fp) + "; channels in the file: " + ChannelList(header));
    }
    if (found == 4) {
      has_fp = true;
      g.footprint_channels = Join(fp);
      names.insert(names.end(), fp.begin(), fp.end());
    }
  }
  bool has_a = false;
  for (const auto &c : header.channels) has_a |= c.name == layers.alpha;
  if (has_a) {
    g.alpha_channel = layers.alpha;
    names.push_back(layers.alpha);
  }

  std::vector<std::vector<float>> planes = ReadExrChannels(path, names, &g.data_window);
  g.display_window = header.display_window;
  g.width = g.data_window.width();
  g.height = g.data_window.height();
  const size_t pixels = static_cast<size_t>(g.width) * static_cast<size_t>(g.height);
  size_t next = 0;
  g.position = Interleave(planes, next, 3, pixels), next += 3;
  g.normal = Interleave(planes, next, 3, pixels), next += 3;
  g.uv = Interleave(planes, next, 2, pixels), next += 2;
  if (has_t) g.tangent = Interleave(planes, next, 3, pixels), next += 3;
  if (has_v) g.view = Interleave(planes, next, 3, pixels), next += 3;
  if (has_fp) g.footprint = Interleave(planes, next, 4, pixels), next += 4;
  if (has_a) g.alpha = std::move(planes[next]);
  return g;
}

void WriteGBuffer(const std::string &path, const GBuffer &g) {
  const size_t pixels = static_cast<size_t>(g.width) * static_cast<size_t>(g.height);
  std::vector<std::vector<float>> store;
  std::vector<ExrPlane> planes;
  auto add = [&](const std::vector<float> &interleaved, const std::vector<std::string> &names) {
    if (interleaved.empty()) return;
    const size_t k = names.size();
    for (size_t c = 0; c < k; ++c) {
      std::vector<float> plane(pixels);
      for (size_t p = 0; p < pixels; ++p) plane[p] = interleaved[p * k + c];
      store.push_back(std::move(plane));
    }
  };
  std::vector<std::string> order;
  auto note = [&](const std::vector<float> &v, std::vector<std::string> names) {
    if (v.empty()) return;
    add(v, names);
    order.insert(order.end(), names.begin(), names.end());
  };
  note(g.position, {"P.X", "P.Y", "P.Z"});
  note(g.normal, {"N.X", "N.Y", "N.Z"});
  note(g.tangent, {"T.X", "T.Y", "T.Z"});
  note(g.uv, {"uv.U", "uv.V"});
  note(g.view, {"V.X", "V.Y", "V.Z"});
  note(g.footprint, {"dudx", "dvdx", "dudy", "dvdy"});
  note(g.alpha, {"A"});
  for (size_t i = 0; i < order.size(); ++i) planes.push_back({order[i], store[i].data()});
  WriteExrChannels(path, g.data_window, g.display_window, planes);
}

bool IsBackground(const GBuffer &g, size_t pixel) {
  if (!g.alpha.empty()) return g.alpha[pixel] == 0.0f;
  const float *n = &g.normal[3 * pixel];
  return n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f;
}

PreviewQueries GBufferQueries(const GBuffer &g,
                              const std::optional<std::array<double, 3>> &camera) {
  if (!camera && g.view.empty()) {
    throw std::runtime_error(g.source +
                             ": no view-vector layer; give the camera position (--camera X,Y,Z)");
  }
  const int w = g.width, h = g.height;
  const size_t pixels = static_cast<size_t>(w) * static_cast<size_t>(h);
  std::vector<char> covered(pixels);
  for (size_t p = 0; p < pixels; ++p) covered[p] = !IsBackground(g, p);

  auto fail = [&](const std::string &layer, size_t p, const std::string &what) {
    const int x = static_cast<int>(p % static_cast<size_t>(w)) + g.data_window.min_x;
    const int y = static_cast<int>(p / static_cast<size_t>(w)) + g.data_window.min_y;
    throw std::runtime_error(g.source + ": layer " + layer + ": pixel (" + std::to_string(x) +
                             ", " + std::to_string(y) + ") " + what);
  };
  auto check_finite = [&](const std::vector<float> &plane, size_t k, const std::string &layer,
                          size_t p) {
    for (size_t c = 0; c < k; ++c) {
      if (!std::isfinite(plane[p * k + c])) fail(layer, p, "is not finite");
    }
  };
  for (size_t p = 0; p < pixels; ++p) {
    if (!g.alpha.empty() && !std::isfinite(g.alpha[p])) fail(g.alpha_channel, p, "is not finite");
    if (!covered[p]) continue;
    check_finite(g.position, 3, g.position_channels, p);
    check_finite(g.normal, 3, g.normal_channels, p);
    check_finite(g.uv, 2, g.uv_channels, p);
    if (!g.tangent.empty()) check_finite(g.tangent, 3, g.tangent_channels, p);
    if (!g.view.empty()) check_finite(g.view, 3, g.view_channels, p);
    if (!g.footprint.empty()) check_finite(g.footprint, 4, g.footprint_channels, p);
  }

  // Which neighbours along +x (dx = 1) or +y (dx = 0) the differences use at pixel (x, y).
  auto stencil = [&](int x, int y, bool along_x) {
    const int mx = along_x ? x - 1 : x, my = along_x ? y : y - 1;
    const int px = along_x ? x + 1 : x, py = along_x ? y : y + 1;
    const bool minus = mx >= 0 && my >= 0 && covered[static_cast<size_t>(my) * w + mx];
    const bool plus = px < w && py < h && covered[static_cast<size_t>(py) * w + px];
    const size_t i = static_cast<size_t>(y) * w + x;
    const size_t m = minus ? static_cast<size_t>(my) * w + mx : i;
    const size_t q = plus ? static_cast<size_t>(py) * w + px : i;
    Stencil s = Stencil::kNone;
    if (minus && plus) {
      const double dmu = double{g.uv[2 * i]} - g.uv[2 * m],
                   dmv = double{g.uv[2 * i + 1]} - g.uv[2 * m + 1];
      const double dpu = double{g.uv[2 * q]} - g.uv[2 * i],
                   dpv = double{g.uv[2 * q + 1]} - g.uv[2 * i + 1];
      const double lm = std::hypot(dmu, dmv), lp = std::hypot(dpu, dpv);
      if (std::hypot(dpu - dmu, dpv - dmv) > std::max(lm, lp)) {
        s = lm <= lp ? Stencil::kMinus : Stencil::kPlus;
      } else {
        s = Stencil::kCentral;
      }
    } else if (minus) {
      s = Stencil::kMinus;
    } else if (plus) {
      s = Stencil::kPlus;
    }
    struct Pick {
      Stencil s;
      size_t m, i, q;
    };
    return Pick{s, m, i, q};
  };
  // d(plane)/d(axis) at the pixel for the chosen stencil, `k` components from `first`.
  auto derivative = [](const std::vector<float> &plane, size_t k, size_t c, Stencil s, size_t m,
                       size_t i, size_t q) -> double {
    switch (s) {
      case Stencil::kCentral:
        return 0.5 * (double{plane[q * k + c]} - plane[m * k + c]);
      case Stencil::kMinus:
        return double{plane[i * k + c]} - plane[m * k + c];
      case Stencil::kPlus:
        return double{plane[q * k + c]} - plane[i * k + c];
      case Stencil::kNone:
        break;
    }
    return 0.0;
  };

  PreviewQueries out;
  out.width = w;
  out.height = h;
  glint::v1::QueryBatch &b = out.queries;
  auto add3 = [](google::protobuf::RepeatedField<float> *f, V3 v) {
    f->Add(static_cast<float>(v.x));
    f->Add(static_cast<float>(v.y));
    f->Add(static_cast<float>(v.z));
  };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (!covered[i]) continue;
      const V3 pos = Load3(g.position, i);
      const std::optional<V3> n = UnitOrNormalised(Load3(g.normal, i));
      if (!n) fail(g.normal_channels, i, "has a normal of zero length but alpha > 0");

      double fp[4];  // dudx, dvdx, dudy, dvdy
      V3 dpdx, dpdy;
      const auto sx = stencil(x, y, true);
      const auto sy = stencil(x, y, false);
      if (!g.footprint.empty()) {
        for (int c = 0; c < 4; ++c) fp[c] = g.footprint[4 * i + c];
      } else {
        fp[0] = derivative(g.uv, 2, 0, sx.s, sx.m, sx.i, sx.q);
        fp[1] = derivative(g.uv, 2, 1, sx.s, sx.m, sx.i, sx.q);
        fp[2] = derivative(g.uv, 2, 0, sy.s, sy.m, sy.i, sy.q);
        fp[3] = derivative(g.uv, 2, 1, sy.s, sy.m, sy.i, sy.q);
      }

      std::optional<V3> t;
      if (!g.tangent.empty()) t = OrthoUnit(Load3(g.tangent, i), *n);
      if (!t) {
        // dp/du from [dP/dx dP/dy] = [dp/du dp/dv] J (see the header comment).
        for (int c = 0; c < 3; ++c) {
          (&dpdx.x)[c] = derivative(g.position, 3, static_cast<size_t>(c), sx.s, sx.m, sx.i, sx.q);
          (&dpdy.x)[c] = derivative(g.position, 3, static_cast<size_t>(c), sy.s, sy.m, sy.i, sy.q);
        }
        const double det = fp[0] * fp[3] - fp[2] * fp[1];
        if (det != 0.0 && std::isfinite(det)) {
          t = OrthoUnit((1.0 / det) * (fp[3] * dpdx - fp[1] * dpdy), *n);
        }
      }
      if (!t) {
        // No usable uv parameterisation here: any tangent; the least n-aligned world axis.
        const V3 axis = std::abs(n->x) < 0.9 ? V3{1, 0, 0} : V3{0, 1, 0};
        t = OrthoUnit(axis, *n);
      }

      V3 wo;
      if (camera) {
        const V3 to_eye = V3{(*camera)[0], (*camera)[1], (*camera)[2]} - pos;
        const double len = std::sqrt(Dot(to_eye, to_eye));
        if (!(len > 0.0)) fail(g.position_channels, i, "coincides with the camera position");
        wo = (1.0 / len) * to_eye;
      } else {
        const std::optional<V3> v = UnitOrNormalised(Load3(g.view, i));
        if (!v) fail(g.view_channels, i, "has a view vector of zero length");
        wo = *v;
      }

      b.add_uv(g.uv[2 * i]);
      b.add_uv(g.uv[2 * i + 1]);
      for (double f : fp) b.add_footprint(static_cast<float>(f));
      add3(b.mutable_wo(), wo);
      add3(b.mutable_position(), pos);
      add3(b.mutable_normal(), *n);
      add3(b.mutable_tangent(), *t);
      out.pixel_of_query.push_back(static_cast<int32_t>(i));
    }
  }
  b.set_count(static_cast<uint32_t>(out.pixel_of_query.size()));
  return out;
}

GBuffer PreviewGBuffer(const PreviewQueries &scene) {
  GBuffer g;
  g.width = scene.width;
  g.height = scene.height;
  g.data_window = {0, 0, scene.width - 1, scene.height - 1};
  g.display_window = g.data_window;
  const size_t pixels = static_cast<size_t>(g.width) * static_cast<size_t>(g.height);
  g.position.assign(3 * pixels, 0.0f);
  g.normal.assign(3 * pixels, 0.0f);
  g.tangent.assign(3 * pixels, 0.0f);
  g.view.assign(3 * pixels, 0.0f);
  g.uv.assign(2 * pixels, 0.0f);
  g.footprint.assign(4 * pixels, 0.0f);
  g.alpha.assign(pixels, 0.0f);
  const glint::v1::QueryBatch &q = scene.queries;
  for (size_t k = 0; k < scene.pixel_of_query.size(); ++k) {
    const auto p = static_cast<size_t>(scene.pixel_of_query[k]);
    for (size_t c = 0; c < 3; ++c) {
      g.position[3 * p + c] = q.position(static_cast<int>(3 * k + c));
      g.normal[3 * p + c] = q.normal(static_cast<int>(3 * k + c));
      g.tangent[3 * p + c] = q.tangent(static_cast<int>(3 * k + c));
      g.view[3 * p + c] = q.wo(static_cast<int>(3 * k + c));
    }
    for (size_t c = 0; c < 2; ++c) g.uv[2 * p + c] = q.uv(static_cast<int>(2 * k + c));
    for (size_t c = 0; c < 4; ++c)
      g.footprint[4 * p + c] = q.footprint(static_cast<int>(4 * k + c));
    g.alpha[p] = 1.0f;
  }
  return g;
}

}  // namespace glint::client
