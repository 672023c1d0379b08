#!/usr/bin/env python3
"""Fetches the project's native pieces from the package registries, pinned and checksummed.

  embree  Embree 4.4 (libembree4 + its libtbb) out of the PyPI wheel embreex==4.4.0.post1,
          into .native/embree/lib/ (the Embree backend loads it at run time).
  meshes  Real test meshes out of Debian packages (the Stanford bunny from glmark2-data,
          OFF meshes from libcgal-demo), into .cache/meshes/.
  photometry  Real goniodiagram files, as test data only (never linked): the IES LM-63-2002
          and EULUMDAT examples inside the lidrs crate 0.2.3 (crates.io, MIT) and the six
          manufacturer .ldt fixtures of the eulumdat 0.7.1 sdist (PyPI), into
          .cache/photometry/.
  hdr     Real HDR latitude-longitude maps: the eight CC0 studio-light worlds of Debian's
          blender-data 3.4.1 (DWAB-compressed EXR, which the exr crate reads), into .cache/hdr/.
  assimp  Khronos glTF 2.0 sample models out of Debian's assimp-testmodels 5.2.5 (the
          2CylinderEngine and ClearCoat scenes), into .cache/scenes/assimp/.
  cornell The Cornell box of blender-data's POV-Ray template cornell.pov (CC-BY 3.0, Kari
          Kivisalo), converted by scripts/pov_cornell.py into OBJ + MTL, into
          .cache/scenes/cornell/ (the same pinned blender-data download as `hdr`).
  dungeon The CC0 castle dungeon glTF level of Debian's castle-game-engine-doc 7.0~alpha.2
          (a 257 MB download): only when asked for by name (the full reproduce does), never
          by default, into .cache/scenes/dungeon/.
  chromium Debian's headless Chromium (chromium-headless-shell and chromium-common
          150.0.7871.100-1~deb12u1, 86 MB, x86-64), installed system-wide with
          `apt-get install` (root), which brings its libraries from Debian: the browser that
          tests/view_browser.rs drives through `coherent view`'s page.
  mitsuba The peer renderer Mitsuba 3.9.1 and Dr.Jit 1.5.0 (PyPI wheels for CPython 3.11,
          x86-64, unpacked into .native/mitsuba/site/), and Debian's libllvm22
          1:22.1.8-1~deb12u1 (installed system-wide with `apt-get install`, root), the LLVM
          that Mitsuba's vectorised variants compile with: the `peers` experiment and the
          exporter's tests (src/export/) run it.

Debian packages are kept in .cache/debs/ once checked (the dungeon's is not: it is too
large), so steps that share a package download it once.

Idempotent and quiet when everything is in place: files already there are checked against
their recorded sha256 and only fetched again when missing or changed. Exit status: 0 when
Embree is usable (a mesh that cannot be fetched is a warning: the experiments say so and go
on without it), 1 when Embree could not be set up (the message names the cause and the fix).

Usage: python3 scripts/native.py [embree] [meshes] [photometry] [hdr] [assimp] [cornell]
                                 [chromium] [mitsuba] [dungeon]
       (no argument: every step but dungeon)
Environment: EMBREE_DIR=<an Embree 4 install> skips the wheel (the backend loads from there).
"""

import hashlib
import json
import os
import platform
import shutil
import subprocess
import sys
import tarfile
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
NATIVE = ROOT / ".native"
MESHES = ROOT / ".cache" / "meshes"
PHOTOMETRY = ROOT / ".cache" / "photometry"
HDR = ROOT / ".cache" / "hdr"
SCENES = ROOT / ".cache" / "scenes"
DEBS = ROOT / ".cache" / "debs"

# Debian bookworm's blender-data: the studio-light world maps (CC0, see its license.txt).
HDR_DEB = {
    "package": "blender-data",
    "version": "3.4.1+dfsg-2",
    "sha256": "5ceaf56a49ba3ded95c751d739aeec3d19e7fad76fba5cb70666986af9303b0e",
    "folder": "usr/share/blender/datafiles/studiolights/world",
    "members": ["city.exr", "courtyard.exr", "forest.exr", "interior.exr", "night.exr",
                "studio.exr", "sunrise.exr", "sunset.exr", "license.txt"],
}

