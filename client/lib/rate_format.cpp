#include "client/lib/rate_format.h"

#include <cmath>
#include <cstdio>

namespace glint::client {

std::string FormatRate(double count, double seconds) {
  if (!(seconds > 0.0) || !std::isfinite(seconds) || !std::isfinite(count)) return "-";
  double rate = count / seconds;
  static const char *const kPrefix[] = {"", " k", " M", " G", " T"};
  int p = 0;
  // Move up a prefix while three significant digits would need a fourth before the point
  // (999.7 prints as "1 k", not "1e+03").
  while (p < 4 && std::fabs(rate) >= 999.5) {
    rate /= 1000.0;
    ++p;
  }
  char text[32];
  std::snprintf(text, sizeof text, "%.3g%s", rate, kPrefix[p]);
  return text;
}

}  // namespace glint::client
