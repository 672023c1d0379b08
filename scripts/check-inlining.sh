#!/usr/bin/env bash
# The run-time dispatched backends (avx2, avx512, pulp8, pulp16) run each kernel inside one
# `#[target_feature]` function (pulp's `vectorize`). Code that LLVM leaves out of line there (a
# closure called twice, `array::map`, a provided trait method marked only `#[inline]`) is
# compiled without AVX, so every intrinsic inside it becomes a function call that spills its
# vectors to memory: a packet loop slower than the scalar one, and no compiler warning.
#
# This script finds such code in a release binary: every function, other than the intrinsics
# themselves, that calls (or tail-calls) an out-of-line AVX/AVX2/FMA/AVX-512 intrinsic of
# `core::arch`, and every function of ours or pulp's that calls libm's rounding (what the
# pulp backend's lane-by-lane `floor`/`round` become outside the kernel). It fails, listing
# them with their call counts, if there is any.
# Usage: scripts/check-inlining.sh [BINARY]   (default: target/release/reproduce, built by
# `scripts/reproduce.sh`; `cargo build --release -p coherent-experiments` builds it alone)
set -euo pipefail
cd "$(dirname "$0")/.."
bin="${1:-target/release/reproduce}"
if [[ ! -x "$bin" ]]; then
    echo "check-inlining: $bin not found; build it with: cargo build --release -p coherent-experiments" >&2
    exit 2
fi
command -v objdump >/dev/null || {
    echo "check-inlining: objdump (binutils) is needed" >&2
    exit 2
}

report=$(objdump -d --no-show-raw-insn -C "$bin" | awk '
    /^[0-9a-f]+ <.*>:$/ {
        fn = substr($0, index($0, "<") + 1)
        sub(/>:$/, "", fn)
        intrinsic = (fn ~ /^core::core_arch::/)
        next
    }
    !intrinsic && /(call|jmp)/ && /core::core_arch::x86(_64)?::(avx|avx2|fma|avx512[a-z]*|f16c|bmi[12])::/ {
        calls[fn]++
    }
    # The pulp backend rounds lane by lane with f32::floor / round_ties_even, which inside the
    # kernel become one vroundps; out of line (no SSE4.1) each lane would call libm.
    (fn ~ /coherent|pulp::/) && /(call|jmp)/ && /<(floorf|ceilf|truncf|rintf|nearbyintf|roundf|roundevenf)(@plt)?>/ {
        calls[fn]++
    }
    END { for (f in calls) printf "%6d  %s\n", calls[f], f }
' | sort -rn)

if [[ -n "$report" ]]; then
    n=$(wc -l <<<"$report")
    echo "check-inlining: $n function(s) in $bin call AVX intrinsics or libm rounding out of line (calls, function):"
    echo "$report"
    echo "Inline them into the kernel (#[inline(always)] functions; no closures called twice," \
        "no array::map over lanes; see the inlining rules in docs/architecture.md)." >&2
    exit 1
fi
echo "check-inlining: no out-of-line AVX intrinsic or libm rounding calls in $bin"
