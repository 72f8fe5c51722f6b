"""scripts/package: the legacy zip installs and runs in Debian's Blender 3.4, the extension zip (manifest,
GPL-3.0-or-later) installs and runs in the bpy module (4.2+); both find their vendored compiled module, and a
damaged compiled module gives a clear message in the panel and in the operators' reports. The zips leave the
shape-matching baseline out and carry meson.build's version, which the add-on's sources repeat."""

import ast
import json
import subprocess
import tomllib
import zipfile

import pytest

from test_addon import BLENDER_TESTS, ROOT, host_env, host_missing, run_host

ADDON = ROOT / "addon" / "opdeform_blender"


@pytest.fixture(scope="module")
def packages(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    proc = subprocess.run([str(ROOT / "scripts" / "package"), str(out)], capture_output=True, text=True,
                          cwd=str(ROOT), timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    zips = {("legacy" if p.name.endswith("-legacy.zip") else "extension"): p for p in out.glob("*.zip")}
    assert set(zips) == {"legacy", "extension"}, zips
    return zips


def meson_version():
    proc = subprocess.run(["meson", "introspect", "--projectinfo", str(ROOT / "meson.build")], capture_output=True,
                          text=True, check=True, timeout=60)
    return json.loads(proc.stdout)["version"]


def bl_info_version(source):
    """bl_info["version"] read the way Blender reads it: statically, without running the file."""
    for node in ast.parse(source).body:
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", None) == "bl_info":
            return ".".join(map(str, ast.literal_eval(node.value)["version"]))
    return None


def test_zip_layout(packages):
    with zipfile.ZipFile(packages["legacy"]) as z:
        names = set(z.namelist())
        assert "opdeform_blender/__init__.py" in names
        assert "opdeform_blender/vendor/opdeform/_core.abi3.so" in names
        assert "bl_info" in z.read("opdeform_blender/__init__.py").decode()
    with zipfile.ZipFile(packages["extension"]) as z:
        names = set(z.namelist())
        assert {"blender_manifest.toml", "__init__.py", "vendor/opdeform/__init__.py",
                "vendor/opdeform/_core.abi3.so"} <= names
        manifest = z.read("blender_manifest.toml").decode()
        assert 'license = ["SPDX:GPL-3.0-or-later"]' in manifest and 'id = "opdeform_blender"' in manifest
        assert not any("__pycache__" in n for n in names)


def test_zips_leave_the_baseline_out(packages):
    for path in packages.values():
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
            assert not [n for n in names if "shape_matching" in n], names
            core = next(n for n in names if n.endswith("vendor/opdeform/_core.abi3.so"))
            assert b"ShapeMatching" not in z.read(core)


def test_versions_are_meson_builds(packages):
    """meson.build's project(version:) is the version: the add-on's bl_info and manifest repeat it (Blender
    reads both statically), and the zips are named and stamped with it."""
    version = meson_version()
    assert bl_info_version((ADDON / "__init__.py").read_text()) == version
    assert tomllib.loads((ADDON / "blender_manifest.toml").read_text())["version"] == version
    for kind, path in packages.items():
        assert path.name == f"opdeform_blender-{version}-{kind}.zip"
        prefix = "opdeform_blender/" if kind == "legacy" else ""
        with zipfile.ZipFile(path) as z:
            assert bl_info_version(z.read(prefix + "__init__.py").decode()) == version
            assert tomllib.loads(z.read(prefix + "blender_manifest.toml").decode())["version"] == version


def _broken_copy(path, tmp_path):
    """The same zip with a compiled module that cannot load (wrong bytes: another platform, a bad copy)."""
    out = tmp_path / path.name
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename.endswith("_core.abi3.so"):
                data = b"\x7fELF not really a shared object"
            dst.writestr(item, data)
    return out


@pytest.mark.parametrize("host,kind", [("blender", "legacy"), ("bpy", "extension")])
@pytest.mark.parametrize("expect", ["ok", "broken"])
def test_installs_and_runs(packages, host, kind, expect, tmp_path):
    why = host_missing(host)
    if why:
        pytest.skip(why)
    zip_path = packages[kind] if expect == "ok" else _broken_copy(packages[kind], tmp_path)
    user = tmp_path / "user"
    user.mkdir()
    env = host_env({"BLENDER_USER_SCRIPTS": str(user), "BLENDER_USER_RESOURCES": str(user)}, with_module=False)
    proc = run_host(host, BLENDER_TESTS / "check_package.py", [str(zip_path), kind, expect], env)
    assert proc.returncode == 0 and f"PACKAGE_OK {kind} {expect}" in proc.stdout, \
        proc.stdout[-4000:] + proc.stderr[-4000:]
