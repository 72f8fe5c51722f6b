"""The armature tail's figures for docs/blender.md: tip angle per frame for goal strengths 0.2, 0.5 and 1 and
the animation, tip lag during the swing, overshoot, settle frame and the frame handler's time.

    OPDEFORM_PYTHONPATH=$PWD/build/python scripts/blender -b --factory-startup -P tests/blender/goal_tail_figure.py -- tail.json
    python3 tests/blender/goal_tail_figure.py tail.json docs/images/blender_goal_tail.png   # the plot (matplotlib)
"""

import json
import os
import sys

import numpy as np

STRENGTHS = (0.2, 0.5, 1.0)


def measure(path):
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import helpers as H
    out = {}
    for strength in STRENGTHS:
        H.fresh()
        tail = H.tail_rig(strength)
        motion = H.tail_motion(tail, range(1, 6 * H.FPS + 1))
        ms = H.runtime().get(tail).timing["total"] * 1000
        deviation = np.array([d for _, _, d in motion])
        lag = [float(np.linalg.norm(o - a)) for o, a, _ in motion]
        angle = np.degrees([np.arctan2(o[1], o[0]) for o, _, _ in motion])
        out[str(strength)] = dict(
            angle=angle.tolist(), animation=np.degrees([np.arctan2(a[1], a[0]) for _, a, _ in motion]).tolist(),
            lag_m=max(lag[:H.SWING_FRAMES + 1]), overshoot_deg=float((angle[H.SWING_FRAMES:] - 60.0).max()),
            settle_frame=next((i + 1 for i in range(len(deviation)) if deviation[i:].max() < 2e-3), None),
            handler_ms=ms)
        print(strength, {k: v for k, v in out[str(strength)].items() if k not in ("angle", "animation")})
    with open(path, "w") as f:
        json.dump(out, f)


def plot(path, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    data = json.load(open(path))
    fig, ax = plt.subplots(figsize=(6.4, 3.2), dpi=100)
    t = np.arange(1, len(data["1.0"]["angle"]) + 1) / 24.0
    ax.plot(t, data["1.0"]["animation"], "k--", lw=1, label="animation (Armature)")
    for key, color in (("0.2", "tab:red"), ("0.5", "tab:blue"), ("1.0", "tab:green")):
        ax.plot(t, data[key]["angle"], color=color, lw=1.2, label=f"goal strength {key}")
    ax.set(xlabel="time (s)", ylabel="tip angle (degrees)", xlim=(0, 4), title="2 m tail, root bone swings 60° in 0.5 s")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(png)


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    measure(args[0]) if len(args) == 1 else plot(*args)
