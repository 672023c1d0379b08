#!/usr/bin/env bash
# The project's tests, set-up included: fetches the pinned native pieces (Embree, meshes,
# goniodiagram files, HDR maps, the real scenes but the dungeon),
# then runs the whole workspace's tests with the default features and with none.
# Usage: scripts/test.sh [extra cargo test arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
python3 scripts/native.py
# The real-mesh tests fail, rather than skip, when the meshes could not be fetched.
export COHERENT_REQUIRE_MESHES=1
# Likewise the goniodiagram files.
export COHERENT_REQUIRE_PHOTOMETRY=1
export COHERENT_REQUIRE_HDR=1
# And the real scenes' assets (every scenes/*.toml but the dungeon, which only the full
# reproduce fetches: a 257 MB download).
export COHERENT_REQUIRE_SCENES=1
cargo test --workspace "$@"
cargo test --workspace --no-default-features "$@"
