"""The files of a bake (issue 15, item 5), free of bpy. A bake writes ``NAME.pc2.part`` in a folder made (or
checked) before anything in the scene changes; only a bake that wrote frames replaces ``NAME.pc2`` (a rename)
and leaves an ownership record ``NAME.pc2.opdeform`` (the file's size and the time it was written). Free Bake
deletes a PC2 file only when its record matches it: a file the user pointed the Mesh Cache modifier at, or
replaced since, stays."""

import json
import os

PART = ".part"
RECORD = ".opdeform"


class BakeFileError(OSError):
    """The output cannot be made: a message for the user."""


def prepare(path):
    """Creates the folder of ``path`` and returns the path of the file to write (``path`` + PART)."""
    folder = os.path.dirname(path) or "."
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as exc:
        raise BakeFileError(f"cannot create the cache folder {folder!r}: {exc.strerror or exc}") from None
    if not os.access(folder, os.W_OK):
        raise BakeFileError(f"the cache folder {folder!r} is not writable")
    return path + PART


def _record(path):
    st = os.stat(path)
    return {"size": st.st_size, "mtime_ns": st.st_mtime_ns}


def commit(path):
    """Moves the written part over ``path`` and records that the bake owns it."""
    os.replace(path + PART, path)
    with open(path + RECORD, "w") as f:
        json.dump(_record(path), f)


def discard(path):
    if os.path.isfile(path + PART):
        os.remove(path + PART)


def owned(path):
    """Whether ``path`` is the file a bake wrote (its record matches it)."""
    try:
        with open(path + RECORD) as f:
            return json.load(f) == _record(path)
    except (OSError, ValueError):
        return False


def delete(path):
    """Deletes the bake's file and record; returns False (and deletes nothing) for a file it did not write."""
    if not owned(path):
        return False
    os.remove(path)
    os.remove(path + RECORD)
    return True
