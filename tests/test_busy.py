"""The busy guard (docs/hardening.md): while an object runs a GIL-free call on one thread, every public call on
it from another thread - each method and property of the Python class and of its core object, enumerated
here so that a new one cannot slip through - is refused with the same RuntimeError, and the object is intact
afterwards."""

import inspect
import re

import numpy as np
import pytest
from test_threads import _probe_during, _world

import opdeform
from opdeform import _core, mesh, meshes, mpm, scenes


def _public(cls):
    """Names of the public methods and properties of a class (inherited ones included)."""
    return {name for name, member in inspect.getmembers(cls)
            if not name.startswith("_") and (inspect.isroutine(member) or inspect.isdatadescriptor(member))}


def _setters(cls):
    """Names of the Python properties that can be set."""
    return {name for name, member in inspect.getmembers(cls) if isinstance(member, property) and member.fset}


def _core_probes(core):
    """A call of every public method (without arguments: the guard comes before parsing) and a read of every
    property of a core object."""
    probes = {}
    for name in _public(type(core)):
        member = inspect.getattr_static(type(core), name)
        probes["_core." + name] = ((lambda n=name: getattr(core, n)()) if inspect.isroutine(member)
                                   else (lambda n=name: getattr(core, n)))
    return probes


class Case:
    """An object, the long GIL-free call to run on another thread, a call for every public name of its class,
    and a snapshot of everything observable (compared with an undisturbed twin afterwards)."""

    def __init__(self, obj, run, probes, snapshot, ready):
        self.obj, self.run, self.probes, self.snapshot = obj, run, probes, snapshot
        self.ready = probes[ready]  # a probe that changes nothing, to see when the run has begun


def _sim_case(scale):
    sim = scenes.falling_body(damping=0.01)
    sim.add_position_constraint((0.0, 0.0, 1.0), weight=1e3)
    n = sim.graph.n_particles
    probes = {
        "add_position_constraint": lambda: sim.add_position_constraint((0.0, 0.0, 1.0)),
        "add_direction_constraint": lambda: sim.add_direction_constraint((0, 0, 0), (1, 0, 0)),
        "set_constraint_target": lambda: sim.set_constraint_target(0, (0.0, 0.0, 0.0)),
        "set_constraint_weight": lambda: sim.set_constraint_weight(0, 1.0),
        "remove_constraint": lambda: sim.remove_constraint(0),
        "n_constraints": lambda: sim.n_constraints,
        "default_weight": lambda: sim.default_weight(),
        "set_floor": lambda: sim.set_floor(0.5), "clear_floor": lambda: sim.clear_floor(),
        "add_collider": lambda: sim.add_collider("sphere"), "move_collider": lambda: sim.move_collider(0, (0, 0, 0)),
        "update_collider_vertices": lambda: sim.update_collider_vertices(0, np.zeros((3, 3))),
        "set_collider_contact": lambda: sim.set_collider_contact(0), "remove_collider": lambda: sim.remove_collider(0),
        "n_colliders": lambda: sim.n_colliders, "push_out": lambda: sim.push_out([(0.0, 0.0, 0.0)]),
        "collider_distances": lambda: sim.collider_distances([(0.0, 0.0, 0.0)]),
        "set_contact_skin": lambda: sim.set_contact_skin(None), "n_contact_points": lambda: sim.n_contact_points,
        "set_contact_points": lambda: sim.set_contact_points([(0.0, 0.0, 0.0)], [0]),
        "set_self_contact": lambda: sim.set_self_contact(), "self_contact": lambda: sim.self_contact,
        "add_force_field": lambda: sim.add_force_field(), "move_force_field": lambda: sim.move_force_field(0, (0, 0, 0)),
        "remove_force_field": lambda: sim.remove_force_field(0), "n_force_fields": lambda: sim.n_force_fields,
        "set_goal_strength": lambda: sim.set_goal_strength(0.5),
        "set_goal_frequencies": lambda: sim.set_goal_frequencies(np.ones(n)),
        "set_goals": lambda: sim.set_goals(sim.graph.centers),
        "set_goals_carry_rest": lambda: sim.set_goals_carry_rest(), "goals_carry_rest": lambda: sim.goals_carry_rest,
        "goal_motion": lambda: sim.goal_motion,
        "set_goal_motion": lambda: sim.set_goal_motion((np.zeros((n, 3)), np.zeros((n, 3)), -1)),
        "surface_forces": lambda: sim.surface_forces,
        "set_surface_forces": lambda: sim.set_surface_forces((np.zeros((n, 3)), np.full(n, -2))),
        "set_particle_damping": lambda: sim.set_particle_damping(0.1), "particle_damping": lambda: sim.particle_damping,
        "set_stiffness_scale": lambda: sim.set_stiffness_scale(np.ones(n)),
        "stiffness_scale": lambda: sim.stiffness_scale,
        "set_link_softness": lambda: sim.set_link_softness(np.ones(n)), "link_softness": lambda: sim.link_softness,
        "set_stretch_limit": lambda: sim.set_stretch_limit(1.2), "stretch_limit": lambda: sim.stretch_limit,
        "step": lambda: sim.step(1), "solve_static": lambda: sim.solve_static(1), "energy": lambda: sim.energy(),
        "set_state": lambda: sim.set_state(np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1))),
        "positions": lambda: sim.positions, "rotations": lambda: sim.rotations,
        "velocities": lambda: sim.velocities, "angular_velocities": lambda: sim.angular_velocities,
        "skin_points": lambda: sim.skin_points([(0.0, 0.0, 0.0)]),
        "params": lambda: sim.params, "set_params": lambda: sim.set_params(damping=0.5),
        "set_solver": lambda: sim.set_solver("anderson"), "solver": lambda: sim.solver,
        "counters": lambda: sim.counters, "energy_trace": lambda: sim.energy_trace,
        "tolerance": lambda: sim.tolerance, "max_iterations": lambda: sim.max_iterations,
        "step_report": lambda: sim.step_report,
        "trace_energy": lambda: sim.trace_energy, "trace_energy=": lambda: setattr(sim, "trace_energy", True),
    }

    def snapshot():
        counters = {k: v for k, v in sim.counters.items() if not k.endswith("_seconds")}
        return [sim.positions, sim.rotations, sim.velocities, sim.angular_velocities, sim.n_constraints,
                sim.params, sim.solver, counters, sim.trace_energy, sim.energy()]

    return Case(sim, lambda: sim.step(300 * scale), probes, snapshot, "positions")


