"""A far jump fills the add-on's frame cache to its cap; the process must grow by about the cap, not more
(issue 28: the cap counted each array's exact bytes, and Blender's allocator on Linux, jemalloc, rounds a
block up to its size class: a jump of 100,000 frames held 298 MiB for 256 counted). Run in a fresh process
(a suite's earlier tests leave freed memory the cache then reuses, which hides the growth); resident memory
from /proc (Linux). Prints CACHE_MEMORY {json} and exits 1 past the bound.

    blender -b --factory-startup --python-exit-code 1 -P check_cache_memory.py
    <python with bpy> check_cache_memory.py
"""

import json
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import helpers as H  # noqa: E402

CAP = 128 * 2 ** 20
FAR = 100_000
SLACK = 1.05  # of the cap, plus what the jump itself keeps without a cache (+5 MiB with a 1 MB cap)
BESIDE = 6 * 2 ** 20


def resident():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


H.fresh()
scene = bpy.context.scene
scene.frame_end = FAR
obj = H.bar_object(particles=20)
bpy.ops.opdeform.enable(object=obj.name)
obj.opdeform.use_frame_rate_substeps = False
scene.frame_set(1)
scene.frame_set(2)
rt = H.runtime().get(obj)
rt.engine.cache.max_bytes = CAP
before = resident()
scene.frame_set(FAR)
grown = resident() - before
row = {"host": H.host(), "grown_mib": grown / 2 ** 20, "cap_mib": CAP / 2 ** 20, "frames": len(rt.engine.cache),
       "counted_mib": rt.engine.cache.bytes / 2 ** 20, "shown": list(rt.shown), "error": obj.opdeform.error}
print("CACHE_MEMORY " + json.dumps(row))
H.cleanup()
ok = rt.shown == ("frame", FAR) and not obj.opdeform.error and grown <= SLACK * CAP + BESIDE
sys.exit(0 if ok else 1)
