// Configurations and measurements behind the AUTO area method's error table
// (kernels/area/area_auto.h, models/smooth/area_auto_table.h): random polygon lights and views
// drawn from a seeded generator (the fit uses one seed, validation and tests others, so they are
// held out), the truth of each query by an independent adaptive integration in double
// (tests/support/plane_adaptive.h), and the relative error every method makes on it.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "glint/v1/glint.pb.h"

namespace glint::area_auto {

using V3 = std::array<double, 3>;

// One polygon light (local frame, shading point at the origin, counter-clockwise seen from it,
// one-sided, radiance 1) on a grey Schlick f0 = 1 material (an albedo <= 1, so a query's value
// is at most ~1), seen along several views: one EvaluateRequest without a frame.
struct Config {
  int ndf = 1;  // GLINT_NDF_*
  double alpha = 0.1;
  std::vector<V3> polygon;
  std::vector<V3> wo;  // unit, local
};

// The views' range: theta_o uniform in [0, kGrazingFromDeg] for three views in four, and for
// every fourth (views 3, 7, ...) the grazing band up to the horizon, cos theta_o log-uniform in
// [kGrazingMinCos, kGrazingMaxCos = cos kGrazingFromDeg] (89.994 .. 85 deg). The band is the
// error table's last view bin (kernels/area/area_auto_features.h, edge 85 deg).
constexpr double kGrazingFromDeg = 85.0;
constexpr double kGrazingMaxCos = 0.08715574274765817;  // cos 85 deg
constexpr double kGrazingMinCos = 1e-4;

// `count` configurations of `views` queries each for one NDF: alpha log-uniform in [0.01, 1];
// a convex polygon of 3 to 6 vertices on an ellipse (aspect 0.3-1, random spin), distance
// log-uniform in [0.02, 30] (solid angles ~1e-3 to ~6 sr), centre elevation uniform in
// [-10, 90] deg, plane tilted by up to 45 deg; views as above, with a uniform azimuth.
// Deterministic in (seed, count, views, ndf).
std::vector<Config> MakeConfigs(uint64_t seed, int count, int views, int ndf);

// The request of a configuration (fp32 unless told) for an area method.
glint::v1::EvaluateRequest MakeRequest(const Config &c, glint::v1::AreaMethod method,
                                       uint32_t samples, uint64_t seed, float budget = 0.0f,
                                       bool fp64 = false);

// Truth per view: int_P f cos_i dwi (red channel) by PlaneAdaptive in double, rel. tol. 1e-5 (a
// thousandth of the smallest budget validated).
std::vector<double> Truth(const Config &c);

// The error measure of AUTO's budget: |x - truth| / max(truth, kFloor). kFloor = 1e-3 of the
// light's radiance (radiance 1 here): a light whose contribution is below 1/1000 of its
// radiance is held to an absolute error of budget x 1e-3 x radiance.
constexpr double kFloor = 1e-3;
double RelativeError(double x, double truth);

// The error-table cell of each view (area_auto_cell in float, as the fp32 kernels bin), -1 when
// the light is below the horizon.
std::vector<int> Cells(const Config &c);

// The method AUTO picks for each view under `budget` (area_auto_choose in float, as the fp32
// kernels): GLINT_AREA_* and the sample count.
struct Choice {
  int method = 1;
  int samples = 0;
  float predicted = 0;  // the table's error bound; > budget when nothing was predicted to meet it
};
std::vector<Choice> Choices(const Config &c, float budget);

// Runs a request on the host path (fp32 unless the request says FP64): red channel per query.
std::vector<double> HostRed(const glint::v1::EvaluateRequest &r);

}  // namespace glint::area_auto
