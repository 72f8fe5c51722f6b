"""The checks of scripts/release on its folder, before anything is uploaded. Run by the packaging venv's Python
(twine, packaging, trove-classifiers: scripts/setup-package).

    python scripts/release_check.py RELEASE_DIR BUILD_DIR

- one sdist and at least one wheel, all of meson.build's version; `twine check --strict` passes on them
  (metadata, the description renders as the index will show it);
- every classifier is one the index accepts; every wheel's OS among them;
- every wheel tagged cp311-abi3 on a platform of PLATFORMS, its WHEEL file saying the same, one wheel a
  platform; each holds the console command, py.typed, the stubs and the licence;
- every file under the index's size limit (LIMIT_MB); sizes printed, SHA-256 in SHA256SUMS;
- every Blender extension zip carries only wheels that are, byte for byte, files of this release (what the
  extension ships is what the index serves);
- the sdist builds a wheel here (pip wheel, no build isolation, the system's CHOLMOD) whose module steps a bar.
Prints one line a file and `release: ok ...`, or each problem and exits 1. Project URLs are not checked: the
project has none yet; while the metadata has none, a note says so.
"""

import glob
import hashlib
import json
import os
import subprocess
import sys
import tarfile
import zipfile

from packaging.utils import parse_sdist_filename, parse_wheel_filename
from trove_classifiers import classifiers as KNOWN_CLASSIFIERS

LIMIT_MB = 100  # the package index's default limit a file
# a wheel's platform tag -> (the extension's platform, the classifier of its OS)
PLATFORMS = {"manylinux_2_28_x86_64": ("linux-x64", "Operating System :: POSIX :: Linux"),
             "win_amd64": ("windows-x64", "Operating System :: Microsoft :: Windows"),
             "macosx_11_0_arm64": ("macos-arm64", "Operating System :: MacOS"),
             "macosx_10_13_x86_64": ("macos-x64", "Operating System :: MacOS"),
             "macosx_11_0_x86_64": ("macos-x64", "Operating System :: MacOS")}
IN_WHEEL = ("opdeform/py.typed", "opdeform/_core.pyi", "opdeform/cli.py")
# the project has no public address yet: said, not failed, until a maintainer adds them
NO_URLS = "no project URLs: add [project.urls] to pyproject.toml before the first upload (docs/packaging.md)"
ENTRY_POINT = "opdeform = opdeform.cli:main"
SMOKE = """import numpy as np, opdeform
n = 10
c = np.c_[(np.arange(n) + 0.5) * 0.1, np.zeros(n), np.zeros(n)]
g = opdeform.Graph(c, np.tile([0.05, 0.1, 0.1], (n, 1)), np.c_[np.arange(n - 1), np.arange(1, n)])
sim = opdeform.Simulation(g, stiffness=1e9, dt=1 / 60)
sim.add_position_constraint((0.0, 0.0, 0.0))
sim.step(10)
assert sim.positions[-1][2] < 0, sim.positions[-1]
"""


def meson_version():
    info = subprocess.run(["meson", "introspect", "--projectinfo", "meson.build"], capture_output=True, text=True,
                          check=True)
    return json.loads(info.stdout)["version"]


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def wheel_problems(path, version, classifiers):
    """What is wrong with one wheel, and its platform (a key of PLATFORMS, or None)."""
    name, wheel_version, _, tags = parse_wheel_filename(os.path.basename(path))
    problems = [] if str(wheel_version) == version else [f"{path}: version {wheel_version}, meson.build {version}"]
    known = sorted({t.platform for t in tags} & set(PLATFORMS))
    if {(t.interpreter, t.abi) for t in tags} != {("cp311", "abi3")} or not known:
        problems.append(f"{path}: tags {sorted(map(str, tags))}: want cp311-abi3 on one of {sorted(PLATFORMS)}")
    info = f"{name}-{wheel_version}.dist-info"
    with zipfile.ZipFile(path) as z:
        names = z.namelist()
        wheel_file = z.read(f"{info}/WHEEL").decode()
        entry_points = z.read(f"{info}/entry_points.txt").decode() if f"{info}/entry_points.txt" in names else ""
    stated = {line.split(":", 1)[1].strip() for line in wheel_file.splitlines() if line.startswith("Tag:")}
    if stated != {str(t) for t in tags}:
        problems.append(f"{path}: WHEEL says {sorted(stated)}, the name {sorted(map(str, tags))}")
    if "Root-Is-Purelib: false" not in wheel_file:
        problems.append(f"{path}: WHEEL does not say Root-Is-Purelib: false")
    problems += [f"{path}: no {n}" for n in (*IN_WHEEL, f"{info}/licenses/COPYING") if n not in names]
    if ENTRY_POINT not in entry_points:
        problems.append(f"{path}: no console command ({ENTRY_POINT!r} not in entry_points.txt)")
    problems += [f"{path}: {PLATFORMS[p][1]!r} is not among the classifiers" for p in known
                 if PLATFORMS[p][1] not in classifiers]
    return problems, known[0] if known else None


