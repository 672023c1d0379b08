#!/usr/bin/env bash
# Frame times of two revisions side by side: builds `coherent` (release) at REV_A and at
# REV_B, each in a worktree and target folder of its own under target/ab/, then renders each
# scene on each backend with both binaries in alternating rounds (one thread, pinned to CPU 0
# where taskset exists) and prints per scene and backend the median frame time of each and
# their ratio B / A. What a change to the renderer's code costs or gains, with the machine's
# drift spread over both sides.
#
#   scripts/ab-frames.sh REV_A REV_B [ROUNDS] [SCENES] [BACKENDS] [WxH]
#   scripts/ab-frames.sh HEAD~1 HEAD 8 "car spdemo glass1 room2" "scalar sse avx512 pulp16" 384x288
#
# REV_B may be `.`: the working tree as it is. Backends this CPU cannot run are skipped by the
# renderer with its reason.
set -euo pipefail
cd "$(dirname "$0")/.."
[[ $# -ge 2 ]] || { sed -n 2,13p "$0"; exit 2; }
rev_a=$1
rev_b=$2
rounds=${3:-8}
scenes=${4:-"car spdemo glass1 room2"}
backends=${5:-"scalar sse avx512 pulp16"}
size=${6:-384x288}
root=$PWD
ab=$root/target/ab

build() { # build REV NAME: prints the binary's path
    local rev=$1 name=$2 src
    if [[ $rev == . ]]; then
        src=$root
    else
        src=$ab/$name
        rm -rf "$src"
        git worktree prune
        git worktree add --detach -f "$src" "$rev" >&2
    fi
    # Each side its own target folder: the two builds never share artifacts.
    (cd "$src" && CARGO_TARGET_DIR="$ab/target-$name" cargo build --release --bin coherent >&2)
    echo "$ab/target-$name/release/coherent"
}

mkdir -p "$ab"
bin_a=$(build "$rev_a" a)
bin_b=$(build "$rev_b" b)
pin=()
command -v taskset > /dev/null && pin=(taskset -c 0)
out=$ab/frames.txt
: > "$out"
for scene in $scenes; do
    for backend in $backends; do
        for ((r = 1; r <= rounds; r++)); do
            for side in a b; do
                bin=$bin_a
                [[ $side == b ]] && bin=$bin_b
                # The renderer prints "median T s" for --frames N.
                t=$("${pin[@]}" "$bin" render "$scene" --backend "$backend" --threads 1 --spp 1 \
                    --resolution "$size" --frames 5 --out "$ab/$side.png" 2>&1 |
                    grep -o 'median [0-9.]*' | awk '{print $2}') || true
                [[ -n $t ]] && echo "$scene $backend $side $t" >> "$out"
            done
        done
    done
done
python3 - "$out" "$rev_a" "$rev_b" <<'EOF'
import collections, statistics, sys
path, a, b = sys.argv[1:]
times = collections.defaultdict(list)
for line in open(path):
    scene, backend, side, t = line.split()
    times[(scene, backend, side)].append(float(t))
print(f"median frame seconds, A = {a}, B = {b}")
print(f"{'scene':<10} {'backend':<8} {'A':>8} {'B':>8} {'B / A':>7}")
for scene, backend in dict.fromkeys((s, k) for s, k, _ in times):
    ta, tb = times[(scene, backend, "a")], times[(scene, backend, "b")]
    if ta and tb:
        ma, mb = statistics.median(ta), statistics.median(tb)
        print(f"{scene:<10} {backend:<8} {ma:8.4f} {mb:8.4f} {mb / ma:7.3f}")
EOF
