"""The paper's three scenes: ms/step (median, one thread, wall and processor time) against the paper's 2013
figures (the speed-up and the aim from the wall time)."""

import os

from opdeform import scenes

from .common import median_times, print_aims, table

PAPER_MS = {"fig1 bar": 0.51, "fig2 twist": 0.62, "fig4 body": 2.25}


def _scenes():
    bar = scenes.fig1_bar()
    twist = scenes.TwistedBar()
    frame = [0]

    def twist_step():
        twist.animate(frame[0] / 60.0)
        twist.sim.step()
        frame[0] = (frame[0] + 1) % 240

    body = scenes.falling_body()
    return {"fig1 bar": lambda: bar.step(), "fig2 twist": twist_step, "fig4 body": lambda: body.step()}


def run(args):
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    rows, times = [], {}
    for name, fn in _scenes().items():
        for _ in range(60):  # warm-up: factorization and a settled motion
            fn()
        ms, cpu = median_times(fn, repeats=15, inner=100)
        paper = PAPER_MS[name]
        rows.append((name, f"{ms:.4f}", f"{cpu:.4f}", f"{paper:.2f}", f"{paper / ms:.1f}x",
                     "yes" if paper / ms >= 10 else "NO"))
        times[name] = ms, cpu
    table(rows, ["scene", "ms/step", "cpu ms/step", "paper ms", "speed-up", ">=10x"])
    body = times["fig4 body"][0]
    print_aims([("Fig. 4 body, one thread", f"{body:.4f} ms/step, {PAPER_MS['fig4 body'] / body:.1f}x the paper",
                 "<= 0.112 ms, 20x", body <= 0.112)])
    # issue 26's aims, on processor time: one thread, so it is the step's own time however loaded the machine is
    print_aims([(f"{name}, one thread, processor time", f"{cpu:.4f} ms/step, {PAPER_MS[name] / cpu:.1f}x the paper",
                 f"<= {PAPER_MS[name] / 20:.4f} ms, 20x", PAPER_MS[name] / cpu >= 20)
                for name, (_, cpu) in times.items()], issue=26)
