"""Contact between opdeform objects, free of bpy: engines whose simulations can step together (the same dt, substeps
and cache range) form one ``opdeform.ContactGroup`` (docs/contact.md) and go to a frame together (core/engine.py
``simulate``); each engine's cache keeps its own states, and the group's state after each frame (the pairs and
forces its next step starts from, ``ContactGroup.save_state``): a group continues from a cached frame with the
forces it had there, and from the start frame with none, so a bake simulates the frames playback showed, bit for
bit.

A group's frames depend on every member, so an engine remembers the group it was simulated in (``partners``):
joining, leaving or a change of the group's contact outdates its whole cache. Before simulating, the members'
plans are made the same: each cache is cut back to the shortest one (a member whose colliders moved outdates the
others' frames after it too), so a bake of one member simulates the whole group again, bit for bit as playback.
The group's gap is the largest of its members' Distance, its friction their mean. A member's skin meets its floor
and colliders, as alone; the bodies meet each other's ellipsoids (core/engine.py; docs/contact.md, "Contact on the
skin": round bodies roll off each other's skins). Members that overlap at rest: where both have a goal, the core
leaves out the pairs their goals put together (docs/contact.md, "Members that overlap at rest"); where not, their
contact pushes them apart from the first step, which ``overlapping`` finds for the panel to say.
"""

import numpy as np

from .engine import simulate

OVERLAP_CHUNK = 256  # particles of one body measured against all of another's at a time (``_deep``)


def _rest(run):
    """A run's particles at rest in the world: its goals (the animated shape) with a goal, else Build's rest; and
    each one's largest radius."""
    graph = run.engine.graph
    return (graph.centers if run.goals is None else run.goals[0]), graph.radii.max(axis=1)


def _deep(a, b):
    """Whether a particle's centre of one body lies within the largest radius of one of the other's."""
    (xa, ra), (xb, rb) = a, b
    for k in range(0, len(xa), OVERLAP_CHUNK):
        near = np.linalg.norm(xa[k:k + OVERLAP_CHUNK, None] - xb[None], axis=2)
        if (near < np.maximum(ra[k:k + OVERLAP_CHUNK, None], rb[None])).any():
            return True
    return False


def overlapping(runs):
    """Pairs (k, l), k < l, of runs stepping together whose bodies overlap at rest without a goal on both (their
    goals' overlap is no contact): their contact pushes them apart from the first step (a body inside a jacket
    without a goal stretched 4x)."""
    rests = [_rest(r) for r in runs]
    return [(k, l) for k in range(len(runs)) for l in range(k + 1, len(runs))
            if (runs[k].goals is None or runs[l].goals is None) and _deep(rests[k], rests[l])]


def partition(runs):
    """Runs (``Engine.begin``'s) in groups that can step together, in their order (a group of one steps alone)."""
    groups = {}
    for r in runs:
        e = r.engine
        groups.setdefault((e.timestep, e.start, e.end), []).append(r)
    return list(groups.values())


def _same_plans(runs):
    return len({(r.plan.kind, r.plan.frame, tuple(r.plan.steps)) for r in runs}) == 1


def _replan(runs, keep_until=None, clear=False):
    for r in runs:
        if clear or keep_until is not None:
            r.engine.invalidate(keep_until)
        r.plan = r.engine.plan(r.frame)


def align(runs):
    """Makes the runs' plans the same: the caches cut back to the shortest (all cleared if that does not do)."""
    if _same_plans(runs):
        return
    lasts = [r.engine.cache.last for r in runs]
    _replan(runs, None if None in lasts else min(lasts), clear=True)
    if not _same_plans(runs):
        _replan(runs, clear=True)


def join(runs, key):
    """Marks the group the runs' engines are simulated in (None: alone); another than before outdates a cache."""
    for r in runs:
        if r.engine.partners != key:
            r.engine.partners = key
            _replan([r], clear=True)


class Bodies:
    """The contact groups in use, re-made when their members or contact change."""

    def __init__(self):
        self.groups = {}  # the members' simulations (ids) -> (contact, ContactGroup)
        self.overlaps = {}  # (the members' simulations (ids), which have no goal) -> ``overlapping``'s pairs

    def clear(self):
        self.groups.clear()
        self.overlaps.clear()

    def keep_only(self, sims):
        """Forgets the groups with a member not among these simulations (ids): a rebuilt or removed object's."""
        self.groups = {k: g for k, g in self.groups.items() if set(k) <= sims}
        self.overlaps = {k: o for k, o in self.overlaps.items() if set(k[0]) <= sims}

    def overlapping(self, runs):
        """``overlapping(runs)``, measured once for the same members with goals on the same ones."""
        key = (tuple(id(r.engine.sim) for r in runs), tuple(r.goals is None for r in runs))
        if key not in self.overlaps:
            self.overlaps[key] = overlapping(runs) if len(runs) > 1 else []
        return self.overlaps[key]

    def _group(self, od, engines):
        members = tuple(id(e.sim) for e in engines)
        contact = (max(e.body_contact[0] for e in engines), sum(e.body_contact[1] for e in engines) / len(engines))
        held = self.groups.get(members)
        if held is None or held[0] != contact:
            # contact forces inside the iterations (docs/contact.md): their warm start is the group's state,
            # cached with the members' (simulate)
            held = self.groups[members] = (contact, od.ContactGroup([e.sim for e in engines], *contact))
        return members, contact, held[1]

    def simulate(self, od, runs, budget=None):
        """The outputs of runs that step together (``partition``), in contact when more than one. Errors as
        ``Engine.goto``'s, the solver's for the whole group."""
        if len(runs) == 1:
            join(runs, None)
            e = runs[0].engine
            return simulate(runs, lambda: e.sim.step(e.timestep[1]), budget)
        members, contact, group = self._group(od, [r.engine for r in runs])
        join(runs, (members, contact))
        align(runs)
        substeps, first = runs[0].engine.timestep[1], runs[0].engine
        frames, kept = iter(runs[0].plan.steps), []

        def step():
            if not kept:  # the frame simulate restored the members to: the group's state there
                group.restore_state(first.cache.contact(first.solver_frame))
                kept.append(None)
            group.step(substeps)
            kept.append((next(frames), group.save_state()))

        try:
            return simulate(runs, step, budget)
        finally:
            for k, state in kept[1:]:
                for r in runs:
                    r.engine.cache.store_contact(k, state)
