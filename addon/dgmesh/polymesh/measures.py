"""Numbers the operators report about a result: how many vertices moved, the smallest angle."""

import numpy as np


def moved_count(V: np.ndarray, V0: np.ndarray) -> int:
    """Vertices moved by more than rounding (1e-9 of the mesh's size)."""
    size = float(np.ptp(V0, axis=0).max()) if len(V0) else 0.0
    return int((np.abs(V - V0).max(axis=1) > 1e-9 * max(size, 1e-300)).sum())


def min_angle_deg(V: np.ndarray, F: np.ndarray) -> float:
    """The smallest corner angle of the triangles (V, F), in degrees (0.0 without triangles)."""
    if len(F) == 0:
        return 0.0
    out = 180.0
    for k in range(3):
        a, b, c = V[F[:, k]], V[F[:, (k + 1) % 3]], V[F[:, (k + 2) % 3]]
        u, v = b - a, c - a
        cos = (u * v).sum(1) / np.maximum(np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1), 1e-300)
        out = min(out, float(np.degrees(np.arccos(np.clip(cos, -1, 1))).min()))
    return out
