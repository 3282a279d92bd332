#!/usr/bin/env bash
# Installs the Debian (bookworm) packages glint builds and runs with.
# Idempotent: skips apt entirely when everything is already installed.
set -euo pipefail
PACKAGES=(
  build-essential cmake pkg-config
  pocl-opencl-icd ocl-icd-opencl-dev opencl-headers opencl-clhpp-headers clinfo
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler grpc-proto
  libopenexr-dev libpng-dev libgtest-dev
  libfreetype-dev fonts-dejavu-core
  nlohmann-json3-dev python3  # bench_models --json; scripts/bench_tables.py (README tables)
  python3-venv libb64-0d  # KServe tests: tritonclient venv; perf_analyzer's libb64
  libcpp-httplib-dev  # glintd --metrics-listen (Prometheus /metrics)
  openssl             # tests: certificates for TLS / mutual TLS made at test time
  libboost-math1.74-dev  # chi-square quantiles of the sampling tests (tests/service/sample_test.cpp)
  libssl-dev
  clang-14 libclang-rt-14-dev
  nginx-light  # tests/deploy: the gRPC load balancer of docker/compose.yaml
)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
