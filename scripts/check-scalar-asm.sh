#!/usr/bin/env bash
# Checks that the scalar baseline is really scalar: disassembles the release build of the
# scalar kernels (`coherent::kernels::scalar_baseline`, the same generic code `reproduce`
# times, monomorphised for the scalar backend) and fails if it holds packed floating-point
# arithmetic (LLVM's loop vectoriser would show up as `mulps`, `addps`, `vfmadd...ps`, ...).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo rustc --release --quiet --lib -p coherent -- --emit asm=target/scalar-baseline.s
sym=$(grep -oE '^_ZN[0-9A-Za-z_$.]*scalar_baseline[0-9A-Za-z_$.]*:' target/scalar-baseline.s | head -1 | tr -d :)
[ -n "$sym" ] || { echo "scalar_baseline not found in the assembly" >&2; exit 1; }
body=$(awk -v s="$sym:" '$0==s {on=1; next} on && /^\.Lfunc_end/ {exit} on' target/scalar-baseline.s)
packed=$(grep -cE '\b(v?(add|sub|mul|div|sqrt|min|max|fmadd[0-9]*|fmsub[0-9]*|fnmadd[0-9]*)ps)\b' <<<"$body" || true)
scalar=$(grep -cE '\b(v?(add|sub|mul|div|sqrt|min|max|fmadd[0-9]*)ss)\b' <<<"$body" || true)
echo "scalar_baseline: $scalar scalar float ops (..ss), $packed packed float ops (..ps)"
[ "$packed" -eq 0 ] || { echo "the scalar baseline was vectorised" >&2; exit 1; }
