#!/usr/bin/env bash
# install-deps.sh: installs, with apt-get, every Debian 12 package that texfree's
# build, tests, benchmarks and demo need. Idempotent: does nothing (not even
# apt-get update) when dpkg-query reports every package installed.
# Runs as root, or through sudo when not root.
set -euo pipefail

PACKAGES=(
  # Toolchain.
  build-essential cmake ninja-build pkg-config git ca-certificates
  # gRPC + protobuf: all four are needed for find_package(gRPC CONFIG).
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libabsl-dev
  # Algorithms and images (contrib provides the freetype module).
  libopencv-dev libopencv-contrib-dev libeigen3-dev
  # libjpeg-turbo directly: light bursts decode only the rows that hold lights.
  libjpeg62-turbo-dev
  # Storage.
  libsqlite3-dev sqlite3
  # Logging, CLI, JSON.
  libspdlog-dev libfmt-dev libcli11-dev nlohmann-json3-dev
  # Tests and benchmarks.
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  # Fonts for overlays and rendered pages.
  fonts-dejavu-core fonts-dejavu-extra
  # Held-out fonts for test pages (Times/Arial/Courier-like and TeX's Latin
  # Modern, never used in tuning): texfree-bench-retrieval --fonts
  # liberation|freefont|latinmodern.
  fonts-liberation2 fonts-freefont-ttf fonts-lmodern
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$pkg" 2>/dev/null || true)
  if [[ "$status" != "installed" ]]; then
    missing+=("$pkg")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#PACKAGES[@]} packages already installed" >&2
  exit 0
fi

SUDO=()
if [[ $(id -u) -ne 0 ]]; then
  if command -v sudo >/dev/null 2>&1; then
    SUDO=(sudo)
  else
    echo "install-deps: missing packages (${missing[*]}) and not root;" \
      "run as root or install sudo" >&2
    exit 1
  fi
fi

echo "install-deps: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
"${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update
"${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y \
  --no-install-recommends "${missing[@]}"
