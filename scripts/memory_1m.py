#!/usr/bin/env python3
"""The renderer's memory goal: a scene of a million triangles renders in under 2 GB.

Writes a binary PLY terrain of 1,005,362 triangles (a 710 x 710 height field) into a
temporary folder, renders it with the release `coherent` binary (built first) once
per accelerator (`--resolution 320x240 --spp 1 --threads 1`), and reports each run's peak
resident memory (the child's `ru_maxrss`). Fails if a run fails or reaches 2 GB.

Usage: python3 scripts/memory_1m.py [--accel bsp,embree,obvhs]
"""

import argparse
import math
import os
import struct
import subprocess
import sys
import tempfile

LIMIT = 2 * 1024**3
N = 710  # vertices per side: 2 * 709^2 = 1,005,362 triangles


def write_terrain(path):
    with open(path, "wb") as f:
        faces = 2 * (N - 1) ** 2
        f.write(
            (
                "ply\nformat binary_little_endian 1.0\n"
                f"element vertex {N * N}\nproperty float x\nproperty float y\nproperty float z\n"
                f"element face {faces}\nproperty list uchar int vertex_indices\nend_header\n"
            ).encode()
        )
        for j in range(N):
            z = j / (N - 1) * 2 - 1
            row = bytearray()
            for i in range(N):
                x = i / (N - 1) * 2 - 1
                y = 0.1 * math.sin(7 * x) * math.cos(5 * z) + 0.05 * math.sin(23 * x + 11 * z)
                row += struct.pack("<3f", x, y, z)
            f.write(row)
        for j in range(N - 1):
            row = bytearray()
            for i in range(N - 1):
                a = j * N + i
                b, c = a + 1, a + N
                row += struct.pack("<B3i", 3, a, c, b) + struct.pack("<B3i", 3, b, c, c + 1)
            f.write(row)
    return 2 * (N - 1) ** 2


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--accel", default="bsp,embree,obvhs")
    args = ap.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    binary = os.path.join(root, "target", "release", "coherent")
    # A no-op when the release binary is up to date with the sources.
    subprocess.run(["cargo", "build", "--release", "--bin", "coherent"], cwd=root, check=True)
    failed = False
    with tempfile.TemporaryDirectory() as tmp:
        mesh = os.path.join(tmp, "terrain.ply")
        tris = write_terrain(mesh)
        print(f"{mesh}: {tris:,} triangles, {os.path.getsize(mesh) / 1e6:.1f} MB")
        for accel in args.accel.split(","):
            # ru_maxrss of RUSAGE_CHILDREN is the largest of any child so far: one child per
            # accelerator through a fresh interpreter keeps the runs apart.
            probe = (
                "import resource, subprocess, sys\n"
                "r = subprocess.run(sys.argv[1:], capture_output=True, text=True)\n"
                "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
                "print(r.returncode)\n"
                "sys.stderr.write(r.stdout + r.stderr)\n"
            )
            cmd = [binary, "render", mesh, "--accel", accel, "--resolution", "320x240",
                   "--spp", "1", "--threads", "1", "--out", os.path.join(tmp, f"{accel}.png")]
            p = subprocess.run([sys.executable, "-c", probe, *cmd], capture_output=True, text=True)
            lines = p.stdout.split()
            if len(lines) < 2 or lines[1] != "0":
                print(f"{accel}: the render failed:\n{p.stderr}", file=sys.stderr)
                failed = True
                continue
            peak = int(lines[0]) * 1024
            summary = next((l for l in p.stderr.splitlines() if "triangles" in l), "")
            ok = peak < LIMIT
            failed |= not ok
            print(f"{accel}: peak resident memory {peak / 2**20:.0f} MiB "
                  f"({'under' if ok else 'NOT under'} 2 GB); {summary.strip()}")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
