#!/usr/bin/env bash
# The tests on aarch64 (NEON), on this x86-64 machine: builds the workspace for
# aarch64-unknown-linux-gnu with Debian's Rust and runs its tests under qemu's user-mode
# emulator. Needs root and apt (a Debian bookworm system, as the native set-up does).
#
# Usage: scripts/cross-test.sh [--lanes|--all] [--reproduce] [extra cargo test arguments]
#   (default) the crates below the renderer, whole (what CI runs): the
#             lane trait bit for bit on every aarch64 backend (backends/simd/tests/lanes.rs),
#             the approximations' error bounds, the traversal interface and the two-level BSP
#             against brute force (packets and builds; beams and watertightness with --all);
#   --lanes   only the lane crate's tests (coherent-simd: the lane trait bit for bit on every
#             aarch64 backend, the approximations' error bounds, dispatch);
#   --all     the whole workspace: the renderer against closed forms, renders per backend and
#             accelerator, obvhs, the `coherent` and `reproduce` command lines (the build
#             takes about 25 minutes on 2 cores, the tests about 8 under emulation);
#   --reproduce  then `reproduce --quick` under emulation, a smoke test whose times are the
#             emulator's (its report says so), into target/aarch64/results.
#
# What does not exist for aarch64 is skipped by name, with the reason: Embree (no Embree 4
# for aarch64 in the registries: PyPI's embreex has x86-64 wheels only, Debian's arm64 has
# Embree 3.13), i.e. the coherent-embree crate's tests and every test named `embree`. The
# other tests that meet Embree (an accelerator loop) print that they skip it.
set -euo pipefail
cd "$(dirname "$0")/.."

target=aarch64-unknown-linux-gnu
all=0
lanes=0
reproduce=0
args=()
for a in "$@"; do
    case "$a" in
        --all) all=1 ;;
        --lanes) lanes=1 ;;
        --reproduce) reproduce=1 ;;
        *) args+=("$a") ;;
    esac
done

# Debian bookworm (and bookworm-security) packages, pinned by version; apt checks each .deb
# against the sha256 of the signed archive index. Debian's Rust 1.96 brings the aarch64
# standard library (the rustup toolchain here has only x86-64's and rustup's own download
# server is not a registry we reach).
packages=(
    "rustc-web=1.96.0+dfsg1-1~deb12u2"
    "libstd-rust-web-dev:arm64=1.96.0+dfsg1-1~deb12u2"
    "gcc-aarch64-linux-gnu=4:12.2.0-3"
    "libc6-dev-arm64-cross=2.36-8cross1"
    "qemu-user-static=1:7.2+dfsg-7+deb12u18+b3"
)
missing=()
for p in "${packages[@]}"; do
    name="${p%%=*}"
    want="${p#*=}"
    have="$(dpkg-query -W -f='${Version}' "$name" 2>/dev/null || true)"
    [[ "$have" == "$want" ]] || missing+=("$p")
done
if ((${#missing[@]})); then
    echo "cross-test.sh: installing ${missing[*]}" >&2
    if [[ $(id -u) -ne 0 ]]; then
        echo "cross-test.sh: installing the cross toolchain needs root (apt-get)" >&2
        exit 1
    fi
    dpkg --add-architecture arm64
    apt-get update -q >/dev/null
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
        "${missing[@]}" >/dev/null
fi

# Debian's compiler, named: the rustup proxies earlier on PATH would hide it. Its own target
# folder: nothing is shared with the x86-64 builds (another compiler).
export RUSTC=/usr/bin/rustc RUSTDOC=/usr/bin/rustdoc
export CARGO_TARGET_DIR=target/aarch64
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_LINKER=aarch64-linux-gnu-gcc
# The static emulator needs no loader path (`qemu-aarch64 -L /usr/aarch64-linux-gnu` hangs at
# the first thread): the arm64 libc of libstd-rust-web-dev:arm64 is where the binaries look.
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUNNER=qemu-aarch64-static
# The tests that start the built `coherent` and `reproduce` run them through it too
# (`coherent::require::command`), so the kernel needs no binfmt registration.
export COHERENT_TEST_RUNNER=qemu-aarch64-static
# The backends aarch64 has must run, never be skipped: the target's list, not the host's (an
# inherited list, as CI exports for the x86-64 tests, names x86 backends).
COHERENT_REQUIRE_BACKENDS="$(scripts/required-backends.sh aarch64)"
export COHERENT_REQUIRE_BACKENDS
echo "cross-test.sh: $target, $($RUSTC -V), COHERENT_REQUIRE_BACKENDS=$COHERENT_REQUIRE_BACKENDS"

embree_reason="no Embree 4 for aarch64 in the registries (PyPI's embreex has x86-64 wheels only; Debian's arm64 has Embree 3.13)"
echo "cross-test.sh: skipped: the coherent-embree crate's tests and every test named *embree*: $embree_reason"
skip=(--skip embree)
# Libraries and test targets (not the examples: clippy checks that they compile).
targets=(--lib --bins --tests)
if ((lanes)); then
    cargo test --target "$target" -p coherent-simd --lib --tests "${args[@]}" -- "${skip[@]}"
elif ((all)); then
    cargo test --target "$target" --workspace --exclude coherent-embree "${targets[@]}" \
        "${args[@]}" -- "${skip[@]}"
else
    cargo test --target "$target" -p coherent-simd -p coherent-accel -p coherent-bsp \
        --lib --test lanes --test input --test equivalence --test build \
        "${args[@]}" -- "${skip[@]}"
fi

if ((reproduce)); then
    out=target/aarch64/results
    rm -rf "$out"
    cargo build --target "$target" --release -p coherent-experiments --bin reproduce
    qemu-aarch64-static "target/aarch64/$target/release/reproduce" --quick --out "$out"
    echo "cross-test.sh: reproduce --quick under emulation wrote $out"
fi
