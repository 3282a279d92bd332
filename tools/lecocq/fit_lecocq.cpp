// glint_fit_lecocq: fits the empirical constants of kernels/area/area_lecocq.h (Lecocq et al. 2015,
// "Accurate Analytic Approximations for Real-Time Specular Area Lighting", SIGGRAPH Talks) and
// rewrites the generated block of that header. Derivation and fit: tools/lecocq/README.md.
//
//   glint_fit_lecocq [--header kernels/area/area_lecocq.h]   (without --header: print the block
//   only)
//
// Three fits, all deterministic (fixed grids, golden-section searches, linear least squares):
//  1. g_L(N, p): width factor of the Lorentzian that replaces the edge integrand I(t) of the
//     reformulated Arvo contour integral (README "Edge integrand");
//  2. g_P(N, p): the same for the Lorentzian + Pearson VII mixture (tail point at t = pi/2);
//  3. kappa(alpha) = (N + 1) alpha^2: the Phong-lobe exponent N that best matches the projected
//     NDF D(h) (h.z) of GGX and Beckmann (README "Phong exponent").
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;

// Edge integrand I(t) = (1 - x^(N+1)) / (1 - x^2), x = c cos t, c^2 = 1 - s^2 (README Eq. E3).
double EdgeI(double N, double s, double t) {
  double st = std::sin(t);
  double omx2 = s * s + (1 - s * s) * st * st;  // 1 - x^2 without cancellation
  if (omx2 < 1e-300) return (N + 1) / 2;
  return -std::expm1((N + 1) / 2 * std::log1p(-omx2)) / omx2;
}

// int_0^t dt' / (1 + q sin^2 t')  (Lorentzian in sin t, README Eq. L2).
double F1(double q, double t) {
  double r = std::sqrt(1 + q);
  return std::atan2(r * std::sin(t), std::cos(t)) / r;
}
// int_0^t dt' / (1 + q sin^2 t')^2  (Pearson VII, m = 2, README Eq. P2).
double F2(double q, double t) {
  double st = std::sin(t), ct = std::cos(t);
  return (2 + q) / (2 * (1 + q)) * F1(q, t) + q * st * ct / (2 * (1 + q) * (1 + q * st * st));
}

const double kGx[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                       -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                       0.7966664774136267,  0.9602898564975363};
const double kGw[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                       0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                       0.2223810344533745, 0.1012285362903763};

// Cumulative integral of I on a grid that resolves the peak (width ~ min(s, 1/sqrt(N+1))).
struct Curve {
  std::vector<double> t, F;
};
Curve Exact(double N, double s) {
  Curve c;
  double w0 = std::fmin(1 / std::sqrt(N + 1), std::fmax(s, 1e-9));
  std::vector<double> g{0};
  for (int k = -60;; ++k) {
    double t = w0 * std::pow(10.0, k / 25.0);
    if (t >= kPi / 2) break;
    g.push_back(t);
  }
  g.push_back(kPi / 2);
  double acc = 0;
  c.t.push_back(0);
  c.F.push_back(0);
  for (size_t i = 1; i < g.size(); ++i) {
    double a = g[i - 1], b = g[i], sum = 0;
    for (int k = 0; k < 8; ++k) sum += kGw[k] * EdgeI(N, s, a + (b - a) * (kGx[k] + 1) / 2);
    acc += sum * (b - a) / 2;
    c.t.push_back(b);
    c.F.push_back(acc);
  }
  return c;
}

// sup_t |model(0..t) - exact(0..t)| / exact(0..pi/2) for the two peak models with width factor g.
double ErrLorentz(const Curve &c, double N, double s, double g) {
  double A = EdgeI(N, s, 0), q = (A - 1) / (g * g), m = 0;
  for (size_t i = 0; i < c.t.size(); ++i) m = std::fmax(m, std::fabs(A * F1(q, c.t[i]) - c.F[i]));
  return m / c.F.back();
}
double ErrPearson(const Curve &c, double N, double s, double g) {
  double A = EdgeI(N, s, 0), q = (A - 1) / (g * g);
  double k = (2 + q - g * g) / A;  // I(pi/2) = 1 (README Eq. P3)
  double m = 0;
  for (size_t i = 0; i < c.t.size(); ++i) {
    double f = A * (k * F1(q, c.t[i]) + (1 - k) * F2(q, c.t[i]));
    m = std::fmax(m, std::fabs(f - c.F[i]));
  }
  return m / c.F.back();
}

double GoldenMin(const std::function<double(double)> &f, double lo, double hi) {
  for (int it = 0; it < 80; ++it) {
    double a = lo + (hi - lo) * 0.381966, b = lo + (hi - lo) * 0.618034;
    if (f(a) < f(b))
      hi = b;
    else
      lo = a;
  }
  return (lo + hi) / 2;
}

