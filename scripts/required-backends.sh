#!/usr/bin/env bash
# Prints the lane backends this machine's CPU can run in the default build, comma-separated,
# for COHERENT_REQUIRE_BACKENDS (tests fail instead of skipping them). Read from the CPU flags
# in /proc/cpuinfo, independently of the backends' own run-time detection; x86-64 only (on
# other machines: scalar and wide, which need nothing).
set -euo pipefail
flags=" $(grep -m1 -E '^flags' /proc/cpuinfo 2>/dev/null | cut -d: -f2) "
has() { for f in "$@"; do [[ "$flags" == *" $f "* ]] || return 1; done; }
list="scalar"
if [ "$(uname -m)" = x86_64 ]; then list="$list,sse"; fi
list="$list,wide4,wide8,wide16"
if [ "$(uname -m)" = x86_64 ]; then
  if has avx2 fma; then list="$list,avx2,pulp8"; fi
  if has avx512f avx512bw avx512cd avx512dq avx512vl; then list="$list,avx512,pulp16"; fi
fi
echo "$list"
