"""A hash of the Fig. 4 body after 200 steps and a 500-particle beam after 20: equal hashes mean the same bits."""
import hashlib, os, sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import numpy as np
from opdeform import scenes
from benchmarks.scale import beam
b = scenes.falling_body()
for _ in range(200): b.step()
bm = beam((20, 5, 5))
for _ in range(20): bm.step()
h = hashlib.md5(b.positions.tobytes() + b.rotations.tobytes() + bm.positions.tobytes() + bm.rotations.tobytes()).hexdigest()
print("RESULT", h[:12])
