#!/usr/bin/env bash
# Prints the lane backends a test run must not skip in the default build, comma-separated, for
# COHERENT_REQUIRE_BACKENDS (tests fail instead of skipping them). Read from the CPU flags in
# /proc/cpuinfo, independently of the backends' own run-time detection.
# Usage: scripts/required-backends.sh [ARCH]  (ARCH: the target's, x86_64 or aarch64; default
# this machine's `uname -m`). A cross run under emulation names its target: aarch64 has scalar,
# wide and pulp4 (NEON is part of the base ISA), whatever the host is.
set -euo pipefail
arch="${1:-$(uname -m)}"
flags=" $(grep -m1 -E '^flags' /proc/cpuinfo 2>/dev/null | cut -d: -f2) "
has() { for f in "$@"; do [[ "$flags" == *" $f "* ]] || return 1; done; }
case "$arch" in
  x86_64)
    list="scalar,sse,wide4,wide8,wide16"
    if has avx2 fma; then list="$list,avx2,pulp8"; fi
    if has avx512f avx512bw avx512cd avx512dq avx512vl; then list="$list,avx512,pulp16"; fi
    ;;
  aarch64 | arm64) list="scalar,wide4,wide8,wide16,pulp4" ;;
  *) list="scalar,wide4,wide8,wide16" ;;
esac
echo "$list"