def _shape_matching_case(scale):
    from opdeform.shape_matching import fig1_bar

    sm = fig1_bar()
    n = sm.graph.n_particles
    probes = {
        "add_position_constraint": lambda: sm.add_position_constraint((2.0, 0.0, 0.0)),
        "set_constraint_target": lambda: sm.set_constraint_target(0, (0.0, 0.0, 0.0)),
        "n_constraints": lambda: sm.n_constraints,
        "set_floor": lambda: sm.set_floor(0.5), "clear_floor": lambda: sm.clear_floor(), "step": lambda: sm.step(1),
        "set_state": lambda: sm.set_state(np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1))),
        "positions": lambda: sm.positions, "rotations": lambda: sm.rotations, "velocities": lambda: sm.velocities,
        "angular_velocities": lambda: sm.angular_velocities, "skin_points": lambda: sm.skin_points([(0, 0, 0)]),
        "params": lambda: sm.params, "set_params": lambda: sm.set_params(damping=0.5),
        "counters": lambda: sm.counters,
    }

    def snapshot():
        return [sm.positions, sm.rotations, sm.velocities, sm.angular_velocities, sm.n_constraints, sm.params,
                sm.counters]

    return Case(sm, lambda: sm.step(500 * scale), probes, snapshot, "positions")


def _world_case(scale):
    w = _world()
    probes = {
        "add_particles": lambda: w.add_particles([(0.5, 0.5, 0.9)], mpm.snow()),
        "set_wind": lambda: w.set_wind(), "add_collider": lambda: w.add_collider("sphere", radius=0.1),
        "add_floor": lambda: w.add_floor(0.05), "move_collider": lambda: w.move_collider(0, (0, 0, 0.1)),
        "step": lambda: w.step(1 / 120), "substep": lambda: w.substep(1e-4),
        "update_orientations": lambda: w.update_orientations(), "n_particles": lambda: w.n_particles,
        "read": lambda: w.read("plastic_j"), "positions": lambda: w.positions, "velocities": lambda: w.velocities,
        "orientations": lambda: w.orientations, "rotations": lambda: w.rotations, "stats": lambda: w.stats,
        "add_force_field": lambda: w.add_force_field(), "move_force_field": lambda: w.move_force_field(0, (0, 0, 0)),
        "remove_force_field": lambda: w.remove_force_field(0), "n_force_fields": lambda: w.n_force_fields,
    }

    def snapshot():
        fields = ("positions", "velocities", "orientations", "rotations", "deformation", "affine", "plastic_j")
        return [w.read(name) for name in fields] + [w.stats]

    return Case(w, lambda: w.step(4 * scale / 120), probes, snapshot, "positions")


