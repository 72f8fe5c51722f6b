"""Shots (issue 17): the shipped example bakes, bad specs are refused naming the key before anything runs,
outputs are complete or absent, a bake resumes from its checkpoint to the same bits; PC2 in opdeform.io."""

import os
import shutil

import numpy as np
import pytest

from opdeform import cli, io, meshes
from opdeform import shot as shots

EXAMPLE = os.path.join(os.path.dirname(__file__), "..", "examples", "tail.toml")

SMALL = """version = 1
mesh = "builtin:bar"
frames = [1, {last}]
substeps = 2
[graph]
particles = 20
[material]
stiffness = 1e6
[solver]
threads = 1
[pins]
vertices = [0, 1, 2, 3, 4, 5, 6, 7, 8]
[[handles]]
vertex = 11
strength = 0.01
rotation = true
keys = [{{ frame = 1, offset = [0, 0, 0] }}, {{ frame = 10, offset = [0, 0.6, 0], rotate = [0, 0, 40] }}]
[output]
folder = "out"
checkpoint_every = {every}
{extra}
"""


def write_spec(folder, name="shot", last=30, every=0, extra="", text=None):
    path = os.path.join(folder, f"{name}.toml")
    with open(path, "w") as f:
        f.write(text if text is not None else SMALL.format(last=last, every=every, extra=extra))
    return path


def test_the_example_bakes_every_output(tmp_path):
    spec = tmp_path / "tail.toml"
    shutil.copy(EXAMPLE, spec)
    text = spec.read_text().replace('"../out/examples/tail"', '"out"')
    spec.write_text(text)
    assert cli.main(["bake", str(spec)]) == 0
    out = tmp_path / "out"
    _, _, frames = io.read_pc2(out / "tail.pc2")
    assert frames.shape == (48, len(meshes.bar()[0]), 3)
    assert len(list((out / "frames").glob("tail_*.obj"))) == 48
    v, _ = io.read(out / "frames" / "tail_0048.obj")
    np.testing.assert_allclose(v, frames[-1], atol=1e-6)  # float32 cache, float64 frames
    rows = shots.read_report(out / "report.csv")
    assert [r["frame"] for r in rows] == list(range(1, 49)) and rows[5]["residual"] > 0
    assert (out / "report.png").read_bytes()[:4] == b"\x89PNG"
    assert not [p for p in out.rglob("*") if ".part" in p.name or "checkpoint" in p.name]
    assert np.ptp(frames[:, 11, 1]) > 0.3  # the tip swings


@pytest.mark.parametrize("change, key, problem", [
    (("particles = 20", "particles = 20\nparticels = 3"), "graph.particels", "unknown key"),
    (('mesh = "builtin:bar"', 'mesh = "missing.obj"'), "mesh", "no such file"),
    (("vertices = [0, 1, 2,", "vertices = [170, 1, 2,"), "pins.vertices", "170 is out of range"),
    (("vertex = 11", "vertex = 999"), "handles[0].vertex", "out of range"),
    (("version = 1", "version = 2"), "version", "reads version 1"),
    (("stiffness = 1e6", "stiffness = -1.0"), "material.stiffness", "must be > 0"),
    (("stiffness = 1e6", "density = 5.0"), "material.stiffness", "missing"),
    (("frames = [1, 30]", "frames = [30, 1]"), "frames", "last > first"),
    (('folder = "out"', 'folder = "shot.toml/out"'), "output.folder", "cannot write"),
    (('folder = "out"', 'folder = "out"\nframes = "f.obj"'), "output.frames", "the same"),
    (('folder = "out"', 'folder = "out"\nframes = "f{frame}.abc"'), "output.frames", ".obj or .ply"),
    (("[pins]", "[goals]\nanimation = 'none.pc2'\nstrength = 0.5\n[pins]"), "goals.animation", "no such file"),
])
def test_bad_specs_name_the_key(tmp_path, change, key, problem):
    path = write_spec(tmp_path, text=SMALL.format(last=30, every=0, extra="").replace(*change))
    with pytest.raises(shots.SpecError) as info:
        shots.load(path)
    assert f"{path}: {key}: " in str(info.value) and problem in str(info.value)
    assert not (tmp_path / "out" / "shot.pc2").exists()


