"""dgmesh.colors (numpy only; run here because it ships with the add-on)."""

import numpy as np
import pytest

from dgmesh import colors


def test_shapes_and_types():
    for fn in (colors.diverging, colors.sequential):
        rgba = fn(np.linspace(-1, 1, 7))
        assert rgba.shape == (7, 4) and rgba.dtype == np.float32
        assert np.all(rgba[:, 3] == 1.0) and np.all((rgba >= 0) & (rgba <= 1))
        assert fn(np.zeros(0)).shape == (0, 4)


def test_diverging_signs():
    neg, zero, pos = colors.diverging(np.array([-1.0, 0.0, 1.0]), limit=1.0)
    assert neg[2] > neg[0]  # blue
    assert pos[0] > pos[2]  # red
    assert np.all(zero[:3] > 0.85) and np.ptp(zero[:3]) < 0.01  # near-white grey
    # Symmetric: equal magnitudes give equally saturated ends (reversed channels).
    a, b = colors.diverging(np.array([-0.3, 0.3]), limit=1.0)
    assert abs(a[:3].sum() - b[:3].sum()) < 0.2


def test_robust_limit_ignores_spikes():
    v = np.concatenate([np.linspace(-1, 1, 1000), [1e6, np.nan, np.inf]])
    assert colors.symmetric_limit(v, 95) == pytest.approx(0.95, abs=0.01)
    rgba = colors.diverging(v)
    np.testing.assert_allclose(rgba[1000], colors.diverging(np.array([1.0]), limit=0.5)[0])  # clipped
    grey = colors.srgb_to_linear(np.array(colors.NAN_COLOR))
    np.testing.assert_allclose(rgba[1001, :3], grey, rtol=1e-6)


def test_degenerate_ranges():
    assert colors.symmetric_limit(np.zeros(5)) == 1.0
    assert colors.symmetric_limit(np.array([np.nan])) == 1.0
    # Mostly zero with a few non-zero values: the limit falls back to the max.
    assert colors.symmetric_limit(np.array([0.0] * 99 + [2.0]), 95) == 2.0
    z = colors.diverging(np.zeros(3))
    np.testing.assert_allclose(z, np.repeat(z[:1], 3, axis=0))


def test_sequential_is_ordered():
    rgba = colors.sequential(np.linspace(0, 1, 50), vmax=1.0)
    lum = rgba[:, :3] @ np.array([0.2126, 0.7152, 0.0722])
    assert np.all(np.diff(lum) > 0)  # viridis brightens monotonically
    assert np.allclose(colors.sequential(np.array([2.0, -1.0]), vmax=1.0),
                       colors.sequential(np.array([1.0, 0.0]), vmax=1.0))


def test_srgb_to_linear():
    np.testing.assert_allclose(colors.srgb_to_linear(np.array([0.0, 0.5, 1.0])),
                               [0.0, 0.21404, 1.0], atol=1e-5)


def test_segment_colors_are_distinct_linear_rgba():
    rgba = colors.segment_colors(7)
    assert rgba.shape == (7, 4) and rgba.dtype == np.float32 and np.all(rgba[:, 3] == 1.0)
    # Label 0: hue 0, saturation 0.55, value 0.9 -> sRGB (0.9, 0.405, 0.405), stored linear.
    assert np.allclose(rgba[0, :3], [0.787412, 0.136400, 0.136400], atol=1e-6)
    assert len(np.unique(rgba.round(4), axis=0)) == 7
    assert np.array_equal(colors.segment_colors(3), rgba[:3])  # a label keeps its colour
