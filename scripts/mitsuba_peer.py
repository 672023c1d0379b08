#!/usr/bin/env python3
"""Renders a scene exported by `coherent export --mitsuba` with the pinned Mitsuba 3, timing
each frame: the driver behind src/export/peer.rs (the `peers` experiment and the exporter's
tests). One process per scene and variant, so that the JIT's kernels stay compiled between
frames, as they would for a user rendering several frames.

  python3 scripts/mitsuba_peer.py --scene DIR/scene.xml --variant llvm_ad_rgb --threads 2

It prints one JSON line when the scene is loaded ({"ready": true, "import_s", "load_s",
"mitsuba", "drjit"}), then reads one JSON request per line on stdin, {"spp": N, "seed": S,
"out": "image.exr" or null}, renders, and answers {"seconds": T} with T the time of
`mi.render` and its evaluation (the image written afterwards, outside the time). A failure
is one line {"error": "..."} and exit status 1.

Needs .native/mitsuba/site on PYTHONPATH and DRJIT_LIBLLVM_PATH naming the LLVM library for
the llvm_* variants (peer.rs sets both; `python3 scripts/native.py mitsuba` installs them).
"""

import argparse
import json
import sys
import time


def say(obj):
    print(json.dumps(obj), flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", required=True)
    ap.add_argument("--variant", required=True)
    ap.add_argument("--threads", type=int, required=True)
    args = ap.parse_args()
    pool = args.threads
    if args.threads == 1:
        # A pool of one thread deadlocks in this Mitsuba (a scalar_rgb render at 1024 x 768,
        # an EXR write): one thread's budget is two pool threads pinned to one core.
        import os
        os.sched_setaffinity(0, [min(os.sched_getaffinity(0))])
        pool = 2
    t0 = time.perf_counter()
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError as e:
        say({"error": f"cannot import Mitsuba ({e}): run `python3 scripts/native.py mitsuba`"})
        return 1
    import_s = time.perf_counter() - t0
    if args.variant not in mi.variants():
        say({"error": f"this Mitsuba has no variant {args.variant} (it has "
                      f"{', '.join(mi.variants())})"})
        return 1
    try:
        mi.set_variant(args.variant)
    except Exception as e:  # noqa: BLE001 (Dr.Jit raises plain exceptions here)
        say({"error": f"variant {args.variant} cannot start: {e}"})
        return 1
    dr.set_thread_count(pool)
    t0 = time.perf_counter()
    try:
        scene = mi.load_file(args.scene)
    except Exception as e:  # noqa: BLE001
        say({"error": f"{args.scene}: Mitsuba cannot load it: {e}"})
        return 1
    load_s = time.perf_counter() - t0
    say({"ready": True, "import_s": import_s, "load_s": load_s,
         "mitsuba": mi.__version__, "drjit": dr.__version__})
    for line in sys.stdin:
        line = line.strip()
        if not line:
            continue
        req = json.loads(line)
        try:
            t0 = time.perf_counter()
            img = mi.render(scene, spp=int(req["spp"]), seed=int(req.get("seed", 0)))
            dr.eval(img)
            dr.sync_thread()
            seconds = time.perf_counter() - t0
            if req.get("out"):
                mi.Bitmap(img).write(req["out"])
        except Exception as e:  # noqa: BLE001
            say({"error": f"rendering {args.scene} with {args.variant} failed: {e}"})
            return 1
        say({"seconds": seconds})
    return 0


if __name__ == "__main__":
    sys.exit(main())
