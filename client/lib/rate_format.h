// A throughput for people to read ("glint eval: 3 queries in 2.100 s (1.43 queries/s)"): three
// significant digits with an SI prefix, so a small or slow batch (one query behind a cold kernel
// compile) is not printed as "0 queries/s" and a large one not as an 11-digit integer.
#pragma once

#include <cstdint>
#include <string>

namespace glint::client {

// `count` per `seconds`: "0.333", "12.5", "4.56 k", "3.46 M", "1.2 G"; "-" when seconds is not
// a positive finite number (nothing was timed).
std::string FormatRate(double count, double seconds);

}  // namespace glint::client
