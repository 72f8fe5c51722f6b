"""The opdeform command (issue 25): --version, plain-text help under both names (``opdeform`` and ``python -m
opdeform``), progress with the time left on a terminal and nothing in a pipe (a farm's log), and a clear message
naming the extra when an optional package is missing: the bake still writes everything but its plot.
tests/test_release.py runs the README's commands after ``pip install`` of the wheel into an empty venv."""

import os
import pty
import re
import subprocess
import sys

import pytest

import opdeform
from opdeform import cli

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXAMPLE = os.path.join(ROOT, "examples", "tail.toml")


def spec_in(tmp_path, last=40):
    """examples/tail.toml with its output folder under tmp_path."""
    tmp_path.mkdir(exist_ok=True)
    text = open(EXAMPLE).read()
    text = re.sub(r'(?m)^folder = .*$', f'folder = "{tmp_path / "out"}"', text)
    text = re.sub(r"(?m)^frames = \[.*$", f"frames = [1, {last}]", text)
    path = tmp_path / "tail.toml"
    path.write_text(text)
    return str(path)


def test_version(capsys):
    with pytest.raises(SystemExit) as done:
        cli.main(["--version"])
    assert done.value.code == 0 and capsys.readouterr().out == f"opdeform {opdeform.__version__}\n"


@pytest.mark.parametrize("argv, prog", [([], "opdeform"), (["bake"], "opdeform bake")])
def test_help_is_plain_text(capsys, argv, prog):
    with pytest.raises(SystemExit) as done:
        cli.main([*argv, "--help"])
    text = capsys.readouterr().out
    assert done.value.code == 0 and text.startswith(f"usage: {prog} ")
    assert not re.search(r"``|:(func|class|meth|ref):|\*\*", text), text  # no reST markup
    if not argv:
        assert "opdeform bake examples/tail.toml" in text and 'pip install "opdeform[plot]"' in text


def test_python_m_opdeform_names_itself():
    done = subprocess.run([sys.executable, "-m", "opdeform", "--help"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and done.stdout.startswith("usage: python -m opdeform "), done.stderr


def bake_output(tmp_path, terminal):
    """stderr of ``python -m opdeform bake`` on a pseudo-terminal or on a pipe."""
    spec = spec_in(tmp_path)
    command = [sys.executable, "-m", "opdeform", "bake", spec, "--restart"]
    if not terminal:
        return subprocess.run(command, capture_output=True, text=True, timeout=120, check=True).stderr
    parent, child = pty.openpty()
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=child)
    os.close(child)
    chunks = []
    while True:
        try:
            chunk = os.read(parent, 4096)
        except OSError:  # the child closed the terminal
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(parent)
    assert proc.wait(120) == 0
    return b"".join(chunks).decode()


def test_progress_shows_the_time_left_on_a_terminal_only(tmp_path):
    shown = bake_output(tmp_path / "tty", terminal=True)
    updates = re.findall(r"\[[#.]{40}\] (\d+)/40 frames, [\d.]+ frames/s, (\d+ s|\d+ min \d\d s) left", shown)
    assert len(updates) >= 2 and updates[-1] == ("40", "0 s"), shown
    assert bake_output(tmp_path / "pipe", terminal=False) == ""


def test_duration():
    assert [cli._duration(s) for s in (0.4, 59.4, 65, 3599, 7620)] == \
        ["0 s", "59 s", "1 min 05 s", "59 min 59 s", "2 h 07 min"]


def test_a_bake_without_matplotlib_writes_all_but_the_plot(tmp_path, monkeypatch, caplog):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib raises ModuleNotFoundError
    assert cli.main(["bake", spec_in(tmp_path, last=5)]) == 0
    assert sorted(os.listdir(tmp_path / "out")) == ["frames", "report.csv", "tail.pc2"]
    assert caplog.messages == [f'{tmp_path / "out" / "report.png"} not written: the plot needs matplotlib '
                               '(pip install "opdeform[plot]")']


@pytest.mark.parametrize("command, module, extra", [
    (["render", "x.toml", "--references", "refs"], "matplotlib", "plot"),
    (["batch", "x.toml"], "distributed", "batch"),
])
def test_a_missing_extra_is_named(monkeypatch, capsys, command, module, extra):
    monkeypatch.setitem(sys.modules, module, None)
    assert cli.main(command) == 2
    assert capsys.readouterr().err == \
        f'error: {command[0]} needs {module}, which is not installed: pip install "opdeform[{extra}]"\n'
