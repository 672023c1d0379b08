#!/usr/bin/env bash
# The project's tests, set-up included: fetches the pinned native pieces (Embree, meshes,
# goniodiagram files, HDR maps, the real scenes but the dungeon, headless Chromium, the peer
# renderer Mitsuba),
# then runs the whole workspace's tests with the default features and with none.
# On a machine that is not x86-64 (docs/platforms.md) Embree's tests are skipped by name.
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
# And the accelerators' native libraries (Embree), where the registries have them.
export COHERENT_REQUIRE_ACCELERATORS=1
# And the headless browser of `coherent view`'s page test (native.py's `chromium` step).
export COHERENT_REQUIRE_BROWSER=1
# And the peer renderer the exporter's tests render with (native.py's `mitsuba` step).
export COHERENT_REQUIRE_PEER=1
# A backend this CPU has must run, not be skipped: the list is computed here from the CPU's
# flags (machines differ: some have AVX-512, some only AVX2), independently of the crate's own
# detection. COHERENT_REQUIRE_BACKENDS set by the caller wins.
required=$(scripts/required-backends.sh)
# Off x86-64 no registry has Embree 4 (docs/platforms.md): its tests are skipped by name,
# unless EMBREE_DIR names one built for this machine.
exclude=()
skip=()
if [[ "$(uname -m)" != x86_64 && -z "${EMBREE_DIR:-}" ]]; then
    echo "test.sh: skipped: the coherent-embree crate's tests and every test named *embree*:" \
        "no Embree 4 for $(uname -m) in the registries (set EMBREE_DIR to one built here)"
    exclude=(--exclude coherent-embree)
    skip=(-- --skip embree)
    export COHERENT_REQUIRE_ACCELERATORS=0
fi
# The pinned Chromium packages and Mitsuba wheels are amd64 ones.
if [[ "$(uname -m)" != x86_64 ]]; then
    export COHERENT_REQUIRE_BROWSER=0
    export COHERENT_REQUIRE_PEER=0
fi
# Libraries, binaries and test targets, then the doc tests: not the examples, which
# `cargo test` would build too (clippy --all-targets checks that they compile) and which
# instantiate every kernel for every backend once more.
targets=(--lib --bins --tests)
COHERENT_REQUIRE_BACKENDS="${COHERENT_REQUIRE_BACKENDS:-$required}" \
    cargo test --workspace "${targets[@]}" "${exclude[@]}" "$@" "${skip[@]}"
cargo test --workspace --doc "${exclude[@]}" "$@"
COHERENT_REQUIRE_BACKENDS=scalar cargo test --workspace --no-default-features "${targets[@]}" "$@"
