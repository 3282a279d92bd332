#!/bin/sh
# Compiles models/binomial/binomial_lanes.cl of the source tree $1 (default .) with the options of
# a BINOMIAL fp32 lights request (4 blocks of 16 lanes, as server/device_engine.cpp passes them to
# PoCL) by clang (clang-15, clang-14 or clang; $CLANG overrides) for CPUs with and without AVX-512
# and for spir64 (LLVM IR only), and prints per target and light set OK / FAIL and how many
# AVX-512 compress instructions (x86 assembly) or intrinsics (IR) the kernel holds. Fails unless
# every target builds, skylake-avx512 holds the regrouped draws' compresses and no other target
# holds any (GLINT_BINOMIAL_REGROUP: the plain block loop elsewhere; models/binomial/README.md
# "Quad throughput (session 19)"). This machine's PoCL only builds for its own CPU, so this is how
# the fallback for other devices is tested. ctest BinomialLanesKernelBuildsForEveryTarget; exit 77
# (skipped) without a clang.
src=${1:-.}
CLANG=${CLANG:-$(command -v clang-15 || command -v clang-14 || command -v clang)}
if [ -z "$CLANG" ]; then
  echo "no clang: skipped"
  exit 77
fi
out=$(mktemp -d)
status=0
for t in "x86_64-unknown-linux-gnu -march=x86-64" "x86_64-unknown-linux-gnu -march=x86-64-v3" \
  "x86_64-unknown-linux-gnu -march=skylake-avx512" "spir64-unknown-unknown -emit-llvm"; do
  for lights in "-DGLINT_HAS_DIRECTIONAL=1 -DGLINT_HAS_POINT=0" \
    "-DGLINT_HAS_DIRECTIONAL=0 -DGLINT_HAS_POINT=0" "-DGLINT_HAS_DIRECTIONAL=1 -DGLINT_HAS_POINT=1"; do
    # PoCL defines __OPENCL_VERSION__ itself; clang -x cl does not for these targets.
    # shellcheck disable=SC2086
    if "$CLANG" -x cl -cl-std=CL1.2 -Xclang -finclude-default-header -target $t -O2 -S \
      -D__OPENCL_VERSION__=120 -I"$src" -DGLINT_NDF=0 -DGLINT_FRESNEL=0 -DGLINT_PROBE=0 \
      -DGLINT_HAS_FRAME=0 $lights -DGLINT_USE_DOUBLE=0 -cl-single-precision-constant \
      -DGLINT_LANES=16 -DGLINT_BLOCKS=4 -o "$out/k.s" "$src/models/binomial/binomial_lanes.cl" \
      2>"$out/err.txt"; then
      r=OK
      c=$(grep -ci compress "$out/k.s")
      case "$t" in
      *skylake-avx512*) [ "$c" -gt 0 ] || { r="FAIL (no regrouped draws)"; status=1; } ;;
      *) [ "$c" -eq 0 ] || { r="FAIL (AVX-512 compress outside AVX-512)"; status=1; } ;;
      esac
    else
      r=FAIL
      c=-
      status=1
    fi
    echo "$r  $t  $lights  (compress: $c)"
    case "$r" in FAIL*) grep error "$out/err.txt" | head -3 ;; esac
    rm -f "$out/k.s"
  done
done
rm -rf "$out"
exit $status
