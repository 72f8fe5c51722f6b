"""The other platforms' half of scripts/package: cross-builds with `zig cc` the wheel of Windows x64 or macOS
(arm64, x86-64) from the Linux wheel, whose Python files and metadata it keeps.

    python3 scripts/package_platform.py PLATFORM LINUX_WHEEL BUILD_DIR OUT_DIR   (PLATFORM: a key of PLATFORMS)

Design: meson stays the one description of the build. A native `meson setup` (baselines off, C tests on) is
introspected for each target's sources and its own -D/-I/-f flags; the objects are compiled for the platform by
scripts/zcc with $OPDEFORM_ZIG_TARGET, linked with that platform's static CHOLMOD (scripts/package-cholmod) and
scipy-openblas32's library for that platform (its wheel, fetched by scripts/setup-package). Python's headers are
3.11's with scripts/cross/pyconfig.h (the limited API of 3.11). Windows: `_core.pyd` imports python3.dll only
(an import library made by zig's dlltool from 3.11's python3.dll exports: a symbol outside 3.11's stable ABI
fails to link) and exports PyInit__core alone (PyMODINIT_FUNC is the one dllexport); OpenBLAS's DLL lies next
to it under a hashed name (no clash with numpy's or SciPy's copy in the same process). The C unit tests are
linked as test_core.exe for wine (tests/test_platforms.py). macOS: `_core.abi3.so`, `-undefined
dynamic_lookup` (no libpython), every symbol hidden but PyInit__core, OpenBLAS's dylib unmodified (its
signature stays valid) in opdeform.libs/, found through the rpath @loader_path/../opdeform.libs.
"""

import base64
import concurrent.futures
import hashlib
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CACHE = os.path.join(os.path.expanduser("~"), ".cache", "opdeform")
# wheel platform tag: (zig target, Blender's manifest platform)
PLATFORMS = {"win_amd64": ("x86_64-windows-gnu", "windows-x64"),
             "macosx_11_0_arm64": ("aarch64-macos.11.0", "macos-arm64"),
             "macosx_10_13_x86_64": ("x86_64-macos.10.13", "macos-x64")}
LINUX_MANIFEST_PLATFORM = "linux-x64"
PYTHON3_DLL = os.path.join(CACHE, "wine", "py3.11", "python3.dll")  # scripts/setup-wine: 3.11's stable ABI
FLAG = re.compile(r"^(-D|-I|-std=|-O|-fno-math-errno|-fvisibility)")


def run(args, **kw):
    proc = subprocess.run(args, capture_output=True, text=True, **kw)
    if proc.returncode != 0:
        sys.exit(f"package: {' '.join(map(str, args[:6]))} ... failed:\n{proc.stdout[-3000:]}{proc.stderr[-3000:]}")
    return proc.stdout


def pe_exports(path):
    """The names a PE DLL exports (its export directory), in table order."""
    data = open(path, "rb").read()
    pe = struct.unpack_from("<I", data, 0x3C)[0]
    sections = struct.unpack_from("<H", data, pe + 6)[0]
    optional = pe + 24
    export_rva = struct.unpack_from("<I", data, optional + 112)[0]  # PE32+ data directory 0
    table = optional + struct.unpack_from("<H", data, pe + 20)[0]

    def offset(rva):
        for k in range(sections):
            virt_size, virt, _, raw = struct.unpack_from("<IIII", data, table + 40 * k + 8)
            if virt <= rva < virt + max(virt_size, 1):
                return rva - virt + raw
        raise ValueError(f"{path}: RVA {rva:#x} in no section")

    if export_rva == 0:
        return []
    count, _, names = struct.unpack_from("<III", data, offset(export_rva) + 24)  # NumberOfNames, ..., AddressOfNames
    names = offset(names)
    return [data[offset(rva):data.index(b"\0", offset(rva))].decode()
            for rva in struct.unpack_from(f"<{count}I", data, names)]


def import_library(dll, name, out_dir):
    """An import library for the DLL's exports, loading it as `name` (zig's llvm-dlltool)."""
    stem = os.path.splitext(name)[0]
    definition = os.path.join(out_dir, stem + ".def")
    with open(definition, "w") as f:
        f.write(f"LIBRARY {name}\nEXPORTS\n" + "".join(f"    {symbol}\n" for symbol in pe_exports(dll)))
    lib = os.path.join(out_dir, stem + ".lib")
    run([tools_python(), "-m", "ziglang", "dlltool", "-m", "i386:x86-64", "-d", definition, "-l", lib])
    return lib


