#!/usr/bin/env bash
# run.sh: installs what is missing, builds (Release), then runs texfree-server
# in the foreground on ${TEXFREE_LISTEN:-0.0.0.0:50051} with its database in
# ${TEXFREE_DATA_DIR:-./data}. Extra arguments go to texfree-server.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
"$ROOT/deploy/install-deps.sh"
# Only what runs here: a broken test elsewhere must not keep the server down.
BUILD_TARGETS=${BUILD_TARGETS:-"texfree-server texfree"} "$ROOT/deploy/build.sh"

BUILD_DIR=${BUILD_DIR:-build}
exec "$BUILD_DIR/server/texfree-server" \
  --listen "${TEXFREE_LISTEN:-0.0.0.0:50051}" \
  --data-dir "${TEXFREE_DATA_DIR:-./data}" "$@"
