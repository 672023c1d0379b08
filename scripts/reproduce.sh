#!/usr/bin/env bash
# Regenerates results/ (or --out DIR): fetches the pinned native pieces (Embree, meshes,
# HDR maps, real scenes; the dungeon scene only without --quick),
# then runs `reproduce` in release mode with the arguments given, e.g.
#   scripts/reproduce.sh --quick --only accel --out /tmp/results
#
# --native: first runs the same experiments from a build for this CPU (`-C target-cpu=native`,
# in its own target folder target/native, so the portable build is untouched) into DIR/native,
# then the portable build into DIR; reports show the two builds side by side where they have
# both, and each folder's machine.json says which build it is (`build`: native / portable,
# with its `rustflags` and `target_features`).
set -euo pipefail
cd "$(dirname "$0")/.."
# A failed Embree set-up is not fatal here: the accel experiment then says so and measures
# the other structures.
python3 scripts/native.py || echo "reproduce.sh: going on without Embree (see the error above)" >&2
native=0
out=results
args=()  # everything but --out
while (($#)); do
    case "$1" in
        --native) native=1 ;;
        --out) out="$2"; shift ;;
        --out=*) out="${1#--out=}" ;;
        *) args+=("$1") ;;
    esac
    shift
done
# The full run also renders the castle dungeon scene, whose package is a 257 MB download:
# fetched here only when the run is not --quick.
quick=0
for a in "${args[@]}"; do [[ "$a" == --quick ]] && quick=1; done
# The full run also compiles the spectral colour forms for every hand-written SIMD backend
# (the `spectral-simd` feature: the `spectral` experiment's width comparison); the quick run
# keeps the default build, where they render on scalar alone.
features=()
if ((!quick)); then
    python3 scripts/native.py dungeon
    features=(--features coherent/spectral-simd)
fi
if ((native)); then
    RUSTFLAGS="${RUSTFLAGS:-} -C target-cpu=native" CARGO_TARGET_DIR=target/native \
        cargo run --release -p coherent-experiments "${features[@]}" --bin reproduce -- "${args[@]}" --out "$out/native"
fi
exec cargo run --release -p coherent-experiments "${features[@]}" --bin reproduce -- "${args[@]}" --out "$out"
