"""The fixture script runs and its files stay small."""

import subprocess

import bpy
import numpy as np
import pytest

from helpers import FIXTURES, make_fixtures

NAMES = ("shapes.blend", "bad_meshes.blend", "data_survival.blend")
MAX_BYTES = 300 * 1024


def test_committed_fixtures_are_small():
    for name in NAMES:
        assert (FIXTURES / name).stat().st_size < MAX_BYTES, name


def test_make_fixtures_runs(tmp_path):
    cmd = [bpy.app.binary_path, "--background", "--factory-startup", "--python-exit-code", "1",
           "--python", str(FIXTURES / "make_fixtures.py"), "--", str(tmp_path)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    for name in NAMES:
        assert 0 < (tmp_path / name).stat().st_size < MAX_BYTES, name


def test_numpy_off_reader_matches_native(dg):
    """make_fixtures.read_off is the fallback when dgmesh is not importable."""
    try:
        path = make_fixtures.cgal_mesh_path("fandisk")
    except FileNotFoundError as exc:
        pytest.skip(str(exc))
    V, F = make_fixtures.read_off(path)
    V_ref, F_ref = dg.read_mesh(str(path))
    np.testing.assert_allclose(V, V_ref, rtol=1e-12)
    np.testing.assert_array_equal(F, F_ref)
