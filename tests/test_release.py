"""scripts/release (issue 25): the sdist, every wheel and the Blender packages in one folder, checked (twine
check --strict, tags, sizes, the sdist builds here); then a new user's path: the wheel alone pip-installed into
an empty venv (numpy from the index), and every command of README.md run there under both names, `opdeform`
and `python -m opdeform`: each works, or (batch, render without their extras) names the extra README documents
and exits 2."""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
TOOLS = Path.home() / ".cache" / "opdeform" / "package-venv" / "bin" / "python"  # scripts/setup-package
# What each README command needs beyond the wheel: None, or the extra its message names
EXTRA = {"bake": None, "report": None, "batch": "batch", "render": "plot"}


@pytest.fixture(scope="module")
def release(tmp_path_factory):
    if not TOOLS.exists():
        pytest.skip("the packaging venv is missing (scripts/setup-package)")
    base = tmp_path_factory.mktemp("release")
    env = dict(os.environ, PACKAGE_BUILD_DIR=str(base / "package-build"), RELEASE_BUILD_DIR=str(base / "build"))
    done = subprocess.run([str(ROOT / "scripts" / "release"), str(base / "out")], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=1800)
    return done, base / "out"


def test_the_release_is_checked(release):
    done, out = release
    assert done.returncode == 0, done.stdout + done.stderr
    assert re.search(r"^release: ok: opdeform [\d.]+, the sdist and wheels for .*linux-x64.*; twine check --strict "
                     r"passed$", done.stdout, flags=re.M), done.stdout
    no_urls = "[project.urls]" not in (ROOT / "pyproject.toml").read_text()
    assert ("release: note: no project URLs" in done.stdout) == no_urls, done.stdout
    listed = sorted(line.split()[1] for line in (out / "SHA256SUMS").read_text().splitlines())
    assert listed == sorted(p.name for p in out.iterdir() if p.name != "SHA256SUMS")
    assert len([n for n in listed if n.endswith(".tar.gz")]) == 1 and [n for n in listed if n.endswith(".whl")]


def readme_commands():
    """The opdeform command lines of README.md's shell blocks, without their comments."""
    text = (ROOT / "README.md").read_text()
    lines = [line.split("#")[0].strip() for block in re.findall(r"```sh\n(.*?)```", text, flags=re.S)
             for line in block.splitlines()]
    return [line.split() for line in lines if line.startswith(("python -m opdeform ", "opdeform "))]


@pytest.fixture(scope="module")
def venv(release, tmp_path_factory):
    """An empty venv with the release's Linux wheel pip-installed (and numpy, its one dependency)."""
    done, out = release
    assert done.returncode == 0, done.stdout
    where = tmp_path_factory.mktemp("venv")
    subprocess.run(["python3", "-m", "venv", str(where)], check=True, timeout=120)
    wheel = next(out.glob("opdeform-*manylinux*.whl"))
    install = subprocess.run([str(where / "bin" / "python"), "-m", "pip", "install", "-q",
                              "--disable-pip-version-check", str(wheel)], capture_output=True, text=True, timeout=600)
    assert install.returncode == 0, install.stdout + install.stderr
    return where


def test_readme_commands_work_after_pip_install(venv, tmp_path):
    commands = readme_commands()
    assert sorted({c[c.index("opdeform") + 1] for c in commands}) == sorted(EXTRA), commands
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    text = (ROOT / "README.md").read_text()
    python = str(venv / "bin" / "python")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    for command in commands:
        args = command[command.index("opdeform") + 1:]
        args = ["examples/tail.toml" if a == "shots/*.toml" else str(tmp_path / "refs") if a == "refs/" else a
                for a in args]
        for name in ([python, "-m", "opdeform"], [str(venv / "bin" / "opdeform")]):
            done = subprocess.run(name + args, capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
            extra = EXTRA[args[0]]
            if extra is None:
                assert done.returncode == 0, (args, done.stdout, done.stderr)
            else:
                assert done.returncode == 2 and f'pip install "opdeform[{extra}]"' in done.stderr, (args, done.stderr)
                assert f'pip install "opdeform[{extra}]"' in text  # the extra is documented
    assert (tmp_path / "out" / "examples" / "tail" / "tail.pc2").exists()
    bake = subprocess.run([python, "-m", "opdeform", "bake", "examples/tail.toml", "--restart"], capture_output=True,
                          text=True, cwd=tmp_path, env=env, timeout=300)
    assert 'report.png not written: the plot needs matplotlib (pip install "opdeform[plot]")' in bake.stderr
    version = subprocess.run([str(venv / "bin" / "opdeform"), "--version"], capture_output=True, text=True, timeout=60)
    assert re.fullmatch(r"opdeform \d+\.\d+\.\d+\n", version.stdout), version.stdout
