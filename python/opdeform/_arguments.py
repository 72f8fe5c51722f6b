"""The argument converters of every opdeform call: any array-like or number in, what the core reads out.

The rule: a wrong value for a number or array argument (None, a string, NaN, a complex number, a wrong shape) raises
ValueError naming the argument; an object of the wrong class where an opdeform object
is required raises TypeError naming the expected type (checked where that object is used).
"""

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["ArrayLike", "Floats", "Ints", "Vector", "as_array", "choice", "integer", "number", "vector"]

# The types of the API's annotations: ArrayLike what an array argument accepts (numpy arrays, nested lists or
# tuples of numbers), Floats and Ints what the calls return, Vector a point or direction (x, y, z).
ArrayLike = npt.ArrayLike
Floats = npt.NDArray[np.float64]
Ints = npt.NDArray[np.int32]
Vector = Sequence[float] | npt.NDArray[Any]


def as_array(name: str, value: ArrayLike | None, shape: Sequence[int | None],
             dtype: npt.DTypeLike = np.float64) -> npt.NDArray[Any]:
    """``value`` as a C-contiguous array of ``shape`` (None = any length); ValueError naming ``name``. An array
    already so (every per-frame call of the add-on) is returned as it is, unchecked further: 3-5 us a call less."""
    if (type(value) is np.ndarray and value.dtype == dtype and value.flags.c_contiguous
            and value.ndim == len(shape) and all(s is None or s == a for s, a in zip(shape, value.shape))):
        return value
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{name}: not an array of numbers ({exc})") from None
    known = [s for s in shape[1:] if s is not None]
    if arr.size == 0 and len(shape) > 1 and shape[0] is None and len(known) == len(shape) - 1:
        arr = arr.reshape((0, *known))  # not with a second length unknown: refused below as of the wrong shape
    if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    if np.iscomplexobj(arr):  # numpy would drop the imaginary part with only a warning
        raise ValueError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    if np.issubdtype(dtype, np.integer):
        if arr.size and not np.issubdtype(arr.dtype, np.integer):
            if not np.issubdtype(arr.dtype, np.number) or not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
                raise ValueError(f"{name} must hold integers")
        if arr.size and (arr.min() < np.iinfo(dtype).min or arr.max() > np.iinfo(dtype).max):
            raise ValueError(f"{name} holds values outside the {np.dtype(dtype).name} range")
    elif arr.size and not (np.issubdtype(arr.dtype, np.number) or arr.dtype == np.bool_):
        raise ValueError(f"{name} must hold numbers, got dtype {arr.dtype}")
    return np.ascontiguousarray(arr, dtype=dtype)


def number(name: str, value: Any) -> float:
    """A finite float (None, strings, complex numbers, NaN and infinities refused; the core checks the range)."""
    try:
        x = None if isinstance(value, (str, bytes, complex, np.complexfloating)) else float(value)
    except (TypeError, ValueError):
        x = None
    if x is None or not math.isfinite(x):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return x


_INT32 = (-2 ** 31, 2 ** 31 - 1)


def integer(name: str, value: object, bounds: tuple[int, int] | None = _INT32) -> int:
    """An int (bool and float refused, numpy integers accepted) within ``bounds`` (default: the C int the
    core takes; None: any), else ValueError naming the argument (not OverflowError from the binding)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    value = int(value)
    if bounds is not None and not bounds[0] <= value <= bounds[1]:
        raise ValueError(f"{name} = {value} is out of range: it must be in [{bounds[0]}, {bounds[1]}]")
    return value


_WORDS = {2: "two", 3: "three"}


def vector(name: str, value: ArrayLike, size: int = 3) -> tuple[float, ...]:
    """``size`` finite floats as a tuple; fast for tuples, lists and 1-D arrays."""
    real = (int, float, np.integer, np.floating)
    items: Any = value  # a tuple or list of numbers once converted
    if isinstance(items, np.ndarray) and items.shape == (size,) and issubclass(items.dtype.type, real):
        items = items.tolist()
    if not (isinstance(items, (tuple, list)) and len(items) == size and all(isinstance(x, real) for x in items)):
        items = as_array(name, items, (size,)).tolist()
    result = tuple(float(x) for x in items)
    if not all(math.isfinite(x) for x in result):
        raise ValueError(f"{name} must be {_WORDS.get(size, size)} finite numbers, got {items!r}")
    return result


def choice(name: str, value: object, options: dict[Any, Any] | Sequence[Any]) -> Any:
    """options[value] (a dict or a sequence: its index); ValueError naming the argument otherwise."""
    try:
        found = value in options
    except TypeError:  # an unhashable value
        found = False
    if not found:
        listed = sorted(options) if isinstance(options, dict) else list(options)
        raise ValueError(f"{name} must be one of {listed}, got {value!r}")
    return options[value] if isinstance(options, dict) else options.index(value)