@pytest.fixture(scope="module")
def big_mesh():
    vertices, triangles = meshes.capsule(radius=0.1, length=0.6, segments=128, rings=64, body=64)
    return meshes.subdivide(*meshes.subdivide(vertices, triangles))


def _skin_case(big_mesh):
    vertices, triangles = big_mesh
    graph = mesh.graph_from_mesh(vertices, triangles, particles=60)
    skin = mesh.Skin(graph, vertices, triangles=triangles, threads=1)
    sim = opdeform.Simulation(graph, 1e5)
    x, r = sim.positions, sim.rotations
    normals = np.empty((skin.n_vertices, 3), np.float32)
    skinned, shown = np.zeros((skin.n_vertices, 3)), np.zeros((3, skin.n_vertices, 3), np.float32)
    probes = {
        "n_vertices": lambda: skin.n_vertices, "neighbors": lambda: skin.neighbors, "indices": lambda: skin.indices,
        "weights": lambda: skin.weights, "rest_normals": lambda: skin.rest_normals,
        "deform": lambda: skin.deform(x, r), "deform_sim": lambda: skin.deform_sim(sim),
        "shown_offset": lambda: skin.shown_offset(skinned, skinned, None, *shown),
    }

    def snapshot():
        return [skin.n_vertices, skin.neighbors, skin.indices, skin.weights, skin.rest_normals,
                skin.deform(x, r), normals]

    return Case(skin, lambda: skin.deform(x, r, normals_out=normals), probes, snapshot, "n_vertices")


def _group_case(scale):
    bar = meshes.bar(length=0.6, width=0.3, segments=12, cross=4)
    graph = opdeform.Graph.from_mesh(*bar, particles=100)
    sims = [opdeform.Simulation(graph, 1e6, dt=1 / 60, gravity=(0.0, 0.0, -9.81)) for _ in range(2)]
    for sim, z in zip(sims, (0.15, 0.5)):
        sim.set_state(graph.centers + (0.0, 0.0, z), np.tile(np.eye(3), (graph.n_particles, 1, 1)))
        sim.set_floor(0.0)
    group = opdeform.ContactGroup(sims)
    group.step(20)  # the bars touch: the group keeps forces
    kept = group.save_state()
    probes = {
        "set_contact": lambda: group.set_contact(0.01, 0.2), "step": lambda: group.step(1),
        "save_state": lambda: group.save_state(), "restore_state": lambda: group.restore_state(None),
    }

    def snapshot():
        return [s.positions for s in sims] + [s.velocities for s in sims] + list(group.save_state()) + list(kept)

    return Case(group, lambda: group.step(20 * scale), probes, snapshot, "save_state")


CASES = {"Simulation": _sim_case, "MpmWorld": _world_case, "ContactGroup": _group_case}
if hasattr(_core, "ShapeMatching"):
    CASES["ShapeMatching"] = _shape_matching_case


@pytest.mark.parametrize("type_name", list(CASES) + ["Skin"])
def test_every_call_is_refused_while_busy(type_name, big_mesh):
    make = (lambda scale: _skin_case(big_mesh)) if type_name == "Skin" else CASES[type_name]
    message = re.compile(f"^{type_name} is busy: a call on another thread is running$")
    for scale in (1, 4, 16, 64):
        case = make(scale)
        case.probes.update(_core_probes(case.obj._core))
        cls = type(case.obj)
        expected = (_public(cls) | {n + "=" for n in _setters(cls)}
                    | {"_core." + n for n in _public(type(case.obj._core))})
        assert set(case.probes) == expected, "a public call of the type has no probe here"
        names = list(case.probes)
        outcomes, failure, through = _probe_during(case.run, case.ready, [case.probes[n] for n in names],
                                                   limit=len(names))
        assert failure is None, failure
        if len(outcomes) == len(names) and not through:
            break  # every probe landed inside the run (one got through only if the run ended, or has no guard)
    refused = {name: isinstance(o, RuntimeError) and bool(message.match(str(o))) for name, o in zip(names, outcomes)}
    assert len(outcomes) == len(names) and all(refused.values()), dict(zip(names, outcomes))
    twin = make(scale)
    twin.run()
    np.testing.assert_equal(case.snapshot(), twin.snapshot(), "a refused call changed the object")
