"""The layers of csrc/: a wrong-way include fails the build, and the module graphs of includes and calls have no
cycle (docs/architecture.md; planted faults: tests/test_architecture.py)."""
import json
import os
import runpy
import shlex
import subprocess
import sys

import pytest

import opdeform

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(ROOT, "scripts", "architecture")


def build_dir():
    """The meson build dir the tests import opdeform from (<build>/python/opdeform/__init__.py)."""
    build = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(opdeform.__file__))))
    assert os.path.isfile(os.path.join(build, "compile_commands.json")), f"{build} is not a meson build dir"
    return build


def compile_command(source):
    """The build's own compiler arguments for a file of csrc/, with the source, output and dependency
    file left out (so the command can compile another file)."""
    build = build_dir()
    for entry in json.load(open(os.path.join(build, "compile_commands.json"))):
        if os.path.normpath(os.path.join(entry["directory"], entry["file"])) == os.path.join(ROOT, source):
            args, keep = shlex.split(entry["command"]), []
            skip = False
            for a in args:
                if skip:
                    skip = False
                elif a in ("-o", "-MF", "-MQ", "-c"):
                    skip = True
                elif a != "-MD":
                    keep.append(a)
            return build, keep[:-1] if keep[-1].endswith(".c") else keep
    raise AssertionError(f"{source} is not in the build")


def compile_text(source, text, tmp_path):
    """Compiles `text` with the flags of `source`, as a file beside it would be (its folder first)."""
    build, args = compile_command(source)
    path = tmp_path / "probe.c"
    path.write_text(text)
    folder = os.path.join(ROOT, os.path.dirname(source))
    cmd = args + ["-iquote", folder, "-c", str(path), "-o", str(tmp_path / "probe.o")]
    env = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}  # not the ASan runtime of scripts/test-sanitize
    return subprocess.run(cmd, cwd=build, capture_output=True, text=True, env=env)


@pytest.mark.parametrize("source, include, expect", [
    ("csrc/base/pool.c", '"sim.h"', "sim.h"),                          # an ARAP internal header
    ("csrc/base/pool.c", '"opdeform/opdeform.h"', "arap layer"),        # the ARAP public header
    ("csrc/graph/graph.c", '"mesh_graph.h"', "mesh_graph.h"),
    ("csrc/mesh/skinning.c", '"global_solve.h"', "global_solve.h"),     # mesh may not use the solver
    ("csrc/mesh/skinning.c", '"opdeform/mpm.h"', "mpm layer"),
    ("csrc/mpm/grid.c", '"graph.h"', "graph.h"),
    ("csrc/collide/collider.c", '"world.h"', "world.h"),
])
def test_wrong_way_include_fails_the_build(source, include, expect, tmp_path):
    allowed = compile_text(source, '#include "core.h"\nint probe(void) { return 0; }\n', tmp_path)
    assert allowed.returncode == 0, allowed.stderr  # the same command compiles a right-way include
    wrong = compile_text(source, f'#include "core.h"\n#include {include}\nint probe(void) {{ return 0; }}\n',
                         tmp_path)
    assert wrong.returncode != 0 and expect in wrong.stderr, wrong.stderr


def test_layers_respected_no_cycle_docs_current():
    run = subprocess.run([sys.executable, SCRIPT, "--check", "--part", "csrc"], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    out = subprocess.run([sys.executable, SCRIPT, "--json", "--part", "csrc"], capture_output=True, text=True).stdout
    result = json.loads(out)["csrc"]
    assert result["cycles"] == [] and result["problems"] == []
    edges = {tuple(e) for e in result["edges"]}
    # the analysis sees the graph (not vacuous): the solver uses the position terms, which never use it back
    assert ("arap/global_solve", "arap/position_constraints") in edges
    assert not any(a == "arap/position_constraints" and b == "arap/global_solve" for a, b in edges)
    assert ("arap/constraints", "arap/global_solve") not in edges  # the set does not reach into the solver
    assert [name for name, _ in result["layers"]][:2] == ["base", "graph"]
    # the calls: the driver and the bodies' contact both drive the stages of a step, which call neither back
    calls = {(a, b): names for a, b, names in result["calls"]}
    assert "od_BodyContact_Step" in calls["arap/simulation", "arap/body_contact"]
    assert {"od_Step_Start", "od_Step_Advance"} <= set(calls["arap/body_contact", "arap/step"])
    assert not any(a == "arap/step" and b in ("arap/simulation", "arap/body_contact") for a, b in calls)


def test_cycle_finder_finds_cycles():
    tool = runpy.run_path(SCRIPT)
    assert tool["cycles"]({("a", "b"), ("b", "c"), ("c", "a"), ("c", "d")}) == [["a", "b", "c", "a"]]
    assert tool["cycles"]({("a", "b"), ("a", "c"), ("b", "c")}) == []
