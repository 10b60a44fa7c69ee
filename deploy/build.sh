#!/usr/bin/env bash
# build.sh: configures texfree with CMake + Ninja and builds everything.
# BUILD_TYPE (default Release) and BUILD_DIR (default build/, relative to the
# repository root) override the defaults; extra arguments go to cmake's
# configure step (e.g. -DTEXFREE_BUILD_TESTS=OFF). BUILD_TARGETS (space
# separated) builds only those targets instead of everything.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
BUILD_TYPE=${BUILD_TYPE:-Release}
BUILD_DIR=${BUILD_DIR:-build}
case "$BUILD_DIR" in
  /*) ;;
  *) BUILD_DIR="$ROOT/$BUILD_DIR" ;;
esac

cmake -S "$ROOT" -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE="$BUILD_TYPE" "$@"
targets=()
for target in ${BUILD_TARGETS:-}; do
  targets+=(--target "$target")
done
cmake --build "$BUILD_DIR" -j"$(nproc)" "${targets[@]}"