// Linear least squares by normal equations (small, well-conditioned bases).
std::vector<double> LeastSquares(const std::vector<std::vector<double>> &rows,
                                 const std::vector<double> &y) {
  size_t n = rows[0].size();
  std::vector<std::vector<double>> a(n, std::vector<double>(n + 1, 0));
  for (size_t r = 0; r < rows.size(); ++r)
    for (size_t i = 0; i < n; ++i) {
      for (size_t j = 0; j < n; ++j) a[i][j] += rows[r][i] * rows[r][j];
      a[i][n] += rows[r][i] * y[r];
    }
  for (size_t i = 0; i < n; ++i) {
    size_t p = i;
    for (size_t k = i + 1; k < n; ++k)
      if (std::fabs(a[k][i]) > std::fabs(a[p][i])) p = k;
    std::swap(a[i], a[p]);
    for (size_t k = 0; k < n; ++k) {
      if (k == i) continue;
      double f = a[k][i] / a[i][i];
      for (size_t j = i; j <= n; ++j) a[k][j] -= f * a[i][j];
    }
  }
  std::vector<double> x(n);
  for (size_t i = 0; i < n; ++i) x[i] = a[i][n] / a[i][i];
  return x;
}

// Width-factor basis: g = 1 + p (c0 + c1 p + c2 p^2 + c3 v + c4 p v + c5 v^2), v = 1/sqrt(N+1).
std::vector<double> WidthBasis(double N, double p) {
  double v = 1 / std::sqrt(N + 1);
  return {p, p * p, p * p * p, p * v, p * p * v, p * v * v};
}
double WidthEval(const std::vector<double> &c, double N, double p) {
  std::vector<double> b = WidthBasis(N, p);
  double g = 1;
  for (size_t i = 0; i < c.size(); ++i) g += c[i] * b[i];
  return g;
}

struct WidthFit {
  std::vector<double> coef;
  double worst_opt = 0, worst_fit = 0, mean_fit = 0;
};

// Fits g over N in [n_min, 1e7] (log grid) and p = c^(N+1) in (0, 1].
WidthFit FitWidth(bool pearson, double n_min, double g_lo, double g_hi) {
  std::vector<std::vector<double>> rows;
  std::vector<double> ys, Ns, ps;
  std::vector<Curve> curves;
  std::vector<double> opt_err;
  for (int i = 0; i <= 28; ++i) {
    double N = n_min * std::pow(1e7 / n_min, i / 28.0);
    for (double p : {0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 1.0}) {
      double s = std::sqrt(std::fmax(0.0, -std::expm1(2 / (N + 1) * std::log(p))));
      Curve c = Exact(N, s);
      auto err = [&](double g) {
        return pearson ? ErrPearson(c, N, s, g) : ErrLorentz(c, N, s, g);
      };
      double g = GoldenMin(err, g_lo, g_hi);
      rows.push_back(WidthBasis(N, p));
      ys.push_back(g - 1);
      Ns.push_back(N);
      ps.push_back(p);
      opt_err.push_back(err(g));
      curves.push_back(c);
    }
  }
  WidthFit f;
  f.coef = LeastSquares(rows, ys);
  for (size_t i = 0; i < rows.size(); ++i) {
    double N = Ns[i], p = ps[i];
    double s = std::sqrt(std::fmax(0.0, -std::expm1(2 / (N + 1) * std::log(p))));
    double g = WidthEval(f.coef, N, p);
    double e = pearson ? ErrPearson(curves[i], N, s, g) : ErrLorentz(curves[i], N, s, g);
    f.worst_opt = std::fmax(f.worst_opt, opt_err[i]);
    f.worst_fit = std::fmax(f.worst_fit, e);
    f.mean_fit += e / double(rows.size());
  }
  return f;
}

// Normalised cap CDFs of the projected NDF D(h) (h.z) dh: fraction within theta_h < beta.
double CdfNdf(bool beckmann, double alpha, double beta) {
  double t2 = std::tan(beta) * std::tan(beta) / (alpha * alpha);
  return beckmann ? -std::expm1(-t2) : t2 / (1 + t2);
}
// Phong lobe (N + 1)/(2 pi) cos^N: 1 - cos^(N+1) beta.
double CdfPhong(double N, double beta) {
  return -std::expm1((N + 1) * std::log(std::cos(beta)));
}
// Kolmogorov distance between the two cap CDFs over beta in (0, pi/2).
double Ks(bool beckmann, double alpha, double N) {
  double m = 0;
  for (int i = 1; i < 400; ++i) {
    // beta on a grid fine near the lobe: tan(beta) = alpha * u, u log-spaced.
    double beta = std::atan(alpha * std::pow(10.0, -3 + 6.0 * i / 400));
    m = std::fmax(m, std::fabs(CdfNdf(beckmann, alpha, beta) - CdfPhong(N, beta)));
  }
  return m;
}