# Debian bookworm's assimp-testmodels: Khronos glTF 2.0 sample models (see the package's
# copyright file; the Khronos samples are CC-BY 4.0 / public domain per model). Members:
# (path inside the package, name in .cache/scenes/assimp/).
ASSIMP_MODELS = "usr/share/assimp/models/glTF2"
ASSIMP_DEB = {
    "package": "assimp-testmodels",
    "version": "5.2.5~ds0-1",
    "sha256": "526f326186000cd6f631ea806128548a7d3d391abd8149fddc5c4c8513e80b8a",
    "members": [(f"{ASSIMP_MODELS}/2CylinderEngine-glTF-Binary/2CylinderEngine.glb",
                 "2CylinderEngine.glb")] + [
        (f"{ASSIMP_MODELS}/ClearCoat-glTF/{name}", f"ClearCoat/{name}")
        for name in ["ClearCoatTest.gltf", "ClearCoatTest.bin", "ClearCoatLabels.png",
                     "PartialCoating.png", "PartialCoating_Alpha.png",
                     "PlasticWrap_normals.jpg", "RibsNormal.png", "RoughnessStripes.png"]
    ],
}

# The Cornell box POV-Ray template inside blender-data (the HDR maps' package).
CORNELL_POV = "usr/share/blender/scripts/addons/render_povray/templates_pov/cornell.pov"

# Debian bookworm's castle-game-engine-doc: the third-person example's CC0 dungeon level
# (glTF 2.0, its buffer and textures; the .blend source is left out).
DUNGEON_LEVEL = ("usr/share/doc/castle-game-engine-doc/examples/third_person_navigation/"
                 "data/level")
DUNGEON_DEB = {
    "package": "castle-game-engine-doc",
    "version": "7.0~alpha.2+dfsg1-5",
    "sha256": "48a57969553317d938bdcfc7085f4784ae5d429a0c251b0cbd1457477f122693",
    "size_mb": 257,
}

# Debian bookworm's headless Chromium for the browser test of `coherent view`: the shell and
# the common files it depends on at exactly its version (the security archive's newer
# chromium-common would otherwise be chosen and refused), both amd64. The main archive's
# version, which changes at point releases only (the security archive's changes with every
# Chromium update).
CHROMIUM_DEBS = [
    {
        "package": "chromium-common",
        "version": "150.0.7871.100-1~deb12u1",
        "sha256": "31326f6b71ce20a52e7bea9792bf7135d4ff802e1cdbc250960b1b46729998d2",
    },
    {
        "package": "chromium-headless-shell",
        "version": "150.0.7871.100-1~deb12u1",
        "sha256": "a6d195a93c6d4ee6ea17e99a183d52bd49599138f395a5c861a29ac592e081ee",
    },
]

# The Embree 4.4 library as built by the embreex project (manylinux, x86-64). The wheel is
# tagged per CPython version; the library inside is the same, so one exact file is pinned
# and asked for whatever python runs pip.
EMBREE_WHEEL = {
    "requirement": "embreex==4.4.0.post1",
    "file": "embreex-4.4.0.post1-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl",
    "sha256": "2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f",
    "pip_args": ["--python-version", "3.11", "--implementation", "cp",
                 "--platform", "manylinux_2_28_x86_64"],
    "library": "libembree4-4aef3270.so.4",
}

# Debian bookworm packages holding real meshes: (package, version, .deb sha256, members).
# Each member: (path inside the package, name in .cache/meshes/).
MESH_DEBS = [
    {
        "package": "glmark2-data",
        "version": "2023.01+dfsg-1",
        "sha256": "14a62322c6131ac9d846f428f06056a1de85caded38c77cb497b73e9ec316bd9",
        "members": [("usr/share/glmark2/models/bunny.obj", "bunny.obj")],
    },
    {
        "package": "libcgal-demo",
        "version": "5.5.1-2",
        "sha256": "78b09b23d4d6d1bf15552a1060b419ab3fc09918486462faed197e5fc6ac3735",
        "members": [],  # filled in below: OFF files from the demo data archive
    },
]


