#!/usr/bin/env bash
# test.sh: installs what is missing, builds, and runs every test with ctest.
# Extra arguments go to ctest (e.g. -R config). Exits with ctest's code.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
"$ROOT/deploy/install-deps.sh"
"$ROOT/deploy/build.sh"

BUILD_DIR=${BUILD_DIR:-build}
exec ctest --test-dir "$BUILD_DIR" --output-on-failure -j2 --timeout 600 "$@"
