"""Checks of pickled state before anything is made from it (issue 28: a pickle is untrusted input).

A Simulation unpickles by replaying its calls: the checks here bound what the replay would do (how many
constraint and collider ids it issues, which methods it calls) and that its records agree with each other, so
that a damaged or crafted pickle raises ValueError or TypeError naming the entry before the replay starts,
never a MemoryError hours later. The values themselves (points, weights, arrays) are checked by the calls the
replay makes, as for any caller. ContactGroup pairs are converted to int32 only when they fit.
"""

from typing import Any

import numpy as np

from ._arguments import Ints, integer

__all__ = ["check_simulation", "int32_pairs", "MAX_REPLAYED_IDS"]

# Constraint or collider ids a Simulation's pickle may make the replay issue (each removed one is added and
# removed again): about 10 s of replay at the measured 10 µs per id (tests/test_state_loading.py).
MAX_REPLAYED_IDS = 1_000_000
SIMULATION_KEYS = ("graph", "params", "stiffness_scale", "solver", "trace_energy", "floor", "goal_hz", "goal_frames",
                   "constraints", "history", "ids_before", "targets", "state", "fields", "colliders", "collider_ids",
                   "self_contact")
FIELD_CALLS = ("add_force_field", "move_force_field", "remove_force_field")


def check_simulation(saved: object) -> None:
    """Raises naming the first entry of a Simulation's pickled state that the replay could not use."""
    if not isinstance(saved, dict):
        raise TypeError(f"saved Simulation: a dict expected, got {type(saved).__name__}")
    missing = [key for key in SIMULATION_KEYS if key not in saved]
    if missing:
        raise ValueError(f"saved Simulation: missing {missing}")
    live = _check_history(saved["ids_before"], saved["history"])
    for key in ("constraints", "targets"):
        records = saved[key]
        if not isinstance(records, dict) or set(records) != live:
            raise ValueError(f"{key}: the live constraint ids {sorted(live)[:8]} expected, got "
                             f"{sorted(records)[:8] if isinstance(records, dict) else type(records).__name__}")
    for id, record in saved["constraints"].items():
        if not (isinstance(record, (list, tuple)) and len(record) == 4 and record[0] in (0, 1)):
            raise ValueError(f"constraints[{id}]: [kind 0 or 1, point, direction, weight] expected, got {record!r:.80}")
    _check_colliders(saved["collider_ids"], saved["colliders"])
    _check_fields(saved["fields"])
    _check_goal_motion(saved.get("goal_motion"))
    _check_surface_forces(saved.get("surface_forces"))
    _check_contact_skin(saved.get("contact_skin"))


def _check_history(ids_before: object, history: object) -> set[int]:
    """The adds (ids in issue order) and removals (~id of a live one) since the set was last empty; returns
    the live ids."""
    ids_before = integer("ids_before", ids_before, (0, MAX_REPLAYED_IDS))
    most = 2 * (MAX_REPLAYED_IDS - ids_before)  # each add at most once removed
    if not isinstance(history, list) or len(history) > most:
        raise ValueError(f"history: a list of at most {most} ids expected (ids_before = {ids_before}: a pickle may "
                         f"replay at most {MAX_REPLAYED_IDS} constraint ids)")
    live: set[int] = set()
    next_id = ids_before
    for k, op in enumerate(history):
        op = integer(f"history[{k}]", op)
        if op >= 0 and op != next_id:
            raise ValueError(f"history[{k}] = {op}: the next add gets id {next_id}")
        if op < 0 and ~op not in live:
            raise ValueError(f"history[{k}] removes {~op}, which is not live")
        live.symmetric_difference_update((op if op >= 0 else ~op,))
        next_id += op >= 0
        if next_id > MAX_REPLAYED_IDS:
            raise ValueError(f"ids_before + the adds in history = {next_id}: a pickle may replay at most "
                             f"{MAX_REPLAYED_IDS} constraint ids")
    return live


def _check_colliders(collider_ids: object, colliders: object) -> None:
    count = integer("collider_ids", collider_ids, (0, MAX_REPLAYED_IDS))
    if not isinstance(colliders, dict) or not all(isinstance(id, int) and 0 <= id < count for id in colliders):
        raise ValueError(f"colliders: a dict of ids in [0, {count}) expected")
    for id, c in colliders.items():
        if not (isinstance(c, dict) and isinstance(c.get("args"), dict) and "frame" in c and "target" in c):
            raise ValueError(f"colliders[{id}]: a dict of args, frame and target expected")


def _check_fields(fields: object) -> None:
    if not isinstance(fields, list):
        raise ValueError(f"fields: a list of (name, arguments) expected, got {type(fields).__name__}")
    for k, call in enumerate(fields):
        if not (isinstance(call, tuple) and len(call) == 2 and call[0] in FIELD_CALLS and isinstance(call[1], tuple)):
            raise ValueError(f"fields[{k}]: one of {FIELD_CALLS} with a tuple of arguments expected, got {call!r:.80}")


def _check_goal_motion(motion: object) -> None:
    if motion is None:
        return
    if not (isinstance(motion, (tuple, list)) and len(motion) == 3):
        raise ValueError("goal_motion: (velocities, angular_velocities, steps) or None expected")
    integer("goal_motion steps", motion[2], (-1, 2**31 - 1))


def _check_surface_forces(carried: object) -> None:
    if carried is not None and not (isinstance(carried, (tuple, list)) and len(carried) == 2):
        raise ValueError("surface_forces: (forces, surfaces) or None expected")


def _check_contact_skin(skin: object) -> None:
    if skin is not None and not (isinstance(skin, (tuple, list)) and len(skin) == 4):
        raise ValueError("contact_skin: (rest vertices, indices, weights, bodies) or None expected")


def int32_pairs(pairs: Any) -> Ints:
    """ContactGroup pairs as int32, refused (ValueError naming them) unless they are integers that fit."""
    arr = np.asarray(pairs)
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        raise ValueError(f"pairs: integers expected, got {arr.dtype}")
    if arr.size and (arr.min() < -2**31 or arr.max() > 2**31 - 1):
        raise ValueError(f"pairs: particle indices in [0, 2^31) expected, got {arr.min()} to {arr.max()}")
    return np.ascontiguousarray(arr, np.int32)