def tools_python():
    return os.path.join(os.environ.get("OPDEFORM_PACKAGE_VENV", os.path.join(CACHE, "package-venv")), "bin", "python")


def openblas_dir(platform):
    """scipy-openblas32's lib/ folder for the platform (its wheel, unpacked by scripts/setup-package)."""
    return os.path.join(CACHE, "openblas", platform, "scipy_openblas32", "lib")


def cross_python_include(build):
    """CPython 3.11's headers with scripts/cross/pyconfig.h in place of the build machine's."""
    include = run([tools_python(), "-c", "import sysconfig; print(sysconfig.get_paths()['include'])"]).strip()
    if not include.endswith("python3.11"):
        sys.exit(f"package: the package venv's Python headers are {include}, not 3.11's (the limited API's)")
    out = os.path.join(build, "python-include")
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(include, out)
    shutil.copy(os.path.join(ROOT, "scripts", "cross", "pyconfig.h"), os.path.join(out, "pyconfig.h"))
    return out


def meson_targets(build):
    """meson's targets (introspected from a native set-up with the C tests on and the baselines off)."""
    native = os.path.join(build, "introspect")
    if not os.path.exists(os.path.join(native, "build.ninja")):
        run(["meson", "setup", native, "--buildtype=release", "-Dbaselines=false", "-Dtests=true"], cwd=ROOT)
    else:  # ninja's regeneration rule: set up again where a meson.build changed (a new source file)
        run(["ninja", "-C", native, "build.ninja"], cwd=ROOT)
    targets = json.loads(run(["meson", "introspect", "--targets", native]))
    return {t["name"].split(".")[0]: (native, t["target_sources"]) for t in targets
            if t["type"] in ("static library", "shared module", "executable")}


def compile_commands(target, native, cholmod, python_include, obj_dir):
    """(object, zig cc arguments) for each C source of a meson target, with that target's flags."""
    for group in (g for g in target if g.get("sources")):  # the compiler's groups (not the linker's)
        flags = [f for f in group["parameters"] if FLAG.match(f)]
        includes = []
        for f in flags:
            path = os.path.realpath(os.path.join(native, f[2:])) if f.startswith("-I") else ""
            if path.startswith(ROOT + os.sep) and os.path.isdir(path):
                includes.append("-I" + path)
        flags = [f for f in flags if not f.startswith("-I")] + includes
        flags += ["-I" + os.path.join(cholmod, "include"), "-I" + python_include, "-fvisibility=hidden"]
        for source in group["sources"]:
            obj = os.path.join(obj_dir, os.path.relpath(source, ROOT).replace(os.sep, "_") + ".o")
            yield obj, [*flags, "-c", source, "-o", obj]


def compile_all(commands, zig_target):
    env = dict(os.environ, OPDEFORM_ZIG_TARGET=zig_target)
    zcc = os.path.join(ROOT, "scripts", "zcc")
    with concurrent.futures.ThreadPoolExecutor(os.cpu_count() or 2) as pool:
        list(pool.map(lambda c: run([zcc, *c[1]], env=env), commands))
    return [obj for obj, _ in commands]


def link(zig_target, objects, libs, out, args=()):
    env = dict(os.environ, OPDEFORM_ZIG_TARGET=zig_target)
    run([os.path.join(ROOT, "scripts", "zcc"), *args, "-o", out, *objects, *libs], env=env)


def hashed(path):
    """libscipy_openblas-<8 hex digits of its sha256>.<ext>, as auditwheel names the Linux copy."""
    stem, ext = os.path.splitext(os.path.basename(path))
    return f"{stem}-{hashlib.sha256(open(path, 'rb').read()).hexdigest()[:8]}{ext}"


