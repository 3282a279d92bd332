#!/bin/sh
# Compiles models/binomial/binomial_lanes.cl of the source tree $1 (default .) with the options of
# a BINOMIAL fp32 lights request (4 blocks of 16 lanes, as server/device_engine.cpp passes them to
# PoCL) by clang-15 for CPUs with and without AVX-512 and for spir64 (LLVM IR only), and prints per
# target and light set OK / FAIL and how many AVX-512 compress instructions (x86 assembly) or
# intrinsics (IR) the kernel holds: only skylake-avx512 should have any (GLINT_BINOMIAL_REGROUP,
# the regrouped draws), every target should build (models/binomial/README.md "Quad throughput
# (session 19)"). Not a ctest: it needs clang-15, which the test machines need not have.
src=${1:-.}
out=$(mktemp -d)
status=0
for t in "x86_64-unknown-linux-gnu -march=x86-64" "x86_64-unknown-linux-gnu -march=x86-64-v3" \
  "x86_64-unknown-linux-gnu -march=skylake-avx512" "spir64-unknown-unknown -emit-llvm"; do
  for lights in "-DGLINT_HAS_DIRECTIONAL=1 -DGLINT_HAS_POINT=0" \
    "-DGLINT_HAS_DIRECTIONAL=0 -DGLINT_HAS_POINT=0" "-DGLINT_HAS_DIRECTIONAL=1 -DGLINT_HAS_POINT=1"; do
    # PoCL defines __OPENCL_VERSION__ itself; clang -x cl does not for these targets.
    # shellcheck disable=SC2086
    if clang-15 -x cl -cl-std=CL1.2 -Xclang -finclude-default-header -target $t -O2 -S \
      -D__OPENCL_VERSION__=120 -I"$src" -DGLINT_NDF=0 -DGLINT_FRESNEL=0 -DGLINT_PROBE=0 \
      -DGLINT_HAS_FRAME=0 $lights -DGLINT_USE_DOUBLE=0 -cl-single-precision-constant \
      -DGLINT_LANES=16 -DGLINT_BLOCKS=4 -o "$out/k.s" "$src/models/binomial/binomial_lanes.cl" \
      2>"$out/err.txt"; then
      r=OK
    else
      r=FAIL
      status=1
    fi
    c=$(grep -ci compress "$out/k.s" 2>/dev/null)
    echo "$r  $t  $lights  (compress: ${c:-0})"
    [ $r = FAIL ] && grep error "$out/err.txt" | head -3
    rm -f "$out/k.s"
  done
done
rm -rf "$out"
exit $status
