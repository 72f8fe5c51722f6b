"""Argument errors are of one kind everywhere (opdeform/_arguments.py): None, a string or NaN given for any
number or array keyword of the constructors and setters raises ValueError naming the keyword, and the object
the call was made on is unchanged."""

import inspect
import math

import numpy as np
import pytest
from test_threads import _world

import opdeform
from opdeform import _arguments, _core, mesh, meshes, mpm

BAD = [None, "x", math.nan]
# Keywords that take an opdeform object, not a number or an array (a wrong class there is a TypeError).
OBJECTS = {"graph", "material", "sim"}


def _graph():
    return opdeform.Graph([[0, 0, 0], [1, 0, 0]], [[0.5] * 3] * 2, [[0, 1]])


def _sim():
    sim = opdeform.Simulation(_graph(), 1e3)
    sim.add_position_constraint((0, 0, 0))
    sim.step(2)
    return sim


def _sim_state(sim):
    counters = {k: v for k, v in sim.counters.items() if not k.endswith("_seconds")}
    solver = sim.solver if hasattr(sim, "solver") else None
    colliders = sim.collider_distances([(0.0, 0.0, 0.0)]) if hasattr(sim, "n_colliders") else None
    return [sim.positions, sim.rotations, sim.velocities, sim.params, sim.n_constraints, counters, solver, colliders]


def _with_collider(sim):
    sim.add_collider("sphere")
    return sim


def _world_state(world):
    return [world.read(name) for name in ("positions", "velocities", "orientations")] + [world.stats]


def _shape_matching(graph, **kw):
    return opdeform.ShapeMatching(graph, **kw)


_BOX = meshes.bar(length=0.2, width=0.2, segments=1, cross=1)

# name: (object maker or None, the call, keywords that make it valid, the object's observable state)
CALLS = {
    "Simulation": (None, lambda _, **kw: opdeform.Simulation(_graph(), **kw), dict(stiffness=1e3), None),
    "Simulation.set_params": (_sim, lambda s, **kw: s.set_params(**kw), {}, _sim_state),
    "Simulation.set_solver": (_sim, lambda s, **kw: s.set_solver(**kw), {}, _sim_state),
    "Simulation.add_position_constraint": (_sim, lambda s, **kw: s.add_position_constraint(**kw),
                                           dict(point=(1, 0, 0)), _sim_state),
    "Simulation.set_floor": (_sim, lambda s, **kw: s.set_floor(**kw), {}, _sim_state),
    "Simulation.add_collider": (_sim, lambda s, **kw: s.add_collider(**kw),
                                dict(shape="mesh", vertices=_BOX[0], triangles=_BOX[1]), _sim_state),
    "Simulation.move_collider": (lambda: _with_collider(_sim()), lambda s, **kw: s.move_collider(**kw),
                                 dict(id=0, translation=(0, 0, 0)), _sim_state),
    "Skin": (None, lambda _, **kw: mesh.Skin(_graph(), **kw), dict(rest_vertices=[(0, 0, 0), (1, 0, 1)]), None),
    "mpm.World": (None, lambda _, **kw: mpm.World(**kw), dict(lower=(0, 0, 0), upper=(1, 1, 1), dx=0.1), None),
    "mpm.World.add_particles": (_world, lambda w, **kw: w.add_particles(**kw), dict(positions=[(0.5, 0.5, 0.5)]),
                                _world_state),
    "mpm.World.add_collider": (_world, lambda w, **kw: w.add_collider(**kw),
                               dict(shape="mesh", vertices=_BOX[0] + 0.5, triangles=_BOX[1]), _world_state),
    "mpm.World.add_floor": (_world, lambda w, **kw: w.add_floor(**kw), {}, _world_state),
    "mpm.World.set_wind": (_world, lambda w, **kw: w.set_wind(**kw), {}, _world_state),
    "mpm.World.move_collider": (_world, lambda w, **kw: w.move_collider(**kw), dict(id=0, translation=(0, 0, 0)),
                                _world_state),
}
if hasattr(_core, "ShapeMatching"):
    CALLS["ShapeMatching"] = (None, lambda _, **kw: opdeform.ShapeMatching(_graph(), **kw), {}, None)
    CALLS["ShapeMatching.set_params"] = (lambda: _shape_matching(_graph()), lambda s, **kw: s.set_params(**kw),
                                         {}, _sim_state)

_TARGETS = {"Simulation": opdeform.Simulation.__init__, "Simulation.set_params": opdeform.Simulation.__init__,
            "Skin": mesh.Skin.__init__, "mpm.World": mpm.World.__init__,
            "ShapeMatching": getattr(opdeform, "ShapeMatching", object).__init__,
            "ShapeMatching.set_params": getattr(opdeform, "ShapeMatching", object).__init__}


def _keywords(name):
    """The keywords of a call, read from its signature (set_params: the constructor's)."""
    if name in _TARGETS:
        function = _TARGETS[name]
    else:
        cls = opdeform.Simulation if name.startswith("Simulation") else mpm.World
        function = getattr(cls, name.rpartition(".")[2])
    parameters = inspect.signature(function).parameters.values()
    return [(p.name, p.default) for p in parameters if p.name not in OBJECTS | {"self"}]


CASES = [pytest.param(name, keyword, bad, id=f"{name}-{keyword}-{bad!r}")
         for name in CALLS for keyword, default in _keywords(name) for bad in BAD
         if not (bad is None and default is None)]  # None is a valid value where it is the default


@pytest.mark.parametrize("name, keyword, bad", CASES)
def test_a_bad_number_or_array_raises_value_error_naming_it(name, keyword, bad):
    make, call, valid, state = CALLS[name]
    obj = make() if make else None
    before = state(obj) if state else None
    with pytest.raises(ValueError, match=keyword.replace("_", "[_ ]")):
        call(obj, **{**valid, keyword: bad})
    if state:
        np.testing.assert_equal(state(obj), before, "a failed call changed the object")


def test_every_call_of_the_list_is_valid_as_given():
    """The valid keywords above do work (so each failure comes from the bad value alone)."""
    for name, (make, call, valid, _) in CALLS.items():
        call(make() if make else None, **valid)


def test_a_wrong_class_for_an_opdeform_object_stays_type_error():
    with pytest.raises(TypeError, match="opdeform.Graph"):
        opdeform.Simulation("graph", 1e3)
    with pytest.raises(TypeError, match="opdeform.Graph"):
        mesh.Skin("graph", [(0, 0, 0)])


def test_an_empty_array_where_two_lengths_are_open_raises_value_error_naming_it(tmp_path):
    # (n, n, 3) of nothing: refused as of the wrong shape (was a TypeError from reshaping to (0, None, 3))
    with pytest.raises(ValueError, match=r"frames must have shape \(n, n, 3\), got \(0,\)"):
        opdeform.io.write_pc2(tmp_path / "empty.pc2", [])
    assert _arguments.as_array("centers", [], (None, 3)).shape == (0, 3)  # one open length: still (0, 3)
