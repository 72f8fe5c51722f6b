"""The Fig. 4 body (scenes.falling_body): processor time per step, one thread (scripts/speed/side-by-side)."""
import os, time
os.environ.setdefault("OMP_NUM_THREADS", "1")
from opdeform import scenes
body = scenes.falling_body()
for _ in range(60): body.step()
t = time.process_time()
n = int(os.environ.get("N", 40000))
for _ in range(n): body.step()
print("RESULT body_ms=%.4f" % ((time.process_time() - t) * 1e3 / n))