def test_the_command_line_reports_a_bad_spec(tmp_path, capsys):
    path = write_spec(tmp_path, text=SMALL.format(last=30, every=0, extra="").replace("[graph]", "[graf]"))
    assert cli.main(["bake", path]) == 2
    assert "graf: unknown key" in capsys.readouterr().err


def test_goals_follow_an_animation(tmp_path):
    v, _ = meshes.bar()
    lift = np.linspace(0, 0.5, 30)[:, None, None] * (v[None, :, 0:1] / 2.0) * np.array([0, 0, 1.0])
    io.write_pc2(tmp_path / "anim.pc2", v + lift)
    head = SMALL.format(last=30, every=0, extra="").split("[pins]")[0]
    path = write_spec(tmp_path, text=head + "[goals]\nanimation = 'anim.pc2'\nstrength = 1.0\n"
                                            "[output]\nfolder = 'out'\n")
    shots.bake(shots.load(path))
    _, _, frames = io.read_pc2(tmp_path / "out" / "shot.pc2")
    np.testing.assert_allclose(frames[-1], v + lift[-1], atol=1e-5)  # strength 1: the animation


def test_a_bake_resumes_from_its_checkpoint_to_the_same_bits(tmp_path):
    for folder in "ab":
        os.makedirs(tmp_path / folder)
    shots.bake(shots.load(write_spec(tmp_path / "a", every=8)))
    reference = (tmp_path / "a" / "out" / "shot.pc2").read_bytes()
    spec = write_spec(tmp_path / "b", every=8)

    def stop(done, total):
        if done == 20:
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        shots.bake(shots.load(spec), progress=stop)
    out = tmp_path / "b" / "out"
    (part,) = out.glob("shot.part-*.pc2")  # the partial PC2 of that bake's writer
    assert not (out / "shot.pc2").exists() and io.pc2_header(part)[3] == 20
    assert (out / ".shot.checkpoint").exists()
    seen = []
    shots.bake(shots.load(spec), progress=lambda done, total: seen.append(done))
    assert seen[0] == 18  # frames 1..17 came from the checkpoint written after frame 17
    assert (out / "shot.pc2").read_bytes() == reference
    assert not (out / ".shot.checkpoint").exists() and not list(out.glob("shot.part*"))


def test_pc2_round_trip_and_atomic_files(tmp_path):
    frames = np.random.default_rng(1).normal(size=(5, 7, 3)).astype(np.float32)
    io.write_pc2(tmp_path / "a.pc2", frames, start=3.0)
    start, rate, back = io.read_pc2(tmp_path / "a.pc2")
    assert (start, rate) == (3.0, 1.0) and np.array_equal(back, frames)
    with pytest.raises(RuntimeError):
        with io.atomic_path(tmp_path / "b.obj") as part:
            open(part, "w").write("partial")
            raise RuntimeError
    assert os.listdir(tmp_path) == ["a.pc2"]
    with io.PC2Writer(tmp_path / "c.pc2", 7, atomic=False) as writer:  # the add-on's bake: valid at every frame
        writer.write(frames[0])
        assert io.pc2_header(tmp_path / "c.pc2")[3] == 1
    with pytest.raises(ValueError, match="points"):
        io.PC2Writer(tmp_path / "d.pc2", 7).write(frames[0][:3])
    with pytest.raises(ValueError, match="truncated"):
        (tmp_path / "e.pc2").write_bytes((tmp_path / "a.pc2").read_bytes()[:-4])
        io.read_pc2(tmp_path / "e.pc2")


def test_report_command(tmp_path, capsys):
    spec = write_spec(tmp_path, last=12, extra='report = "r.csv"')
    shots.bake(shots.load(spec))
    assert cli.main(["report", spec]) == 0
    out = capsys.readouterr().out
    assert "frames 1-12" in out and "residual: largest" in out
