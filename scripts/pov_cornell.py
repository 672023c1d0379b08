#!/usr/bin/env python3
"""Converts the Cornell box of blender-data's POV-Ray template `cornell.pov` (Kari Kivisalo,
CC-BY 3.0) into Wavefront OBJ + MTL, which the renderer's OBJ reader takes.

Only what that file uses is read: `#declare NAME=finish{diffuse D ambient A}`,
`#declare NAME=texture{pigment{rgb<r,g,b>} finish{NAME}}`, `union{ triangle{<a>,<b>,<c>} ...
texture{NAME} }` and the light patch `box{<a><b> ... pigment{rgb<..>} finish{ambient A
diffuse D}}`. A material's OBJ colours are POV's: Kd = pigment x diffuse, Ka = pigment x
ambient (the light patch glows through its ambient term). Coordinates are copied as they
are: POV-Ray is left-handed, and the file's camera (`right <-1,0,0>`) mirrors x back, so the
renderer's right-handed camera at the same place, looking +z with +y up (its right is -x),
sees the image POV-Ray renders. The camera and the light (3 x 3 area-light patches under
the ceiling) are written into scenes/cornell_pov.toml by hand, from the same file.

Usage: python3 scripts/pov_cornell.py cornell.pov cornell.obj   (writes cornell.mtl beside)
"""

import re
import sys
from pathlib import Path


class PovError(Exception):
    """The .pov file is not the one this converter reads; the message says what is off."""


NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)"
VEC = rf"<\s*({NUM})\s*,?\s*({NUM})\s*,?\s*({NUM})\s*>"


def vec(m, k=1):
    return [float(m.group(k)), float(m.group(k + 1)), float(m.group(k + 2))]


def block(text, start):
    """The text between the `{` at or after `start` and its matching `}`, and the end."""
    i = text.index("{", start)
    depth = 0
    for j in range(i, len(text)):
        if text[j] == "{":
            depth += 1
        elif text[j] == "}":
            depth -= 1
            if depth == 0:
                return text[i + 1:j], j + 1
    raise PovError("unbalanced braces")


def finish_of(body, finishes):
    """(diffuse, ambient) of a finish{...} body or a declared finish's name."""
    name = body.strip()
    if name in finishes:
        return finishes[name]
    d = re.search(rf"diffuse\s+({NUM})", body)
    a = re.search(rf"ambient\s+({NUM})", body)
    # POV-Ray's defaults: diffuse 0.6, ambient 0.1.
    return (float(d.group(1)) if d else 0.6, float(a.group(1)) if a else 0.1)


def pigment_rgb(body):
    m = re.search(rf"pigment\s*{{\s*rgb\s*{VEC}\s*}}", body)
    if not m:
        raise PovError(f"no `pigment{{rgb<...>}}` in `{body.strip()[:60]}`")
    return vec(m)


def parse(text):
    """(materials {name: (kd, ka)}, groups [(material, [triangles])])."""
    text = re.sub(r"//[^\n]*", "", text)
    finishes, textures = {}, {}
    for m in re.finditer(r"#declare\s+(\w+)\s*=\s*(finish|texture)\s*(?={)", text):
        body, _ = block(text, m.end())
        if m.group(2) == "finish":
            finishes[m.group(1)] = finish_of(body, finishes)
        else:
            f = re.search(r"finish\s*{", body)
            if not f:
                raise PovError(f"texture {m.group(1)} has no finish")
            fbody, _ = block(body, f.start())
            d, a = finish_of(fbody, finishes)
            rgb = pigment_rgb(body)
            textures[m.group(1)] = ([c * d for c in rgb], [c * a for c in rgb])
    materials, groups = {}, []
    for m in re.finditer(r"(?<![#\w])union\s*(?={)", text):
        body, _ = block(text, m.end())
        t = re.search(r"texture\s*{\s*(\w+)\s*}", body)
        if not t or t.group(1) not in textures:
            raise PovError("a union without a declared texture")
        tris = [[vec(v, 1), vec(v, 4), vec(v, 7)] for v in re.finditer(
            rf"triangle\s*{{\s*{VEC}\s*,?\s*{VEC}\s*,?\s*{VEC}\s*}}", body)]
        if not tris:
            raise PovError("a union without triangles")
        materials[t.group(1)] = textures[t.group(1)]
        groups.append((t.group(1), tris))
    for k, m in enumerate(re.finditer(r"(?<![#\w])box\s*(?={)", text)):
        body, _ = block(text, m.end())
        c = re.match(rf"\s*{VEC}\s*,?\s*{VEC}", body)
        if not c:
            raise PovError("a box without its two corners")
        f = re.search(r"finish\s*{", body)
        d, a = finish_of(block(body, f.start())[0] if f else "", finishes)
        rgb = pigment_rgb(body)
        name = f"box{k}"
        materials[name] = ([x * d for x in rgb], [x * a for x in rgb])
        groups.append((name, box_triangles(vec(c, 1), vec(c, 4))))
    if not groups:
        raise PovError("no geometry found")
    return materials, groups


def box_triangles(a, b):
    lo = [min(a[i], b[i]) for i in range(3)]
    hi = [max(a[i], b[i]) for i in range(3)]
    p = [[(lo, hi)[(k >> i) & 1][i] for i in range(3)] for k in range(8)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    out = []
    for f in faces:
        q = [p[i] for i in f]
        out += [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    return out


def fmt(v):
    return " ".join(f"{x:g}" for x in v)


def convert(pov, obj):
    """Writes `obj` and the .mtl beside it from `pov`; returns the two file names."""
    pov, obj = Path(pov), Path(obj)
    materials, groups = parse(pov.read_text())
    mtl = obj.with_suffix(".mtl")
    lines = [f"# {mtl.name}: materials of {pov.name} (CC-BY 3.0, Kari Kivisalo), "
             "converted by scripts/pov_cornell.py"]
    for name, (kd, ka) in materials.items():
        lines += [f"newmtl {name}", f"Kd {fmt(kd)}", f"Ka {fmt(ka)}", "Ks 0 0 0", "illum 1", ""]
    mtl.write_text("\n".join(lines))
    out = [f"# {obj.name}: the geometry of {pov.name} (CC-BY 3.0, Kari Kivisalo), converted "
           "by scripts/pov_cornell.py", f"mtllib {mtl.name}"]
    base = 1
    for name, tris in groups:
        out += [f"g {name}", f"usemtl {name}"]
        for t in tris:
            out += [f"v {fmt(v)}" for v in t]
            out.append(f"f {base} {base + 1} {base + 2}")
            base += 3
    obj.write_text("\n".join(out) + "\n")
    return [obj.name, mtl.name]


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    try:
        print(" ".join(convert(sys.argv[1], sys.argv[2])))
    except (PovError, OSError) as e:
        sys.exit(f"pov_cornell.py: {sys.argv[1]}: {e}")