def sdist_metadata(path, field):
    """The values of a metadata field (Classifier, Project-URL) in the sdist's PKG-INFO."""
    with tarfile.open(path) as tar:
        member = next(m for m in tar.getmembers() if m.name.count("/") == 1 and m.name.endswith("/PKG-INFO"))
        header = tar.extractfile(member).read().decode().split("\n\n", 1)[0]
    return [line.split(":", 1)[1].strip() for line in header.splitlines() if line.startswith(field + ":")]


def extension_problems(release, wheels):
    """Each extension zip's wheels must be files of this release, byte for byte."""
    digests = {sha256(w) for w in wheels}
    problems = []
    for path in sorted(glob.glob(os.path.join(release, "opdeform_blender-*.zip"))):
        if "-legacy" in os.path.basename(path):  # the legacy zips vendor the wheel's files, not the wheel
            continue
        with zipfile.ZipFile(path) as z:
            inside = [n for n in z.namelist() if n.endswith(".whl")]
            problems += [] if inside else [f"{path}: carries no wheel"]
            problems += [f"{path}: {n} is not a wheel of this release" for n in inside
                         if hashlib.sha256(z.read(n)).hexdigest() not in digests]
    return problems


def sdist_builds(sdist, build):
    """Builds a wheel from the sdist here and steps a bar with it; the problems."""
    out = os.path.join(build, "from-sdist")
    subprocess.run(["rm", "-rf", out], check=True)
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
                           "--disable-pip-version-check", "-w", out, f"-Cbuild-dir={out}/meson", sdist],
                          capture_output=True, text=True)
    if done.returncode != 0:
        return [f"{sdist}: does not build here:\n{done.stdout}{done.stderr}"]
    wheel = glob.glob(os.path.join(out, "*.whl"))[0]
    with zipfile.ZipFile(wheel) as z:
        z.extractall(os.path.join(out, "site"))
    env = dict(os.environ, PYTHONPATH=os.path.join(out, "site"))
    run = subprocess.run(["python3", "-c", SMOKE], capture_output=True, text=True, env=env, cwd=out)
    if run.returncode != 0:
        return [f"{sdist}: its wheel {os.path.basename(wheel)} does not run:\n{run.stderr}"]
    print(f"release: the sdist builds here ({os.path.basename(wheel)}) and steps a bar")
    return []


def file_problems(release):
    """Sizes (printed, checked against LIMIT_MB); writes SHA256SUMS."""
    files = sorted(p for p in glob.glob(os.path.join(release, "*")) if os.path.basename(p) != "SHA256SUMS")
    with open(os.path.join(release, "SHA256SUMS"), "w") as f:
        f.writelines(f"{sha256(p)}  {os.path.basename(p)}\n" for p in files)
    problems = []
    for path in files:
        mb = os.path.getsize(path) / 2 ** 20
        print(f"release: {os.path.basename(path)}  {mb:.2f} MB")
        if mb > LIMIT_MB and path.endswith((".whl", ".tar.gz")):
            problems.append(f"{path}: {mb:.0f} MB, over the index's {LIMIT_MB} MB")
    return problems


def main(release, build):
    version = meson_version()
    sdists = glob.glob(os.path.join(release, "opdeform-*.tar.gz"))
    wheels = sorted(glob.glob(os.path.join(release, "opdeform-*.whl")))
    if len(sdists) != 1 or not wheels:
        print(f"release: want one sdist and the wheels in {release}, found {sorted(os.listdir(release))}")
        return 1
    problems = [] if str(parse_sdist_filename(os.path.basename(sdists[0]))[1]) == version else \
        [f"{sdists[0]}: not version {version}"]
    classifiers = sdist_metadata(sdists[0], "Classifier")
    problems += [f"classifier {c!r} is not one the index accepts" for c in classifiers if c not in KNOWN_CLASSIFIERS]
    seen = {}
    for wheel in wheels:
        found, platform = wheel_problems(wheel, version, classifiers)
        problems += found + ([f"two wheels for {platform}: {seen[platform]}, {wheel}"] if platform in seen else [])
        seen[platform] = wheel
    twine = subprocess.run([sys.executable, "-m", "twine", "check", "--strict", *sdists, *wheels],
                           capture_output=True, text=True)
    problems += [] if twine.returncode == 0 else [f"twine check:\n{twine.stdout}{twine.stderr}"]
    problems += extension_problems(release, wheels) + file_problems(release) + sdist_builds(sdists[0], build)
    if problems:
        print("release: FAILED\n" + "\n".join(f"  {p}" for p in problems))
        return 1
    platforms = ", ".join(sorted(PLATFORMS[p][0] for p in seen if p))
    if not sdist_metadata(sdists[0], "Project-URL"):
        print(f"release: note: {NO_URLS}")
    print(f"release: ok: opdeform {version}, the sdist and wheels for {platforms}; twine check --strict passed")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