# Goniodiagram files: archives pinned by sha256, and the members taken out of each
# (path inside the archive, name in .cache/photometry/).
PHOTOMETRY_ARCHIVES = [
    {
        "what": "lidrs 0.2.3 (crates.io)",
        "url": "https://static.crates.io/crates/lidrs/lidrs-0.2.3.crate",
        "sha256": "2f66dc03c76e9977546d53573b94578aad2c1c9e24a3318832acb56fd2f1f040",
        "members": [
            ("lidrs-0.2.3/src/io/ies/iesna2002_example_typec.ies", "lidrs_iesna2002_example_typec.ies"),
            ("lidrs-0.2.3/src/io/eulumdat/example.ldt", "lidrs_example.ldt"),
        ],
    },
    {
        # The sdist's URL as PyPI's simple index (PEP 503) lists it; `pip download` of this
        # sdist would also build its Rust extension's metadata, which the data does not need.
        "what": "eulumdat 0.7.1 sdist (PyPI)",
        "url": "https://files.pythonhosted.org/packages/6f/df/"
               "9ad6fdaf922d5134eca47095686401b84dbf281ad3c95a3aaadb28b1b793/eulumdat-0.7.1.tar.gz",
        "sha256": "639f7e907eea96e832ae036a9588cc03f1c03ea97d9c8166a6d1223c56d3fead",
        "members": [
            (f"eulumdat-0.7.1/crates/eulumdat/tests/fixtures/{name}", f"eulumdat_{name}")
            for name in ["acrux_452lm.ldt", "alya_359lm.ldt", "biolux_dn150.ldt", "sensor.ldt",
                         "variant2_sensor_wide.ldt", "wide_luminaire.ldt"]
        ],
    },
]


# The peer renderer: Mitsuba 3 and the Dr.Jit it requires, exactly (its metadata pins
# drjit==1.5.0), as CPython 3.11 manylinux wheels; and the LLVM its `llvm_*` variants load
# at run time. Dr.Jit 1.5 fails at its first kernel with Debian's LLVM 15 and 16 (an
# instruction-selection error); Debian's libllvm22 works.
MITSUBA_WHEELS = [
    {
        "requirement": "mitsuba==3.9.1",
        "file": "mitsuba-3.9.1-cp311-cp311-manylinux_2_28_x86_64.whl",
        "sha256": "7ad4fca9aedd588e5851177c7510eb8b6d27b2a5d2ee614e443dfd1bf92d457f",
    },
    {
        "requirement": "drjit==1.5.0",
        "file": "drjit-1.5.0-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl",
        "sha256": "0d9cb374fe1f05d4167a8c24cbce6084404372e5fb3dcd6f08bbb1cee06f245a",
    },
]
MITSUBA_PIP_ARGS = ["--python-version", "3.11", "--implementation", "cp",
                    "--platform", "manylinux_2_28_x86_64"]
LLVM_DEB = {
    "package": "libllvm22",
    "version": "1:22.1.8-1~deb12u1",
    "sha256": "729ec3e943d320515c2bbdc96acfffd7ce34861e62bd5c42726bf586d644dfe2",
    # Where the package puts the library; src/export/peer.rs looks for it there.
    "library": "/usr/lib/x86_64-linux-gnu/libLLVM.so.22.1",
}


class SetupError(Exception):
    """A set-up step failed; the message names the cause and the fix."""


def say(msg):
    print(f"native.py: {msg}", file=sys.stderr)


def sha256_of(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def marker_ok(folder):
    """True when folder/READY.json lists files that are all present with their sha256."""
    marker = folder / "READY.json"
    try:
        recorded = json.loads(marker.read_text())
        return all(sha256_of(folder / name) == digest for name, digest in recorded.items())
    except (OSError, ValueError, AttributeError):
        return False


def write_marker(folder, names):
    recorded = {name: sha256_of(folder / name) for name in names}
    (folder / "READY.json").write_text(json.dumps(recorded, indent=1, sort_keys=True) + "\n")


def pip_download(requirement, extra_args, dest,
                 hint="or set EMBREE_DIR to an Embree 4 install"):
    cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
           "--only-binary=:all:", "--disable-pip-version-check", "--dest", str(dest),
           *extra_args, requirement]
    try:
        run = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as e:
        raise SetupError(f"cannot run pip ({e}); install pip for {sys.executable}") from e
    if run.returncode != 0:
        tail = (run.stderr or run.stdout).strip().splitlines()[-3:]
        raise SetupError(f"`pip download {requirement}` failed: {' / '.join(tail)}; "
                         f"check that PyPI is reachable, {hint}")