struct PhongFit {
  std::vector<double> coef;  // kappa = sum c_i alpha^i
  double worst_ks = 0, worst_kappa_rel = 0;
};
PhongFit FitPhong(bool beckmann) {
  std::vector<std::vector<double>> rows;
  std::vector<double> ys;
  for (int i = 0; i <= 60; ++i) {
    double alpha = 1e-3 * std::pow(1e3, i / 60.0);
    double lk =
        GoldenMin([&](double l) { return Ks(beckmann, alpha, std::exp(l) / (alpha * alpha) - 1); },
                  std::log(0.3), std::log(4.0));
    rows.push_back({1, alpha, alpha * alpha, alpha * alpha * alpha});
    ys.push_back(std::exp(lk));
  }
  PhongFit f;
  f.coef = LeastSquares(rows, ys);
  for (size_t i = 0; i < rows.size(); ++i) {
    double alpha = rows[i][1], kappa = 0;
    for (size_t j = 0; j < 4; ++j) kappa += f.coef[j] * rows[i][j];
    f.worst_kappa_rel = std::fmax(f.worst_kappa_rel, std::fabs(kappa / ys[i] - 1));
    f.worst_ks = std::fmax(f.worst_ks, Ks(beckmann, alpha, kappa / (alpha * alpha) - 1));
  }
  return f;
}

std::string Num(double x) {
  char b[64];
  std::snprintf(b, sizeof b, "GLINT_R(%.9g)", x);
  return b;
}

std::string Block(const WidthFit &gl, const WidthFit &gp, const PhongFit &ggx,
                  const PhongFit &bkm) {
  std::ostringstream o;
  auto width = [&](const char *name, const WidthFit &f) {
    o << "GLINT_FN real " << name
      << "(real N, real p) {\n  real v = GLINT_R(1.0) / sqrt(N + GLINT_R(1.0));\n"
      << "  return GLINT_R(1.0) + p * (" << Num(f.coef[0]) << " + p * (" << Num(f.coef[1])
      << " + p * " << Num(f.coef[2]) << ") + v * (" << Num(f.coef[3]) << " + " << Num(f.coef[4])
      << " * p + " << Num(f.coef[5]) << " * v));\n}\n";
  };
  auto kappa = [&](const char *name, const PhongFit &f) {
    o << "GLINT_FN real " << name << "(real a) {\n  return " << Num(f.coef[0]) << " + a * ("
      << Num(f.coef[1]) << " + a * (" << Num(f.coef[2]) << " + a * " << Num(f.coef[3])
      << "));\n}\n";
  };
  o << "/* Generated by tools/lecocq/fit_lecocq.cpp (glint_fit_lecocq --header "
       "kernels/area/area_lecocq.h). Do not edit.\n"
    << " * g_L: worst sup-error of the edge integral " << gl.worst_fit << " (mean " << gl.mean_fit
    << ", best possible " << gl.worst_opt << ")\n"
    << " * g_P: worst " << gp.worst_fit << " (mean " << gp.mean_fit << ", best possible "
    << gp.worst_opt << "), N >= 4\n"
    << " * kappa GGX: worst KS distance " << ggx.worst_ks << ", Beckmann " << bkm.worst_ks
    << " */\n";
  width("lecocq_width_lorentz", gl);
  width("lecocq_width_pearson", gp);
  kappa("lecocq_kappa_ggx", ggx);
  kappa("lecocq_kappa_beckmann", bkm);
  return o.str();
}

}  // namespace

int main(int argc, char **argv) {
  std::string header;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--header" && i + 1 < argc) {
      header = argv[++i];
    } else {
      std::fprintf(stderr, "usage: glint_fit_lecocq [--header kernels/area/area_lecocq.h]\n");
      return 2;
    }
  }
  WidthFit gl = FitWidth(false, 1.05, 0.5, 3.0);
  WidthFit gp = FitWidth(true, 4.0, 1.0, 3.0);
  PhongFit ggx = FitPhong(false), bkm = FitPhong(true);
  std::string block = Block(gl, gp, ggx, bkm);
  std::fputs(block.c_str(), stdout);
  if (header.empty()) return 0;
  std::ifstream in(header);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  const std::string begin = "/* BEGIN GENERATED (glint_fit_lecocq) */\n";
  const std::string end = "/* END GENERATED (glint_fit_lecocq) */";
  size_t b = text.find(begin), e = text.find(end);
  if (!in || b == std::string::npos || e == std::string::npos || e < b) {
    std::fprintf(stderr, "error: %s has no generated block markers\n", header.c_str());
    return 1;
  }
  text = text.substr(0, b + begin.size()) + block + text.substr(e);
  std::ofstream out(header);
  out << text;
  std::fprintf(stderr, "updated %s\n", header.c_str());
  return out ? 0 : 1;
}