def build_windows(build, zig_target, objects, test_objects, cholmod):
    """_core.pyd and OpenBLAS's DLL (package files), and test_core.exe beside a copy of that DLL."""
    dll = os.path.join(openblas_dir("win_amd64"), "libscipy_openblas.dll")
    name = hashed(dll)
    libs = [os.path.join(cholmod, "lib", "libcholmod.a"), import_library(dll, name, build)]
    core = os.path.join(build, "_core.pyd")
    link(zig_target, objects["core"] + objects["binding"], [*libs, import_library(PYTHON3_DLL, "python3.dll", build)],
         core, ["-shared", "-s"])
    link(zig_target, objects["core"] + test_objects, libs, os.path.join(build, "test_core.exe"), ["-s"])
    shutil.copy(dll, os.path.join(build, name))
    return {"opdeform/_core.pyd": core, "opdeform/" + name: dll}


def build_macos(build, platform, zig_target, objects, cholmod):
    dylib = os.path.join(openblas_dir(platform), "libscipy_openblas.dylib")
    core = os.path.join(build, "_core.abi3.so")
    link(zig_target, objects["core"] + objects["binding"], [os.path.join(cholmod, "lib", "libcholmod.a"), dylib],
         core, ["-shared", "-undefined", "dynamic_lookup", "-Wl,-rpath,@loader_path/../opdeform.libs"])
    return {"opdeform/_core.abi3.so": core, "opdeform.libs/libscipy_openblas.dylib": dylib}


def record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}\n"


def write_wheel(linux_wheel, platform, files, out):
    """The Linux wheel's Python files and metadata, with the platform's compiled files, tag, WHEEL and RECORD."""
    name = re.sub(r"-cp311-abi3-.*\.whl$", f"-cp311-abi3-{platform}.whl", os.path.basename(linux_wheel))
    path = os.path.join(out, name)
    record = []
    with zipfile.ZipFile(linux_wheel) as src, zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as dst:
        dist_info = next(n.split("/")[0] for n in src.namelist() if n.split("/")[0].endswith(".dist-info"))
        members = [(n, src.read(n)) for n in src.namelist() if not n.endswith("/")
                   and not n.startswith("opdeform.libs/") and n != "opdeform/_core.abi3.so"
                   and n not in (f"{dist_info}/RECORD", f"{dist_info}/WHEEL")]
        wheel = re.sub(r"^Tag: .*$", f"Tag: cp311-abi3-{platform}", src.read(f"{dist_info}/WHEEL").decode(), flags=re.M)
        members.append((f"{dist_info}/WHEEL", wheel.encode()))
        members[len(members) - 1:len(members) - 1] = [(n, open(p, "rb").read()) for n, p in files.items()]
        for member, data in members:
            dst.writestr(member, data)
            record.append(record_line(member, data))
        dst.writestr(f"{dist_info}/RECORD", "".join(record) + f"{dist_info}/RECORD,,\n")
    print(f"package: {path} ({os.path.getsize(path) // 1024} KiB)")
    return path


def main(platform, linux_wheel, build_root, out):
    zig_target = PLATFORMS[platform][0]
    build = os.path.join(os.path.realpath(build_root), platform)
    obj_dir = os.path.join(build, "obj")
    os.makedirs(obj_dir, exist_ok=True)
    cholmod = os.path.join(CACHE, f"cholmod-suitesparse-5.12.0-{platform}")
    run([os.path.join(ROOT, "scripts", "package-cholmod"), cholmod],
        env=dict(os.environ, OPDEFORM_ZIG_TARGET=zig_target, OPDEFORM_OPENBLAS_DIR=openblas_dir(platform)))
    targets = meson_targets(os.path.realpath(build_root))
    python_include = cross_python_include(build)
    sources = {"core": [t for name, t in targets.items() if name.startswith("od_")],
               "binding": [targets["_core"]], "tests": [targets["test_core"]]}
    objects = {kind: compile_all([c for native, group in found
                                  for c in compile_commands(group, native, cholmod, python_include, obj_dir)],
                                 zig_target)
               for kind, found in sources.items() if kind != "tests" or platform == "win_amd64"}
    if platform == "win_amd64":
        files = build_windows(build, zig_target, objects, objects["tests"], cholmod)
    else:
        files = build_macos(build, platform, zig_target, objects, cholmod)
    write_wheel(linux_wheel, platform, files, out)


if __name__ == "__main__":
    main(*sys.argv[1:5])
