"""Pickling by the arguments an object was made from: for objects whose whole state is what their
constructor computed (Skin, GoalFit), a pickle stores those arguments and unpickling makes the object again.
The constructor checks them as any call, but ``pickle.loads`` runs whatever a crafted pickle names before that:
unpickle only trusted files; elsewhere store the arguments as arrays and call the constructor."""

from typing import Any

__all__ = ["FromArguments"]


class FromArguments:
    """Set ``self._args`` (the constructor's arguments, copied) in ``__init__``; pickling does the rest."""

    _args: tuple[Any, ...] = ()

    def __getstate__(self) -> tuple[Any, ...]:
        return self._args

    def __setstate__(self, args: tuple[Any, ...]) -> None:
        type(self).__init__(self, *args)
