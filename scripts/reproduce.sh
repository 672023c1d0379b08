#!/usr/bin/env bash
# Regenerates results/ (or --out DIR): fetches the pinned native pieces (Embree, meshes),
# then runs `reproduce` in release mode with the arguments given, e.g.
#   scripts/reproduce.sh --quick --only accel --out /tmp/results
set -euo pipefail
cd "$(dirname "$0")/.."
# A failed Embree set-up is not fatal here: the accel experiment then says so and measures
# the other structures.
python3 scripts/native.py || echo "reproduce.sh: going on without Embree (see the error above)" >&2
exec cargo run --release -p coherent-experiments --bin reproduce -- "$@"
