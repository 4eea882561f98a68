"""The noisy meshes of the step-rule fit (bench/notes/denoise.md), shared by its scripts: sweep.py and
sweep_op.py make them, the others read sweep.py's rows back and make the same noisy mesh again."""
import numpy as np
from bench.common import cgal_mesh
from dgmesh import estimate_noise, shapes
from bench.workloads.denoise import add_noise, add_noise_isotropic


def noisy(V, F, kind, level, seed0):
    """V with `kind` ("normal" or "isotropic") noise of `level` mean edge lengths, seeded as in sweep.py."""
    return (add_noise if kind == "normal" else add_noise_isotropic)(V, F, level, seed0 + int(level * 1000))


def sweep_inputs(models, levels, seed0):
    """(key, clean vertices, faces, noisy vertices, their noise estimate) for every model, noise kind and
    level of a sweep, in the order and with the row keys of sweep.py and sweep_op.py."""
    for name in models:
        V, F = cgal_mesh(name)
        V, F = np.asarray(V, float), np.asarray(F)
        for kind in ("normal", "isotropic"):
            for level in levels:
                Vn = noisy(V, F, kind, level, seed0)
                yield f"{name} {kind} {level}", V, F, Vn, estimate_noise(Vn, F)


def sweep_rows(rows, seed0):
    """(key, row, noisy vertices, faces) for every row of a sweep.py output made with seed0."""
    meshes = {}
    for key, row in rows.items():
        name, kind, level = key.split()
        if name not in meshes:
            V, F = cgal_mesh(name)
            meshes[name] = (np.asarray(V, float), np.asarray(F))
        V, F = meshes[name]
        yield key, row, noisy(V, F, kind, float(level), seed0), F


def cube(jitter, seed):
    """tests/python/test_denoise.py's jittered_rounded_cube: the clean superellipsoids the rule must leave alone."""
    V, F = shapes.icosphere(2, 1.0)
    e = np.linalg.norm(V[F[:, [1, 2, 0]]] - V[F], axis=2).mean()
    V = V + np.random.default_rng(seed).normal(0.0, jitter * e, V.shape)
    V /= np.linalg.norm(V, axis=1)[:, None]
    return V / ((V**8).sum(axis=1) ** 0.125)[:, None], np.asarray(F)
