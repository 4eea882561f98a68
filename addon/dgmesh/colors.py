"""Colour maps for scalar fields on meshes and distinct colours for labels (numpy only, no bpy).

Every map returns an (n, 4) float32 RGBA array in *linear* colour space,
which is what Blender's FLOAT_COLOR attributes store (BYTE_COLOR's ``color``
property converts from linear as well).  The palettes are defined by sRGB
control points and converted, so the viewport shows the intended colours.
Non-finite input values map to a neutral grey.
"""

import colorsys

import numpy as np

__all__ = [
    "DIVERGING_SRGB",
    "SEQUENTIAL_SRGB",
    "NAN_COLOR",
    "srgb_to_linear",
    "symmetric_limit",
    "upper_limit",
    "diverging",
    "sequential",
    "segment_colors",
]

# Signed fields (curvature): blue negative, near-white zero, red positive.
# Reversed ColorBrewer RdBu, 11 classes: a symmetric palette whose centre is a
# light grey, so zero stands out from both signs.
DIVERGING_SRGB = np.array(
    [
        (0x05, 0x30, 0x61),
        (0x21, 0x66, 0xAC),
        (0x43, 0x93, 0xC3),
        (0x92, 0xC5, 0xDE),
        (0xD1, 0xE5, 0xF0),
        (0xF7, 0xF7, 0xF7),
        (0xFD, 0xDB, 0xC7),
        (0xF4, 0xA5, 0x82),
        (0xD6, 0x60, 0x4D),
        (0xB2, 0x18, 0x2B),
        (0x67, 0x00, 0x1F),
    ],
    dtype=np.float64,
) / 255.0

# Non-negative fields (residuals, stretch, distance): viridis, sampled at ten
# evenly spaced points; perceptually ordered and readable in grey scale.
SEQUENTIAL_SRGB = np.array(
    [
        (0x44, 0x01, 0x54),
        (0x48, 0x28, 0x78),
        (0x3E, 0x49, 0x89),
        (0x31, 0x68, 0x8E),
        (0x26, 0x82, 0x8E),
        (0x1F, 0x9E, 0x89),
        (0x35, 0xB7, 0x79),
        (0x6E, 0xCE, 0x58),
        (0xB5, 0xDE, 0x2B),
        (0xFD, 0xE7, 0x25),
    ],
    dtype=np.float64,
) / 255.0

NAN_COLOR = (0.5, 0.5, 0.5)  # sRGB


def srgb_to_linear(c):
    """Convert sRGB components in [0, 1] to linear (IEC 61966-2-1)."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _finite_abs(values):
    v = np.asarray(values, dtype=np.float64).ravel()
    return np.abs(v[np.isfinite(v)])


def symmetric_limit(values, percentile=95.0):
    """Robust half-width of a symmetric range: the percentile of |value|.

    A percentile rather than the maximum keeps a few spikes (sharp corners,
    scan noise) from washing out the rest of the map.  Returns 1.0 when the
    field is all zero or has no finite value, so the map is uniformly neutral.
    """
    a = _finite_abs(values)
    if a.size == 0:
        return 1.0
    limit = float(np.percentile(a, float(np.clip(percentile, 0.0, 100.0))))
    if not limit > 0.0:
        limit = float(a.max())
    return limit if limit > 0.0 else 1.0


def upper_limit(values, percentile=95.0):
    """Robust upper end of a [0, limit] range (percentile of the finite values)."""
    return symmetric_limit(values, percentile)


def _lookup(t, palette_srgb):
    """Piecewise-linear palette lookup; t in [0, 1] (clipped), NaN -> grey."""
    t = np.asarray(t, dtype=np.float64).ravel()
    bad = ~np.isfinite(t)
    t = np.clip(np.where(bad, 0.0, t), 0.0, 1.0)
    stops = np.linspace(0.0, 1.0, len(palette_srgb))
    rgba = np.empty((t.size, 4), dtype=np.float32)
    for ch in range(3):
        rgba[:, ch] = np.interp(t, stops, palette_srgb[:, ch])
    rgba[bad, :3] = NAN_COLOR
    rgba[:, :3] = srgb_to_linear(rgba[:, :3])
    rgba[:, 3] = 1.0
    return rgba


def diverging(values, limit=None, percentile=95.0):
    """Signed field -> RGBA: [-limit, 0, limit] -> blue, white, red.

    ``limit`` defaults to :func:`symmetric_limit` of the values; values beyond
    it are clipped to the end colours.
    """
    if limit is None:
        limit = symmetric_limit(values, percentile)
    limit = float(limit) if limit and np.isfinite(limit) and limit > 0 else 1.0
    v = np.asarray(values, dtype=np.float64).ravel()
    return _lookup(0.5 + 0.5 * v / limit, DIVERGING_SRGB)


def sequential(values, vmax=None, vmin=0.0, percentile=95.0):
    """Non-negative field -> RGBA along viridis; [vmin, vmax] spans the palette.

    ``vmax`` defaults to :func:`upper_limit` of the values.
    """
    if vmax is None:
        vmax = upper_limit(values, percentile)
    span = float(vmax) - float(vmin)
    if not (np.isfinite(span) and span > 0):
        span = 1.0
    v = np.asarray(values, dtype=np.float64).ravel()
    return _lookup((v - float(vmin)) / span, SEQUENTIAL_SRGB)


def segment_colors(n: int) -> np.ndarray:
    """n distinct linear RGBA colours (golden-ratio hue steps), (n, 4) float32: one per segment
    label (Segment's face colours)."""
    hues = (np.arange(n) * 0.618033988749895) % 1.0
    rgb = np.array([colorsys.hsv_to_rgb(h, 0.55 + 0.3 * (i % 2), 0.9 - 0.15 * (i % 3 == 2))
                    for i, h in enumerate(hues)])
    out = np.ones((n, 4), dtype=np.float32)
    out[:, :3] = srgb_to_linear(rgb)
    return out
