"""Why a mesh edge stretches (issue 24, docs/goals.md "Edges that stretch"): reads the npz that
`OUTSIDE_RIGS_STRETCH=FILE scripts/outside_rigs.py ...` writes and prints the worst mesh edge over its
armature-only length, its vertices' skinning particles (weights, distances, Follow, softness), those particles'
offsets and turns from their goal frames, the particle graph's edges over their goal-shape lengths and the turns
between neighbours, and the worst edge skinned again from the particles' positions with the goals' rotations and
the reverse (which of the two stretches it), and each skinning particle's calibrated k against the body's.

    python3 scripts/stretch_cause.py FILE.npz
"""
import sys

import numpy as np


def angle(r):
    return np.degrees(np.arccos(np.clip((np.trace(r, axis1=-2, axis2=-1) - 1) / 2, -1, 1)))


def skinned(d, positions, rotations, v):
    idx, w, x, c = d["skin_indices"][v], d["skin_weights"][v], d["rest"][v], d["centers"]
    return sum(w[k] * (positions[idx[k]] + rotations[idx[k]] @ (x - c[idx[k]])) for k in range(len(idx)))


def main(path):
    d = np.load(path)
    shown, rig, (i, j) = d["shown"], d["armature_only"], d["edges"].T
    ratio = np.linalg.norm(shown[:, i] - shown[:, j], axis=2) / np.linalg.norm(rig[:, i] - rig[:, j], axis=2)
    f, e = np.unravel_index(np.argmax(ratio), ratio.shape)
    a, b = d["edges"][e]
    length = np.linalg.norm(rig[f, a] - rig[f, b])
    print(f"mesh edge {a}-{b} {ratio[f, e]:.2f}x its {1e3 * length:.1f} mm at frame {f + 1}; "
          f"{(ratio.max(0) > 1.5).sum()} edges over 1.5x")
    p, r, gp, gr = d["positions"][f], d["rotations"][f], d["goal_positions"][f], d["goal_rotations"][f]
    for v in (a, b):
        idx = d["skin_indices"][v]
        print(f"  vertex {v}: particles {idx}, weights {d['skin_weights'][v].round(2)}, "
              f"{(1e3 * np.linalg.norm(d['centers'][idx] - d['rest'][v], axis=1)).round(1)} mm away, "
              f"Follow {d['follow'][idx].round(2)}, softness {d['softness'][idx].round(3)}")
    stiffness = np.broadcast_to(d["stiffness"], d["softness"].shape) / d["softness"]  # before the softness map
    for k in np.unique(d["skin_indices"][[a, b]]):
        print(f"  particle {k}: {1e3 * np.linalg.norm(p[k] - gp[k]):.1f} mm and {angle(r[k] @ gr[k].T):.1f} deg "
              f"off its goal, its k before the softness 1/{np.median(stiffness) / stiffness[k]:.0f} of the median")
    ge = d["graph_edges"]
    P, GP = d["positions"], d["goal_positions"]
    graph = (np.linalg.norm(P[:, ge[:, 0]] - P[:, ge[:, 1]], axis=2)
             / np.linalg.norm(GP[:, ge[:, 0]] - GP[:, ge[:, 1]], axis=2))
    dev = np.einsum("fnij,fnkj->fnik", d["rotations"], d["goal_rotations"])
    turn = angle(np.einsum("feji,fejk->feik", dev[:, ge[:, 0]], dev[:, ge[:, 1]]))
    print(f"particle graph: {len(d['centers'])} particles, edges {graph.min():.2f}-{graph.max():.2f}x their goal "
          f"length ({(graph.max(0) > 1.3).sum()} over 1.3x), neighbours turned up to {turn.max():.1f} deg apart")
    for name, pos, rot in (("positions, the goals' rotations", p, gr), ("rotations, the goals' positions", gp, r)):
        stretch = np.linalg.norm(skinned(d, pos, rot, a) - skinned(d, pos, rot, b)) / length
        print(f"  the edge skinned from the particles' {name}: {stretch:.2f}x")


if __name__ == "__main__":
    main(sys.argv[1])
