"""Shots against hostile output folders (issue 28): a checkpoint is data (a planted pickle runs nothing, a damaged
checkpoint is reported with its path and the bake starts over), output names stay inside the output folder, a
second bake of the same output is refused, every partial file is unique to its writer, and spec values a bake
cannot run are refused at spec time naming the key."""

import logging
import os
import pickle
import subprocess
import sys

import pytest

from opdeform import cli, io
from opdeform import shot as shots
from test_shot import SMALL, write_spec


class Planted:
    """A pickle that runs a command when loaded: what an attacker would leave in a shared output folder."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def reference(tmp_path, last=30):
    os.makedirs(tmp_path / "ref")
    shots.bake(shots.load(write_spec(tmp_path / "ref", last=last, every=8)))
    return (tmp_path / "ref" / "out" / "shot.pc2").read_bytes()


def interrupted(folder, at=20):
    """A spec baked up to frame ``at`` and stopped there (its checkpoint after frame 17 and partial PC2 left)."""
    os.makedirs(folder, exist_ok=True)
    spec = write_spec(folder, every=8)

    def stop(done, total):
        if done == at:
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        shots.bake(shots.load(spec), progress=stop)
    return spec


def parts(folder):
    return sorted(p for p in os.listdir(folder) if ".part" in p)


def test_a_planted_pickle_checkpoint_runs_nothing(tmp_path, caplog):
    expected = reference(tmp_path)
    spec = interrupted(tmp_path / "b")
    out = tmp_path / "b" / "out"
    marker = tmp_path / "ran"
    (out / ".shot.checkpoint").write_bytes(pickle.dumps({"digest": Planted(marker), "frame": 17}))
    with caplog.at_level(logging.WARNING, "opdeform"):
        assert cli.main(["bake", spec]) == 0
    assert not marker.exists()
    assert (out / "shot.pc2").read_bytes() == expected
    assert f"{out / '.shot.checkpoint'}: cannot resume" in caplog.text and "from the first frame" in caplog.text


@pytest.mark.parametrize("damage", ["half", "flip", "empty", "old pickle"])
def test_a_damaged_checkpoint_is_reported_and_the_bake_starts_over(tmp_path, caplog, damage):
    expected = reference(tmp_path)
    spec = interrupted(tmp_path / "b")
    path = tmp_path / "b" / "out" / ".shot.checkpoint"
    data = path.read_bytes()
    assert data.startswith(b"OPDEFORM CHECKPOINT\n")
    damaged = {"half": data[:len(data) // 2], "flip": data[:-9] + bytes([data[-9] ^ 4]) + data[-8:], "empty": b"",
               "old pickle": pickle.dumps({"digest": shots.load(spec).digest, "frame": 17})}[damage]
    path.write_bytes(damaged)
    seen = []
    with caplog.at_level(logging.WARNING, "opdeform"):
        shots.bake(shots.load(spec), progress=lambda done, total: seen.append(done))
    assert seen[0] == 2 and f"{path}: cannot resume" in caplog.text
    assert (tmp_path / "b" / "out" / "shot.pc2").read_bytes() == expected
    assert not path.exists() and parts(tmp_path / "b" / "out") == []


def test_a_checkpoint_resumes_to_the_same_bits_with_a_partial_file_of_its_own(tmp_path):
    expected = reference(tmp_path)
    spec = interrupted(tmp_path / "b")
    out = tmp_path / "b" / "out"
    (part,) = parts(out)
    assert part.startswith("shot.part-") and part.endswith(".pc2")
    seen = []
    shots.bake(shots.load(spec), progress=lambda done, total: seen.append(done))
    assert seen[0] == 18 and (out / "shot.pc2").read_bytes() == expected and parts(out) == []


@pytest.mark.parametrize("key, value", [
    ("pc2", '"ABS/x.pc2"'), ("pc2", '"../../../x.pc2"'), ("report", '"ABS/existing.csv"'),
    ("frames", '"../../../f_{frame:04d}.obj"'), ("plot", '"sub/../../p.png"'), ("name", '"../../../x"'),
    ("name", '"a/b"'), ("frames", '"f_{frame:04d}/../../x_{frame}.obj"'),
])
def test_output_names_that_leave_the_folder_are_refused(tmp_path, capsys, key, value):
    where = "" if key == "name" else "output."
    value = value.replace("ABS", str(tmp_path / "abs"))  # an absolute path, here inside the test's folder
    text = SMALL.format(last=5, every=0, extra="" if key == "name" else f"{key} = {value}")
    if key == "name":
        text = f"name = {value}\n" + text
    path = write_spec(tmp_path, text=text)
    assert cli.main(["bake", path]) == 2
    err = capsys.readouterr().err
    assert f"{path}: {where}{key}: " in err and "inside the output folder" in err
    assert not list(tmp_path.rglob("*.pc2")) and not list(tmp_path.parent.parent.glob("x*"))


@pytest.mark.parametrize("change, key, problem", [
    ('frames = "f_{frame:999999999d}.obj"', "output.frames", "width"),
    ('frames = "f_{frame:04d}_{other}.obj"', "output.frames", "{other}"),
    ("frames = [1, 100000000]", "frames", "at most"),
    ("substeps = 100000", "substeps", "at most"),
    ("particles = 2000000000", "graph.particles", "at most"),
    ("stiffness = 1e308", "material.stiffness", "at most"),
    ("density = 1e308", "material.density", "at most"),
])
def test_spec_values_a_bake_cannot_run_are_refused_at_spec_time(tmp_path, capsys, change, key, problem):
    text = SMALL.format(last=5, every=0, extra=change if change.startswith("frames = \"") else "")
    if change.startswith("frames = ["):
        text = text.replace("frames = [1, 5]", change)
    elif change.startswith("substeps"):
        text = text.replace("substeps = 2", change)
    elif change.startswith("particles"):
        text = text.replace("particles = 20", change)
    elif change.startswith(("stiffness", "density")):
        text = text.replace("stiffness = 1e6", "stiffness = 1e6\n" + change if "density" in change else change)
    path = write_spec(tmp_path, text=text)
    assert cli.main(["bake", path]) == 2
    err = capsys.readouterr().err
    assert f"{path}: {key}: " in err and problem in err, err


def test_a_second_bake_of_the_same_output_is_refused(tmp_path, capsys):
    spec = write_spec(tmp_path, last=12)
    codes = []

    def second(done, total):
        if done == 5:
            codes.append(cli.main(["bake", spec]))
    shots.bake(shots.load(spec), progress=second)
    assert codes == [1]
    err = capsys.readouterr().err
    assert "is being baked by process" in err and str(tmp_path / "out" / ".shot.pc2.lock") in err
    assert io.pc2_header(tmp_path / "out" / "shot.pc2")[3] == 12
    assert not [p for p in os.listdir(tmp_path / "out") if p.endswith(".lock") or ".part" in p]


def test_a_lock_left_by_a_dead_process_is_taken_over(tmp_path):
    spec = write_spec(tmp_path, last=5)
    os.makedirs(tmp_path / "out")
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    (tmp_path / "out" / ".shot.pc2.lock").write_text(f"{os.uname().nodename} {int(dead.stdout)}\n")
    assert cli.main(["bake", spec]) == 0
    assert io.pc2_header(tmp_path / "out" / "shot.pc2")[3] == 5


@pytest.mark.parametrize("held, holder", [("farm-node-7 4242\n", "process 4242 on farm-node-7, another host: "
                                                                 "whether it still runs cannot be checked"),
                                          ("\x00\xff", "a writer whose lock cannot be read")],
                         ids=["another host", "unreadable"])
def test_a_lock_that_cannot_be_checked_is_refused_naming_it_and_how_to_clear_it(tmp_path, capsys, held, holder):
    # before: "... by process 4242 on farm-node-7 (lock ...); if no bake of it runs, delete the lock" (not saying
    # why the lock is kept, nor which file to delete); an unreadable lock: "by process None on an unknown host"
    spec = write_spec(tmp_path, last=5)
    os.makedirs(tmp_path / "out")
    lock = tmp_path / "out" / ".shot.pc2.lock"
    lock.write_bytes(held.encode("latin-1"))
    assert cli.main(["bake", spec]) == 1
    err = capsys.readouterr().err
    assert f"is being baked by {holder}" in err and f"if no bake of it runs, delete {lock} and bake again" in err, err
    assert lock.read_bytes() == held.encode("latin-1") and not (tmp_path / "out" / "shot.pc2").exists()
    lock.unlink()
    assert cli.main(["bake", spec]) == 0


def test_atomic_files_of_one_output_have_a_part_name_per_writer(tmp_path):
    with io.atomic_path(tmp_path / "a.obj") as first, io.atomic_path(tmp_path / "a.obj") as second:
        assert first != second and os.path.dirname(first) == str(tmp_path)
        open(first, "w").write("1")
        open(second, "w").write("2")
    assert (tmp_path / "a.obj").read_text() == "1" and os.listdir(tmp_path) == ["a.obj"]
    one, two = io.PC2Writer(tmp_path / "b.pc2", 2), io.PC2Writer(tmp_path / "b.pc2", 2)
    assert one.partial != two.partial
    one.close()
    two.close()
