"""Simulations that collide with each other (``opdeform.ContactGroup``, docs/contact.md)."""

from collections.abc import Sequence

import numpy as np

from . import _core
from ._arguments import ArrayLike, Floats, Ints, integer, number
from ._saved import int32_pairs
from .simulation import Simulation

__all__ = ["ContactGroup"]

PAIR_VALUES = 10  # a pair's forces in the group's state (OD_PAIR_VALUES, csrc/include/opdeform/colliders.h)


class ContactGroup:
    """Two or more simulations whose particles collide: ``step`` advances them all together (each as its own
    ``step`` would, with its floor, colliders, fields and self-contact), their iterations side by side:
    particles of different bodies closer than ``thickness`` (m) push each other apart with forces inside
    every solve, with Coulomb ``friction`` against their slip (a pair that sticks pulled back towards where it
    began to stick), and what is still in contact after the iterations is pushed apart along the line between
    their centres, mass weighted. A body dropped on
    another comes to rest on it. ``in_iterations=False``: the push after the iterations only (the earlier
    model: a stack does not stay, but a step depends on the simulations' states alone, not on the forces the
    group kept from its last step). The simulations must share dt; while the group steps, each of them is
    busy. The forces the group keeps between steps are part of its state: ``save_state`` and ``restore_state``
    with the members' states (``Simulation.set_state``) make a step again bit for bit. Members whose goals carry
    the rest (``set_goals_carry_rest``) do not collide where their goals put them together (goal centres closer
    than 1.5 times the sum of two particles' largest reaches): a jacket on its body follows one animation."""

    def __init__(self, sims: Sequence[Simulation], thickness: float = 0.005, friction: float = 0.5,
                 in_iterations: bool = True) -> None:
        sims = list(sims)
        for k, sim in enumerate(sims):
            if not isinstance(sim, Simulation):
                raise TypeError(f"sims[{k}] must be an opdeform.Simulation, got {type(sim).__name__}")
        self.sims = tuple(sims)
        self._core = _core.ContactGroup([sim._core for sim in sims], number("thickness", thickness),
                                        number("friction", friction), bool(in_iterations))

    def set_contact(self, thickness: float = 0.005, friction: float = 0.5, in_iterations: bool = True) -> None:
        """The gap (m, > 0) and Coulomb friction between the bodies, and whether contact acts inside the
        iterations (docs/contact.md)."""
        self._core.set_contact(number("thickness", thickness), number("friction", friction), bool(in_iterations))

    def step(self, steps: int = 1) -> None:
        """Advances every simulation ``steps`` time steps, in contact. On a non-finite result raises
        SolverError; each simulation keeps its state from before the call."""
        self._core.step(integer("steps", steps))
        for sim in self.sims:
            sim._colliders_arrived()

    def save_state(self) -> tuple[Ints, Floats]:
        """What the group keeps from one step to the next besides its members' states: its pairs of particles
        ((m, 2) int32, indices over the members' particles in order) and their forces ((m, 10) float64: the
        normal force, the friction force, the normal and the friction's anchor, where the second particle was
        from the first when the pair began to stick, turned with the first particle since), the warm start of the
        next step's forces. Restored
        together with the members' states, the next step is the one that followed the save, bit for bit."""
        m = self._core.pair_count()
        pairs, forces = np.empty((m, 2), np.int32), np.empty((m, PAIR_VALUES))
        self._core.read_pairs(pairs, forces)
        return pairs, forces

    def restore_state(self, state: tuple[ArrayLike, ArrayLike] | None) -> None:
        """Sets what ``save_state`` returned (of this group or one of the same members); ``None``: a new group's
        (no forces). ValueError on pairs out of range (never wrapped to int32) or forces out of range
        (docs/hardening.md), nothing changed."""
        if state is None:
            pairs, forces = np.empty((0, 2), np.int32), np.empty((0, PAIR_VALUES))
        else:
            given_pairs, given_forces = state
            pairs, forces = int32_pairs(given_pairs), np.ascontiguousarray(given_forces, np.float64)
            if pairs.ndim != 2 or pairs.shape[1] != 2 or forces.shape != (len(pairs), PAIR_VALUES):
                raise ValueError(f"state: pairs (m, 2) and forces (m, {PAIR_VALUES}) expected, got {pairs.shape} and "
                                 f"{forces.shape}")
        self._core.write_pairs(pairs, forces)
