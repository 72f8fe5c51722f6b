"""The add-on half of scripts/package: stages the Blender extension (the add-on's files with meson.build's
version stamped in, every platform's wheel under wheels/, listed in the manifest's `wheels`, and those wheels'
platforms in its `platforms`) for Blender's builder, and writes one legacy zip per platform (the same files under
opdeform_blender/, that platform's wheel's files vendored under vendor/).

    python3 scripts/package_addon.py PROJECTINFO_JSON STAGE_DIR OUT_DIR WHEEL...
    python3 scripts/package_addon.py --zip STAGE_DIR OUT_DIR   (no Blender builder: zip the staged extension)
"""

import json
import os
import re
import shutil
import sys
import tomllib
import zipfile

ADDON = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "addon", "opdeform_blender")
# a wheel's platform tag (its last part) -> Blender's platform name
BLENDER_PLATFORMS = {"win_amd64": "windows-x64", "macosx_11_0_arm64": "macos-arm64",
                     "macosx_10_13_x86_64": "macos-x64", "manylinux_2_28_x86_64": "linux-x64"}


def blender_platform(wheel_name):
    tag = wheel_name[:-len(".whl")].split("-")[-1].split(".")[-1]
    if tag not in BLENDER_PLATFORMS:
        sys.exit(f"package: the wheel {wheel_name} is for {tag}, not one of {sorted(BLENDER_PLATFORMS)}")
    return BLENDER_PLATFORMS[tag]


def stamped(rel, data, version, wheel_names):
    """The file's bytes, with meson.build's version in bl_info and the manifest, and in the manifest the wheels
    and their platforms."""
    platforms = ", ".join(f'"{blender_platform(w)}"' for w in wheel_names)
    wheels = ", ".join(f'"./wheels/{w}"' for w in wheel_names)
    stamps = {"__init__.py": [(r'("version":\s*)\([^)]*\)', r"\g<1>(" + version.replace(".", ", ") + ")")],
              "blender_manifest.toml": [(r'^(version\s*=\s*)"[^"]*"', rf'\g<1>"{version}"'),
                                        (r"^platforms\s*=.*$", f"platforms = [{platforms}]\nwheels = [{wheels}]")]}
    text = data.decode() if rel in stamps else None
    for pattern, repl in stamps.get(rel, []):
        text, count = re.subn(pattern, repl, text, count=1, flags=re.M)
        if count != 1:
            sys.exit(f"package: no {pattern!r} to stamp in {rel}")
    return data if text is None else text.encode()


def addon_files(version, wheel_names):
    for root, dirs, names in os.walk(ADDON):
        dirs[:] = sorted(d for d in dirs if d not in ("__pycache__", "vendor"))
        for name in sorted(names):
            if not name.endswith((".pyc", ".pyo")):
                path = os.path.join(root, name)
                rel = os.path.relpath(path, ADDON)
                yield rel, stamped(rel, open(path, "rb").read(), version, wheel_names)


def wheel_files(wheel):
    """The wheel's package files (opdeform/, opdeform.libs/), not its metadata."""
    with zipfile.ZipFile(wheel) as z:
        for name in z.namelist():
            if not name.split("/")[0].endswith(".dist-info") and not name.endswith("/"):
                yield name, z.read(name)


def folders(names):
    """Every folder above the names, parents first: the zip's folder entries."""
    return sorted({"/".join(name.split("/")[:k]) + "/" for name in names for k in range(1, name.count("/") + 1)})


def write_zip(path, files):
    """The zip with a folder entry for every folder: Blender's Install (and Install again, to update) removes
    an installed add-on's folder only when the zip names it, and without one extracted over the loaded module
    (Blender 3.4: a bus error, the compiled module truncated under the running process)."""
    files = list(files)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for folder in folders(rel for rel, _ in files):
            z.mkdir(folder.rstrip("/"))
        for rel, data in files:
            z.writestr(rel, data)
    print(f"package: {path} ({os.path.getsize(path) // 1024} KiB)")


def main(info_path, stage, out, wheels):
    version = json.load(open(info_path))["version"]
    if not re.fullmatch(r"\d+\.\d+\.\d+", version):
        sys.exit(f"package: meson.build's version {version!r} is not MAJOR.MINOR.PATCH (bl_info needs three numbers)")
    names = [os.path.basename(w) for w in wheels]
    shutil.rmtree(stage, ignore_errors=True)
    for rel, data in addon_files(version, names):
        os.makedirs(os.path.dirname(os.path.join(stage, rel)), exist_ok=True)
        open(os.path.join(stage, rel), "wb").write(data)
    os.makedirs(os.path.join(stage, "wheels"))
    for wheel, name in zip(wheels, names):
        shutil.copy(wheel, os.path.join(stage, "wheels", name))
        vendored = [("vendor/__init__.py", b'"""The opdeform wheel\'s files, vendored by scripts/package."""\n')]
        vendored += [("vendor/" + file, data) for file, data in wheel_files(wheel)]
        platform = blender_platform(name).replace("-", "_")
        write_zip(os.path.join(out, f"opdeform_blender-{version}-legacy-{platform}.zip"),
                  [("opdeform_blender/" + rel, data) for rel, data in [*addon_files(version, [name]), *vendored]])


def zip_stage(stage, out):
    manifest = tomllib.load(open(os.path.join(stage, "blender_manifest.toml"), "rb"))
    files = [(os.path.relpath(os.path.join(root, n), stage), open(os.path.join(root, n), "rb").read())
             for root, _, names in sorted(os.walk(stage)) for n in sorted(names)]
    for platform in manifest["platforms"]:
        write_zip(os.path.join(out, f"{manifest['id']}-{manifest['version']}-{platform.replace('-', '_')}.zip"), files)


if __name__ == "__main__":
    if sys.argv[1] == "--zip":
        zip_stage(*sys.argv[2:4])
    else:
        main(*sys.argv[1:4], sys.argv[4:])