def verify(path, expected, what):
    got = sha256_of(path)
    if got != expected:
        raise SetupError(f"checksum mismatch for {what} ({path.name}): expected sha256 "
                         f"{expected}, got {got}; the registry served a file that is not the "
                         "pinned one, or it was corrupted on the way: run "
                         "`python3 scripts/native.py` again, and if it persists review the "
                         "pin in scripts/native.py (never just replace the checksum)")


def setup_embree():
    """Makes .native/embree/lib/libembree4.so.4 (and its libtbb) from the pinned wheel."""
    if os.environ.get("EMBREE_DIR"):
        return  # the user's own Embree install; the backend loads from there
    if sys.platform != "linux" or platform.machine() not in ("x86_64", "AMD64"):
        say(f"no pinned Embree build for {sys.platform}/{platform.machine()}: the embree "
            "backend will report itself unavailable (set EMBREE_DIR to an Embree 4 install)")
        return
    folder = NATIVE / "embree" / "lib"
    if marker_ok(folder):
        return
    say("fetching Embree 4.4 (PyPI embreex==4.4.0.post1, pinned by sha256) into .native/embree")
    downloads = NATIVE / "downloads"
    downloads.mkdir(parents=True, exist_ok=True)
    wheel = downloads / EMBREE_WHEEL["file"]
    if not wheel.exists() or sha256_of(wheel) != EMBREE_WHEEL["sha256"]:
        with tempfile.TemporaryDirectory(dir=downloads) as tmp:
            pip_download(EMBREE_WHEEL["requirement"], EMBREE_WHEEL["pip_args"], tmp)
            got = list(Path(tmp).iterdir())
            names = [p.name for p in got]
            if names != [EMBREE_WHEEL["file"]]:
                raise SetupError(f"pip served {names}, not the pinned {EMBREE_WHEEL['file']}; "
                                 "update EMBREE_WHEEL in scripts/native.py deliberately")
            verify(got[0], EMBREE_WHEEL["sha256"], EMBREE_WHEEL["requirement"])
            os.replace(got[0], wheel)
    verify(wheel, EMBREE_WHEEL["sha256"], EMBREE_WHEEL["requirement"])
    # Unpack the libraries only (the wheel's Python module is not used).
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    libs = []
    with zipfile.ZipFile(wheel) as zf:
        for info in zf.infolist():
            if info.filename.startswith("embreex.libs/") and not info.is_dir():
                name = Path(info.filename).name
                with zf.open(info) as src, open(folder / name, "wb") as dst:
                    shutil.copyfileobj(src, dst)
                libs.append(name)
    if EMBREE_WHEEL["library"] not in libs:
        raise SetupError(f"{wheel.name} holds no {EMBREE_WHEEL['library']} (found {libs})")
    # The SONAME is libembree4-4aef3270.so.4 and its RPATH is $ORIGIN, so libtbb is found
    # beside it. The usual names point at it so that a linker or loader can use either.
    for alias in ("libembree4.so.4", "libembree4.so"):
        (folder / alias).symlink_to(EMBREE_WHEEL["library"])
    write_marker(folder, sorted(libs))


def apt_download(package, version, dest):
    """Fetches one .deb by name and version with apt-get (Debian's own client)."""
    spec = f"{package}={version}"
    cmd = ["apt-get", "download", "-q", spec]
    try:
        run = subprocess.run(cmd, cwd=dest, capture_output=True, text=True)
    except OSError as e:
        raise SetupError(f"cannot run apt-get ({e}): no Debian package client") from e
    if run.returncode != 0 and "Unable to locate" in run.stderr and os.geteuid() == 0:
        # A fresh machine may have no package lists yet: fetch them once and try again.
        subprocess.run(["apt-get", "update", "-q"], capture_output=True)
        run = subprocess.run(cmd, cwd=dest, capture_output=True, text=True)
    if run.returncode != 0:
        tail = (run.stderr or run.stdout).strip().splitlines()[-2:]
        hint = "run `apt-get update` first" if "Unable to locate" in run.stderr or \
            "Can't find a source" in run.stderr else "check that Debian's mirror is reachable"
        raise SetupError(f"`apt-get download {spec}` failed: {' / '.join(tail)}; {hint}")
    debs = list(Path(dest).glob(f"{package}_*.deb"))
    if len(debs) != 1:
        raise SetupError(f"`apt-get download {spec}` left {debs}, expected one .deb")
    return debs[0]


