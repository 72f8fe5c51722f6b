"""The add-on in Blender's real user interface, on a virtual X server (xvfb-run; no display needed): the Bake
button's modal bake reports progress, Esc cancels it and keeps the frames baked so far, a second bake runs to
the end. Debian's Blender only (the bpy module has no windows)."""

import os
import shutil
import signal
import subprocess

import pytest

from test_addon import BLENDER_TESTS, ROOT, host_env


@pytest.mark.skipif(shutil.which("blender") is None or shutil.which("xvfb-run") is None,
                    reason="needs Debian's blender and xvfb-run (scripts/setup installs both)")
def test_modal_bake_escape_keeps_frames(tmp_path):
    blender = str(ROOT / "scripts" / "blender")
    empty = tmp_path / "empty.blend"  # opening a file skips the splash screen
    subprocess.run([blender, "-b", "--factory-startup", "--python-expr",
                    f"import bpy; bpy.ops.wm.save_as_mainfile(filepath={str(empty)!r})"],
                   capture_output=True, timeout=120, check=True)
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 800x600x24", blender, "--factory-startup", "--enable-event-simulate",
           str(empty), "-P", str(BLENDER_TESTS / "ui_bake.py"), "--", str(tmp_path)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=host_env(),
                            cwd=str(ROOT), start_new_session=True)
    try:
        out, err = proc.communicate(timeout=240)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # xvfb-run, Xvfb and Blender: the whole group
        out, err = proc.communicate()
    assert "UI_BAKE_OK" in out, out[-4000:] + err[-2000:]
    assert "UI_BAKE cancelled after" in out


SHOTS = ROOT / "out" / "ui"  # the tests' output folder (ignored by git): looked at by eye after a change


@pytest.mark.skipif(shutil.which("blender") is None or shutil.which("xvfb-run") is None,
                    reason="needs Debian's blender and xvfb-run (scripts/setup installs both)")
def test_properties_screenshots(tmp_path):
    """The Physics tab (every OPDeform panel open) and the Modifier tab at the factory Properties width (333 px
    under a 1920-pixel window) written to out/ui; Blender 3.4 only (the bpy module has no windows)."""
    blender = str(ROOT / "scripts" / "blender")
    empty = tmp_path / "empty.blend"
    subprocess.run([blender, "-b", "--factory-startup", "--python-expr",
                    f"import bpy; bpy.ops.wm.save_as_mainfile(filepath={str(empty)!r})"],
                   capture_output=True, timeout=120, check=True)
    SHOTS.mkdir(parents=True, exist_ok=True)
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1920x4000x24", blender, "--factory-startup", str(empty), "-P",
           str(BLENDER_TESTS / "screenshot_tabs.py"), "--", str(SHOTS)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=240, env=host_env(), cwd=str(ROOT),
                          start_new_session=True)
    assert "TABS_OK 333 " in proc.stdout, proc.stdout[-4000:] + proc.stderr[-2000:]
    for tab in ("physics", "modifier"):
        assert (SHOTS / f"properties_{tab}.png").stat().st_size > 10000
