"""scripts/demo.py runs end to end (small model) and renders a coloured object."""

import subprocess

import bpy
import numpy as np
import pytest

from helpers import REPO, make_fixtures


def _coloured_fraction(path):
    img = bpy.data.images.load(str(path))
    try:
        px = np.empty(img.size[0] * img.size[1] * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    px = px.reshape(-1, 4)
    # The background is neutral grey; the curvature colours are red or blue.
    return float(np.mean(np.abs(px[:, 0] - px[:, 2]) > 0.1))


def test_demo(tmp_path):
    try:
        make_fixtures.cgal_mesh_path("elephant")
    except FileNotFoundError as exc:
        pytest.skip(str(exc))
    cmd = [bpy.app.binary_path, "--background", "--factory-startup", "--python-exit-code", "1",
           "--python", str(REPO / "scripts" / "demo.py"), "--", str(tmp_path), "--model", "elephant"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    for name in ("curvature_mean.png", "curvature_gaussian.png"):
        assert _coloured_fraction(tmp_path / name) > 0.01, name
    # Greyscale renders of later steps: the crest lines' coloured curves are hidden from them.
    for name in ("unwrap_checker.png", "skeletal_bend_twist.png"):
        assert _coloured_fraction(tmp_path / name) < 0.001, name
    assert (tmp_path / "demo.blend").stat().st_size > 0
    summary = (tmp_path / "summary.md").read_text()
    assert summary.count("\n") == 1 and "elephant" in summary and "2775 vertices" in summary