def deb_members(deb, wanted, out):
    """Extracts the wanted paths from a .deb's data archive into `out` (dpkg-deb -x)."""
    with tempfile.TemporaryDirectory() as tmp:
        run = subprocess.run(["dpkg-deb", "-x", str(deb), tmp], capture_output=True, text=True)
        if run.returncode != 0:
            raise SetupError(f"dpkg-deb -x {deb.name} failed: {run.stderr.strip()}")
        got = []
        for inner, name in wanted(Path(tmp)):
            shutil.copyfile(Path(tmp) / inner, out / name)
            got.append(name)
        return got


# libcgal-demo ships its demo data as a tarball; these OFF meshes are taken from it.
CGAL_DATA = "usr/share/doc/libcgal-dev/data.tar.gz"
CGAL_OFF = ["armadillo.off", "ChineseDragon-10kv.off", "refined_elephant.off"]


def cgal_members(root):
    """The OFF meshes named in CGAL_OFF, out of libcgal-demo's data archive."""
    found = []
    with tarfile.open(root / CGAL_DATA) as tf:
        for name in CGAL_OFF:
            try:
                member = tf.getmember(f"data/meshes/{name}")
            except KeyError:
                continue
            (root / name).write_bytes(tf.extractfile(member).read())
            found.append((name, name))
    return found


def setup_meshes():
    """Fetches the mesh packages; a failure is reported and the rest goes on."""
    MESHES.mkdir(parents=True, exist_ok=True)
    for spec in MESH_DEBS:
        folder = MESHES / spec["package"]
        if marker_ok(folder):
            continue
        try:
            say(f"fetching meshes from Debian package {spec['package']}={spec['version']}")
            folder.mkdir(parents=True, exist_ok=True)
            with tempfile.TemporaryDirectory(dir=MESHES) as tmp:
                deb = apt_download(spec["package"], spec["version"], tmp)
                verify(deb, spec["sha256"], f"{spec['package']}={spec['version']}")
                if spec["package"] == "libcgal-demo":
                    wanted = cgal_members
                else:
                    wanted = lambda _root, m=spec["members"]: m  # noqa: E731
                names = deb_members(deb, wanted, folder)
            if not names:
                raise SetupError(f"{spec['package']} held none of the expected meshes")
            write_marker(folder, names)
        except (SetupError, OSError) as e:
            say(f"warning: meshes from {spec['package']} unavailable: {e}")


def download(url, dest):
    """Fetches one registry file over HTTPS."""
    import urllib.request
    try:
        with urllib.request.urlopen(url, timeout=120) as r, open(dest, "wb") as f:
            shutil.copyfileobj(r, f)
    except OSError as e:
        raise SetupError(f"cannot download {url}: {e}; check that the registry is reachable") from e


def setup_photometry():
    """Fetches the goniodiagram files; a failure is reported and the rest goes on."""
    if marker_ok(PHOTOMETRY):
        return
    PHOTOMETRY.mkdir(parents=True, exist_ok=True)
    names = []
    for spec in PHOTOMETRY_ARCHIVES:
        try:
            say(f"fetching goniodiagram files from {spec['what']}")
            with tempfile.TemporaryDirectory(dir=PHOTOMETRY) as tmp:
                archive = Path(tmp) / "archive.tar.gz"
                download(spec["url"], archive)
                verify(archive, spec["sha256"], spec["what"])
                with tarfile.open(archive) as tf:
                    for inner, name in spec["members"]:
                        (PHOTOMETRY / name).write_bytes(tf.extractfile(tf.getmember(inner)).read())
                        names.append(name)
        except (SetupError, OSError, KeyError) as e:
            say(f"warning: goniodiagram files from {spec['what']} unavailable: {e}")
    if names:
        write_marker(PHOTOMETRY, sorted(names))


