"""A tail pulled past its own body (docs/contact.md, "A tail pulled past its body"; issue 27).

    PYTHONPATH=build/python python3 scripts/self_contact_tail.py

tests/test_body_contact.py's two scenes: the 1.2 m capsule of scenes.bent_rod (k = 1e5, 60 particles, 1/60 s)
whose tip is carried on a half circle onto its held root (sweep 1) and past it (1.2), by a pin or by goals
of strength 0.5, 0.9 and 1.0 (the root on goals of strength 1), with and without self-contact. Printed per
case: the least distance of the two ends' particles less their largest radii over the motion (< 0: closer
than their largest radii), the tip end's last height (the root at z = 0; < 0: the tip ended below it, round
the root or through it) and the deepest overlap of the tip end's ellipsoids with those of the far half of the
body over the motion (along their centre lines; > 0: one inside the other, which going round never needs).
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
from test_body_contact import _bend_end_onto_end, _goal_tail  # noqa: E402  (the tests' scenes, not a copy)


def main():
    print("pull          sweep  self-contact  least (m)  tip end's height (m)  deepest overlap (mm)")
    for self_contact in (False, True):
        for sweep in (1.0, 1.2):
            least, height, deepest = _bend_end_onto_end(self_contact, sweep)
            print(f"pin           {sweep:5.1f}  {str(self_contact):12}  {least:9.4f}  {height:20.3f}  {1e3 * deepest:20.1f}")
        for strength in (0.5, 0.9, 1.0):
            least, height, deepest = _goal_tail(strength, self_contact)
            print(f"goal {strength:3.1f}      1.2    {str(self_contact):12}  {least:9.4f}  {height:20.3f}  {1e3 * deepest:20.1f}")


if __name__ == "__main__":
    main()
