"""Where the frame handler's time goes on the rigged character, timed in place (issue 24, aim A):
`scripts/bench character --pieces [--hosts blender,bpy-5.2] [--particles 100,1000] [--runs N]` runs this inside
each host, one core, as `scripts/bench character` runs them, one process per run. Inside: the character alone at
N particles (Enable, Goal on, the add-on's defaults) and its armature-only twin in a scene of its own, played
interleaved over frames 1..96; the handler's pieces (blender/playback.py's calls, the colliders' read,
core/engine.py's goal frames and offset) wrapped in process time. Per piece the median of the hops (frames
2..48) and of standing (50..96), ms; "handler-solve" is the handler's total minus the solve, "added-solve"
OPDeform's frame_set minus the twin's minus the solve (what aim A is checked on).

Each run is played twice more with ``--once``: the live objects listed, the rest mesh compared, the settings read
and the colliders read only on the first frame and kept. NOT correct in general (a setting changed, a collider
moved or an edited mesh would not be seen): what reading them only when Blender says they changed could save
at most.
"""

import importlib
import os
import statistics
import sys
import time
import types

PIECES = (  # label, module (relative to the add-on), attribute
    ("live objects listed", "blender.playback", "live_dynamic"),
    ("rest mesh compared", "blender.playback", "ensure"),
    ("settings read", "blender.runtime", "settings_key"),
    ("configure", "blender.playback", "configure"),
    ("maps compared", "blender.runtime", "changed_maps"),
    ("input read", "blender.playback", "frame_input"),
    ("colliders read", "blender.colliders", "surroundings"),
    ("begin", "core.engine", "Engine.begin"),
    ("goal frames", "core.engine", "Engine.goal_frames"),
    ("offset made", "core.engine", "Engine._emit"),
    ("offset shown", "blender.playback", "show"),
    ("handler", "blender.playback", "simulate_frame"),
)
ONCE = (("blender.playback", "live_dynamic"), ("blender.runtime", "settings_key"),
        ("blender.colliders", "surroundings"), ("blender.playback", "ensure"))


def _owner(addon, module, name):
    owner = importlib.import_module(f"{addon}.{module}")
    if "." in name:
        cls, name = name.split(".")
        owner = getattr(owner, cls)
    return owner, name


def _timed(owner, name, label, spent):
    fn = getattr(owner, name)

    def timed(*args, **kw):
        t = time.process_time()
        try:
            return fn(*args, **kw)
        finally:
            spent[label] = spent.get(label, 0.0) + time.process_time() - t
    setattr(owner, name, timed)


def _kept_once(owner, name):
    fn, kept = getattr(owner, name), []

    def once(*args, **kw):
        if not kept or not kept[0]:  # nothing live before Enable: read until there is
            kept[:] = [fn(*args, **kw)]
        return kept[0]
    setattr(owner, name, once)


def inside(particles, once):
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    sys.path.insert(0, os.path.join(root, "tests", "blender"))
    import character_scene as C
    import helpers as H
    H.fresh()
    character = C.build()
    plain, _ = C.variant_scene("plain", character)
    scene, obj = C.variant_scene("opdeform", character)
    C.enable(obj, particles=particles)
    if once:
        for module, name in ONCE:
            _kept_once(*_owner(H.ADDON, module, name))
    spent = {}
    for label, module, name in PIECES:
        owner, attr = _owner(H.ADDON, module, name)
        _timed(owner, attr, label, spent)
    clock = types.SimpleNamespace(perf_counter=time.process_time)
    for module in ("core.engine", "blender.playback"):
        importlib.import_module(f"{H.ADDON}.{module}").time = clock
    engine = H.runtime().get(obj).engine
    rows = []
    for f in range(1, C.FRAMES + 1):
        spent.clear()
        t = time.process_time()
        plain.frame_set(f)
        armature = time.process_time() - t
        t = time.process_time()
        scene.frame_set(f)
        total = time.process_time() - t
        assert not obj.opdeform.error, obj.opdeform.error
        solve = engine.timing["solver"]
        rows.append(dict(spent, **{"handler-solve": spent["handler"] - solve, "added-solve": total - armature - solve}))
    hops, still = rows[1:C.MOTION_END - 1], rows[C.MOTION_END:]
    for label in [p[0] for p in PIECES] + ["handler-solve", "added-solve"]:
        ms = [1e3 * statistics.median(r.get(label, 0.0) for r in part) for part in (hops, still)]
        print(f"PIECE {label}: {ms[0]:.3f} {ms[1]:.3f}")
    print("PIECES_DONE")


def run(args):
    """Every host, particle count and run in turns; per piece the median of the runs, its range beside."""
    import subprocess
    from . import character
    hosts = args[args.index("--hosts") + 1].split(",") if "--hosts" in args else ["blender", "bpy-5.2"]
    counts = args[args.index("--particles") + 1].split(",") if "--particles" in args else ["100", "1000"]
    runs = int(args[args.index("--runs") + 1]) if "--runs" in args else 3
    for name, cmd in character._hosts(hosts):
        if cmd is None:
            print(f"{name}: not installed (scripts/setup-bpy)")
            continue
        cmd = [os.path.abspath(__file__) if c == character.HERE else c for c in cmd]
        for count in counts:
            found = {}
            for _ in range(runs):
                for way in ("as is", "--once"):
                    proc = subprocess.run(cmd + ["--inside", count, way], capture_output=True, text=True,
                                          env=character._env(), timeout=1800, preexec_fn=character._limit)
                    if "PIECES_DONE" not in proc.stdout:
                        print(f"{name} failed\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
                        return
                    for line in proc.stdout.splitlines():
                        if line.startswith("PIECE "):
                            label, values = line[6:].split(": ")
                            found.setdefault((label, way), []).append([float(v) for v in values.split()])
            _print(name, count, runs, found)
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} ({os.cpu_count()} cores)")


def _print(host, count, runs, found):
    print(f"{host}, {count} particles, {runs} runs: ms in place, hops / standing, median of the runs (range)")
    for label in [p[0] for p in PIECES] + ["handler-solve", "added-solve"]:
        cells = []
        for way in ("as is", "--once"):
            values = found.get((label, way), [])
            cells.append(" / ".join(f"{statistics.median(v):.3f} ({min(v):.3f}-{max(v):.3f})"
                                    for v in zip(*values)))
        print(f"  {label:22s} {cells[0]:34s} once: {cells[1]}")


if __name__ == "__main__" and "--inside" in sys.argv:
    argv = sys.argv[sys.argv.index("--inside"):]
    inside(int(argv[1]), argv[2] == "--once")