def fetch_deb(spec, keep=True):
    """The pinned .deb of `spec` (package, version, sha256), checked; kept in .cache/debs/
    when `keep`, so that steps sharing a package download it once. Returns its path (in a
    temporary folder the caller removes when not kept)."""
    name = f"{spec['package']}_{spec['version'].replace(':', '%3a')}_all.deb"
    kept = DEBS / name
    if kept.exists() and sha256_of(kept) == spec["sha256"]:
        return kept
    DEBS.mkdir(parents=True, exist_ok=True)
    size = f" ({spec['size_mb']} MB)" if "size_mb" in spec else ""
    say(f"downloading Debian package {spec['package']}={spec['version']}{size}")
    tmp = Path(tempfile.mkdtemp(dir=DEBS))
    deb = apt_download(spec["package"], spec["version"], tmp)
    verify(deb, spec["sha256"], f"{spec['package']}={spec['version']}")
    if not keep:
        return deb
    os.replace(deb, kept)
    shutil.rmtree(tmp, ignore_errors=True)
    return kept


def deb_extract(deb, wanted, out):
    """Extracts members of a .deb's data archive (ar, then tar: python's own readers, so no
    dpkg is needed and a large package is streamed, never unpacked whole). `wanted` maps a
    path inside the package to a name under `out`; returns the names written. A wanted
    member the package does not hold is an error naming it."""
    import lzma  # noqa: F401  (tarfile needs it for data.tar.xz; fail here with its name)
    with open(deb, "rb") as f:
        if f.read(8) != b"!<arch>\n":
            raise SetupError(f"{deb.name} is not a Debian package (no ar header)")
        while True:
            header = f.read(60)
            if len(header) < 60:
                raise SetupError(f"{deb.name} holds no data.tar archive")
            member = header[:16].decode().strip().rstrip("/")
            size = int(header[48:58].decode().strip())
            if member.startswith("data.tar"):
                break
            f.seek(size + (size & 1), 1)
        if member.endswith(".zst"):
            raise SetupError(f"{deb.name}: {member} is zstd-compressed, which python's tarfile "
                             "cannot read")
        got, left = [], dict(wanted)
        with tarfile.open(fileobj=f, mode="r|*") as tf:
            for info in tf:
                inner = info.name.removeprefix("./")
                if inner in left and info.isfile():
                    dest = out / left.pop(inner)
                    dest.parent.mkdir(parents=True, exist_ok=True)
                    with tf.extractfile(info) as src, open(dest, "wb") as dst:
                        shutil.copyfileobj(src, dst)
                    got.append(str(dest.relative_to(out)))
                    if not left:
                        break
    if left:
        raise SetupError(f"{deb.name} does not hold {sorted(left)}")
    return got


def setup_hdr():
    """Fetches the HDR maps; a failure is reported and the rest goes on."""
    if marker_ok(HDR):
        return
    spec = HDR_DEB
    try:
        say(f"fetching HDR maps from Debian package {spec['package']}={spec['version']} (31 MB)")
        HDR.mkdir(parents=True, exist_ok=True)
        deb = fetch_deb(spec)
        members = {f"{spec['folder']}/{m}": m for m in spec["members"]}
        names = deb_extract(deb, members, HDR)
        write_marker(HDR, names)
    except (SetupError, OSError) as e:
        say(f"warning: HDR maps unavailable: {e}")


def setup_assimp():
    """The Khronos glTF sample models; a failure is reported and the rest goes on."""
    folder = SCENES / "assimp"
    if marker_ok(folder):
        return
    spec = ASSIMP_DEB
    try:
        say(f"fetching glTF sample models from Debian package {spec['package']}="
            f"{spec['version']} (21 MB)")
        folder.mkdir(parents=True, exist_ok=True)
        deb = fetch_deb(spec)
        names = deb_extract(deb, dict(spec["members"]), folder)
        write_marker(folder, names)
    except (SetupError, OSError) as e:
        say(f"warning: the engine and clearcoat scenes are unavailable: {e}")


def setup_cornell():
    """The Cornell box of blender-data's cornell.pov, converted to OBJ + MTL; a failure is
    reported and the rest goes on."""
    folder = SCENES / "cornell"
    if marker_ok(folder):
        return
    try:
        say("fetching cornell.pov (CC-BY 3.0) from Debian package "
            f"{HDR_DEB['package']}={HDR_DEB['version']} and converting it")
        folder.mkdir(parents=True, exist_ok=True)
        deb = fetch_deb(HDR_DEB)
        names = deb_extract(deb, {CORNELL_POV: "cornell.pov"}, folder)
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        sys.dont_write_bytecode = True  # no __pycache__ in scripts/
        import pov_cornell
        try:
            names += pov_cornell.convert(folder / "cornell.pov", folder / "cornell.obj")
        except pov_cornell.PovError as e:
            raise SetupError(str(e)) from e
        write_marker(folder, names)
    except (SetupError, OSError) as e:
        say(f"warning: the cornell scene is unavailable: {e}")


