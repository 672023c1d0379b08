#!/usr/bin/env bash
# Checks that the scalar baseline is really scalar and calls no library math: disassembles the
# release build (the library as `reproduce` links it) of every timed scalar loop
# (`coherent::kernels::scalar_baseline` for the approximations,
# `coherent::bdf::workload::scalar_baseline_bdf` for Table 1's BDF and
# `coherent::texture::workload::scalar_baseline_texture` for the texture lookups: the same
# generic code `reproduce` times, monomorphised for the scalar backend) and fails if
# - the approximations' loop holds packed floating-point arithmetic (LLVM's loop vectoriser
#   would show up as `mulps`, `addps`, `vfmadd...ps`, ...; in the BDF and texture loops the
#   packed ops are counted and warned about: LLVM's SLP vectoriser packs a few within one
#   call there, 80 and 32 at the last check; a build without SLP is as fast), or
# - a loop, or any function of this build it calls (followed transitively), calls libm
#   (`floorf`, `roundf`, `expf`, ...): the SIMD backends inline their rounding, so a library
#   call in the scalar baseline alone would inflate every speedup over it.
set -euo pipefail
cd "$(dirname "$0")/.."
# The library as `reproduce` links it (the same build, so this check costs no compilation of
# its own once `reproduce` is built): its object code, disassembled with relocations.
rlib=$(cargo build --release -p coherent-experiments --message-format=json 2>/dev/null |
    python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "coherent" \
            and "lib" in m["target"]["kind"]:
        print(*[f for f in m["filenames"] if f.endswith(".rlib")])
')
if [[ -z "$rlib" ]]; then
    echo "check-scalar-asm: building the release library failed:" >&2
    cargo build --release -p coherent-experiments >&2
    exit 1
fi
objdump -dr --no-show-raw-insn "$rlib" >target/scalar-baseline.dis 2>/dev/null
python3 - target/scalar-baseline.dis <<'EOF'
import re, sys

# objdump -dr: `0000... <symbol>:` opens a function; a call's target is on the instruction
# (`call 1234 <symbol>`) or, unresolved in an object file, on the relocation line after it.
bodies, cur = {}, None
head_re = re.compile(r"^[0-9a-f]+ <([^>]+)>:$")
for line in open(sys.argv[1]).read().split("\n"):
    m = head_re.match(line)
    if m:
        cur = m.group(1)
        bodies[cur] = []
    elif cur is not None and line.strip():
        bodies[cur].append(line)

roots = sorted(s for s in bodies if re.search(r"scalar_baseline(_bdf|_texture)?17h", s))
wanted = ["scalar_baseline17h", "scalar_baseline_bdf17h", "scalar_baseline_texture17h"]
failed = False
for w in wanted:
    if not any(w in r for r in roots):
        print(f"{w[:-3]} not found in the assembly", file=sys.stderr)
        failed = True

packed_re = re.compile(r"\bv?(add|sub|mul|div|sqrt|min|max|fmadd\d*|fmsub\d*|fnmadd\d*)ps\b")
scalar_re = re.compile(r"\bv?(add|sub|mul|div|sqrt|min|max|fmadd\d*)ss\b")
libm = {
    "floorf", "ceilf", "roundf", "roundevenf", "truncf", "rintf", "nearbyintf", "expf",
    "exp2f", "expm1f", "logf", "log2f", "log10f", "log1pf", "powf", "sinf", "cosf", "tanf",
    "asinf", "acosf", "atanf", "atan2f", "sqrtf", "fmaf", "fmodf", "hypotf", "cbrtf",
    "floor", "ceil", "round", "trunc", "exp", "log", "pow", "sqrt", "fma",
}
insn_target_re = re.compile(r"\b(?:call|jmp)[a-z]*\s+[0-9a-f]+ <([^>+]+)>")
reloc_re = re.compile(r"R_X86_64_(?:PLT32|PC32|GOTPCRELX?|REX_GOTPCRELX)\s+([^\s+-]+)")


def targets(body):
    """The functions a body calls or tail-calls."""
    after_call = False
    for l in body:
        if after_call:
            m = reloc_re.search(l)
            if m:
                yield m.group(1).removesuffix("@plt")
                after_call = False
                continue
        m = insn_target_re.search(l)
        if m:
            yield m.group(1).removesuffix("@plt")
        after_call = bool(re.search(r"\s(call|jmp)[a-z]*\s", l)) and m is None


for root in roots:
    body = bodies[root]
    packed = sum(bool(packed_re.search(l)) for l in body)
    scalar = sum(bool(scalar_re.search(l)) for l in body)
    # Every function of this build reachable by calls from the loop.
    seen, todo, calls = {root}, [root], set()
    while todo:
        for target in targets(bodies[todo.pop()]):
            if target in bodies and target not in seen:
                seen.add(target)
                todo.append(target)
            elif target not in bodies:
                calls.add(target)
    lib = sorted(c for c in calls if c in libm)
    name = re.sub(r"^_ZN.*?(scalar_baseline\w*?)17h.*$", r"\1", root)
    print(f"{name}: {scalar} scalar float ops (..ss), {packed} packed float ops (..ps), "
          f"{len(seen) - 1} functions called, libm calls: {', '.join(lib) or 'none'}")
    if packed and name == "scalar_baseline":
        print(f"{name}: the scalar baseline was vectorised", file=sys.stderr)
        failed = True
    elif packed:
        # Known: LLVM's SLP vectoriser packs a few operations within one call of the BDF and
        # texture loops (not across calls); reported, not yet failed on.
        print(f"{name}: warning: {packed} packed float ops inside one call (SLP)", file=sys.stderr)
    if lib:
        print(f"{name}: the scalar baseline calls libm ({', '.join(lib)})", file=sys.stderr)
        failed = True
sys.exit(1 if failed else 0)
EOF
