"""Blender test suite: run with run.py inside Blender (see run.py)."""

import pytest

try:
    import bpy
except ImportError:  # plain pytest outside Blender: none of these tests can run
    bpy = None
    collect_ignore_glob = ["*.py"]


@pytest.fixture
def dg():
    """The add-on package (numpy API), as enabled by run.py."""
    import dgmesh

    return dgmesh


@pytest.fixture(autouse=True)
def _object_mode_after():
    """Leave Object mode behind, so a failed Edit-mode test does not leak."""
    yield
    if bpy.context.object is not None and bpy.context.object.mode != 'OBJECT':
        bpy.ops.object.mode_set(mode='OBJECT')