def deb_installed(package):
    """The installed version of a Debian package, or None."""
    try:
        run = subprocess.run(["dpkg-query", "-W", "-f", "${Status} ${Version}", package],
                             capture_output=True, text=True)
    except OSError:
        return None
    words = run.stdout.split()
    return words[-1] if run.returncode == 0 and "installed" in words[:3] else None


def setup_chromium():
    """Installs the pinned headless Chromium (root needed); a failure is reported and the
    rest goes on (the browser test then skips, or fails under COHERENT_REQUIRE_BROWSER)."""
    if all(deb_installed(d["package"]) == d["version"] for d in CHROMIUM_DEBS):
        return
    try:
        if platform.machine() not in ("x86_64", "AMD64"):
            raise SetupError(f"no pinned chromium-headless-shell for {platform.machine()} "
                             "(the pins are amd64 packages)")
        if os.geteuid() != 0:
            raise SetupError("installing a Debian package needs root: run "
                             "`sudo python3 scripts/native.py chromium`")
        version = CHROMIUM_DEBS[-1]["version"]
        say(f"installing Debian's chromium-headless-shell={version} (86 MB download) with "
            "apt-get")
        with tempfile.TemporaryDirectory() as tmp:
            debs = []
            for spec in CHROMIUM_DEBS:
                deb = apt_download(spec["package"], spec["version"], tmp)
                verify(deb, spec["sha256"], f"{spec['package']}={spec['version']}")
                debs.append(f"./{deb.name}")
            env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
            run = subprocess.run(["apt-get", "install", "-y", "-q", "--no-install-recommends",
                                  *debs], cwd=tmp, env=env, capture_output=True, text=True)
            if run.returncode != 0:
                tail = (run.stderr or run.stdout).strip().splitlines()[-3:]
                raise SetupError(f"`apt-get install` of the Chromium packages failed: "
                                 f"{' / '.join(tail)}")
    except (SetupError, OSError) as e:
        say(f"warning: chromium-headless-shell unavailable: {e}")


def setup_mitsuba():
    """Unpacks the pinned Mitsuba and Dr.Jit wheels into .native/mitsuba/site/ and installs
    the pinned libllvm22 (root needed); a failure is reported and the rest goes on (the
    exporter's tests then skip, or fail under COHERENT_REQUIRE_PEER, and `peers` says so)."""
    folder = NATIVE / "mitsuba"
    try:
        if platform.machine() not in ("x86_64", "AMD64") or sys.platform != "linux":
            raise SetupError(f"no pinned Mitsuba for {sys.platform}/{platform.machine()} "
                             "(the pins are x86-64 Linux wheels)")
        if not marker_ok(folder):
            say("fetching Mitsuba 3.9.1 and Dr.Jit 1.5.0 (PyPI wheels, 68 MB, pinned by "
                "sha256) into .native/mitsuba")
            downloads = NATIVE / "downloads"
            downloads.mkdir(parents=True, exist_ok=True)
            site = folder / "site"
            if site.exists():
                shutil.rmtree(site)
            site.mkdir(parents=True)
            for spec in MITSUBA_WHEELS:
                wheel = downloads / spec["file"]
                if not wheel.exists() or sha256_of(wheel) != spec["sha256"]:
                    with tempfile.TemporaryDirectory(dir=downloads) as tmp:
                        pip_download(spec["requirement"], MITSUBA_PIP_ARGS, tmp,
                                     hint="or leave the peer out (the `peers` experiment "
                                          "then reports it missing)")
                        got = list(Path(tmp).iterdir())
                        if [p.name for p in got] != [spec["file"]]:
                            raise SetupError(f"pip served {[p.name for p in got]}, not the "
                                             f"pinned {spec['file']}")
                        verify(got[0], spec["sha256"], spec["requirement"])
                        os.replace(got[0], wheel)
                verify(wheel, spec["sha256"], spec["requirement"])
                # A wheel is a zip of the installed tree: unpacked, it imports as installed.
                with zipfile.ZipFile(wheel) as zf:
                    zf.extractall(site)
            versions = {s["requirement"].split("==")[0]: s["requirement"].split("==")[1]
                        for s in MITSUBA_WHEELS}
            (folder / "VERSIONS.json").write_text(json.dumps(versions, indent=1) + "\n")
            write_marker(folder, ["VERSIONS.json", "site/mitsuba/__init__.py",
                                  "site/drjit/__init__.py"])
        if deb_installed(LLVM_DEB["package"]) != LLVM_DEB["version"]:
            if os.geteuid() != 0:
                raise SetupError("installing Debian's libllvm22 needs root: run "
                                 "`sudo python3 scripts/native.py mitsuba`")
            say(f"installing Debian's libllvm22={LLVM_DEB['version']} (29 MB) with apt-get")
            with tempfile.TemporaryDirectory() as tmp:
                deb = apt_download(LLVM_DEB["package"], LLVM_DEB["version"], tmp)
                verify(deb, LLVM_DEB["sha256"], f"libllvm22={LLVM_DEB['version']}")
                env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
                run = subprocess.run(["apt-get", "install", "-y", "-q",
                                      "--no-install-recommends", f"./{deb.name}"],
                                     cwd=tmp, env=env, capture_output=True, text=True)
                if run.returncode != 0:
                    tail = (run.stderr or run.stdout).strip().splitlines()[-3:]
                    raise SetupError(f"`apt-get install` of libllvm22 failed: "
                                     f"{' / '.join(tail)}")
        if not Path(LLVM_DEB["library"]).exists():
            raise SetupError(f"libllvm22 is installed but {LLVM_DEB['library']} is missing")
    except (SetupError, OSError, zipfile.BadZipFile) as e:
        say(f"warning: the peer renderer Mitsuba is unavailable: {e}")


