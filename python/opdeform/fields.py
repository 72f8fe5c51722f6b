"""Force fields (docs/forces.md): wind, point force, vortex and turbulence with falloff and drag, the same on
a ``Simulation`` (they enter each step's prediction) and an ``mpm.World`` (they act on its grid)."""

from typing import Any

from ._arguments import Vector, choice, integer, number, vector

__all__ = ["FIELD_KINDS", "ForceFields"]

FIELD_KINDS = ("wind", "force", "vortex", "turbulence")


class ForceFields:
    """The force-field methods of a class whose core object has ``force_field(op, ...)``."""

    _core: Any  # the class's core object

    def add_force_field(self, kind: str = "wind", strength: float = 1.0, position: Vector = (0.0, 0.0, 0.0),
                        direction: Vector = (0.0, 0.0, 1.0), turbulence: float = 0.0, size: float = 1.0,
                        falloff: float = 0.0, min_distance: float = 0.0, max_distance: float = 0.0, drag: float = 0.0,
                        seed: int = 1) -> int:
        """A force field; returns its id. ``kind``: "wind" (``strength`` m/s² along ``direction``, plus
        ``turbulence`` times that of noise with features of ``size`` m), "force" (from ``position`` outwards;
        negative attracts), "vortex" (about the axis through ``position`` along ``direction``,
        counter-clockwise for strength > 0) or "turbulence" (noise of ``size``). Scale ``strength`` by the
        object's effector weight. Falloff: full within ``min_distance``, (1 + r - min_distance) ** -falloff
        beyond, nothing past ``max_distance`` (0: unlimited); r along the axis for wind, from ``position``
        else. ``drag`` (1/s) slows velocities implicitly: in a wind, a body tends to strength / drag. A NaN
        or out-of-range value raises ValueError naming it, nothing added."""
        args = (choice("kind", kind, FIELD_KINDS), number("strength", strength), vector("position", position),
                vector("direction", direction), number("turbulence", turbulence), number("size", size),
                number("falloff", falloff), number("min_distance", min_distance),
                number("max_distance", max_distance), number("drag", drag), integer("seed", seed) & 0xFFFFFFFF)
        id = self._core.force_field("add", *args)
        self._field_call("add_force_field", (kind, strength, position, direction, turbulence, size, falloff,
                                             min_distance, max_distance, drag, seed))
        return id

    def move_force_field(self, id: int, position: Vector, direction: Vector | None = None) -> None:
        """A field's new origin and axis (None keeps the axis); unknown ids raise IndexError."""
        axis = None if direction is None else vector("direction", direction)
        self._core.force_field("move", integer("id", id), vector("position", position), axis)
        self._field_call("move_force_field", (id, position, direction))

    def remove_force_field(self, id: int) -> None:
        """Removes a field; unknown ids raise IndexError."""
        self._core.force_field("remove", integer("id", id))
        self._field_call("remove_force_field", (id,))

    @property
    def n_force_fields(self) -> int:
        """How many force fields act."""
        return self._core.force_field("count")

    def _field_call(self, name: str, args: tuple[Any, ...]) -> None:
        """Records a field call where the class replays its calls to unpickle (mpm.World); else nothing."""
        calls = getattr(self, "_calls", None)
        if calls is not None:
            calls.append((name, args))
