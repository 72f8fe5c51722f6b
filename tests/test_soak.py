"""Soak (docs/hardening.md): a jiggling body with its handles moved and its mesh skinned every frame. The short
form runs here (1,000 steps; 400 under the sanitizers); `scripts/bench soak` and `scripts/fuzz soak` run the
10,000-step form with the same limits (tests/soak_scene.py)."""

import os

import soak_scene

SANITIZED = bool(os.environ.get("OPDEFORM_SANITIZED"))


def test_soak_short():
    steps = 400 if SANITIZED else 1000
    result = soak_scene.run(steps)
    # Under AddressSanitizer freed memory sits in quarantine, so resident memory is no measure there (its
    # leak checker is); the C-core allocation count still is.
    assert not soak_scene.failures(result, check_rss=not SANITIZED), soak_scene.failures(result, not SANITIZED)
    assert result["steps"] == steps