def setup_dungeon():
    """The castle dungeon level (a 257 MB package, not kept once extracted); a failure is
    reported and the rest goes on."""
    folder = SCENES / "dungeon"
    if marker_ok(folder):
        return
    spec = DUNGEON_DEB
    deb = None
    try:
        say("fetching the castle dungeon glTF level (CC0) from Debian package "
            f"{spec['package']}={spec['version']}")
        folder.mkdir(parents=True, exist_ok=True)
        deb = fetch_deb(spec, keep=False)
        gltf = f"{DUNGEON_LEVEL}/level-dungeon.gltf"
        names = deb_extract(deb, {gltf: "level-dungeon.gltf"}, folder)
        # Then what the glTF refers to: its buffers and images.
        doc = json.loads((folder / "level-dungeon.gltf").read_text())
        uris = [b["uri"] for b in doc.get("buffers", []) if "uri" in b]
        uris += [i["uri"] for i in doc.get("images", []) if "uri" in i]
        refs = {f"{DUNGEON_LEVEL}/{u}": u for u in uris if not u.startswith("data:")}
        names += deb_extract(deb, refs, folder)
        write_marker(folder, names)
    except (SetupError, OSError, ValueError, KeyError) as e:
        say(f"warning: the dungeon scene is unavailable: {e}")
    finally:
        if deb is not None and deb.parent != DEBS:
            shutil.rmtree(deb.parent, ignore_errors=True)


def main(argv):
    default = {"embree", "meshes", "photometry", "hdr", "assimp", "cornell", "chromium",
               "mitsuba"}
    steps = default | {"dungeon"}
    what = set(argv) or default
    unknown = what - steps
    if unknown:
        say(f"unknown step(s) {sorted(unknown)}; steps are: {' '.join(sorted(steps))}")
        return 2
    status = 0
    if "embree" in what:
        try:
            setup_embree()
        except (SetupError, OSError) as e:
            say(f"error: Embree set-up failed: {e}")
            say("the embree backend stays unavailable; everything else still builds and runs")
            status = 1
    if "meshes" in what:
        setup_meshes()
    if "photometry" in what:
        setup_photometry()
    if "hdr" in what:
        setup_hdr()
    if "assimp" in what:
        setup_assimp()
    if "cornell" in what:
        setup_cornell()
    if "chromium" in what:
        setup_chromium()
    if "mitsuba" in what:
        setup_mitsuba()
    if "dungeon" in what:
        setup_dungeon()
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
