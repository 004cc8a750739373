"""The camera's tone curve: grey levels decoded to values proportional to light.

The tracker's models add light: a pixel on the ball's edge is ``S F + (1 - S) B`` for the
covered fraction ``S`` (a blur mixes light in proportion), and the coverage, the centroid and
the edge model (:mod:`._edge`) all rest on that. Most cameras other than raw or machine-vision
ones store ``T(light)`` instead, with a concave tone curve ``T`` (sRGB, IEC 61966-2-1; the
BT.709 camera curve of consumer video; or a plain power ``light^(1/gamma)``): the edge's
mixed pixels then come out brighter than their share of the light, and a bright ball looks
larger (a dark one smaller). Measured on ``tests/render_pbr.py``'s balls of 10-15 px stored
through sRGB and BT.709 (``benchmarks/tracking_tone.py``; docs/tracking.md §3, *the camera's
tone curve*): the radius +1 to +5 % for a bright ball and -2 to -8 % for a dark one under a
lens blur of 0.7-1.5 px taken as linear, within 0.51 % decoded.

:func:`decode_table` gives the 256-entry table that maps a stored grey level to
``255 T^-1(level / 255)`` rounded (uint8, so that every stage reads the frames as before); the
rounding costs the darkest levels their resolution (sRGB: stored 0-6 become 0, 7-17 become 1,
40 becomes 5): a dark ball's radius moved by at most 0.25 % against the frames never encoded.
Written here because the curves are three lines each and no dependency of the package decodes
them to a lookup table.
"""

from __future__ import annotations

import math
from typing import Literal, get_args

import numpy as np

ToneCurveName = Literal["linear", "srgb", "rec709"]
TONE_CURVES: tuple[str, ...] = get_args(ToneCurveName)
GAMMA_RANGE = (1.0, 4.0)  # a power-law curve's gamma: stored = light^(1 / gamma)


def check_tone_curve(name: str, value) -> str | float | None:
    """``value`` if it is None (not given: taken as linear), one of ``TONE_CURVES`` or a gamma
    in ``GAMMA_RANGE`` (a number, or a string holding one); ``ValueError`` naming ``name``, what
    came and what is allowed."""
    if value is None or isinstance(value, str) and value in TONE_CURVES:
        return value
    gamma = math.nan
    if isinstance(value, int | float) and not isinstance(value, bool):
        gamma = float(value)
    elif isinstance(value, str):
        try:
            gamma = float(value)
        except ValueError:
            pass
    lo, hi = GAMMA_RANGE
    if not lo <= gamma <= hi:
        raise ValueError(f"`{name}` must be one of {', '.join(TONE_CURVES)} or a gamma from "
                         f"{lo:g} to {hi:g} (stored = light^(1/gamma)); got {value!r}")
    return gamma


def decode(levels: np.ndarray, curve: str | float | None) -> np.ndarray:
    """Stored grey levels (0-255, any real) to light on the same 0-255 scale (float64); None:
    linear."""
    v = np.clip(np.asarray(levels, dtype=np.float64) / 255.0, 0.0, 1.0)
    if curve is None or curve == "linear":
        light = v
    elif curve == "srgb":  # IEC 61966-2-1 decoding
        light = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    elif curve == "rec709":  # the inverse of the BT.709 camera curve (OETF)
        light = np.where(v < 0.081, v / 4.5, ((v + 0.099) / 1.099) ** (1.0 / 0.45))
    else:
        light = v ** float(curve)
    return 255.0 * light


def decode_table(curve: str | float | None) -> np.ndarray | None:
    """The uint8 lookup table of :func:`decode` (rounded), or None for a linear curve."""
    if curve is None or curve == "linear":
        return None
    return np.rint(decode(np.arange(256), curve)).astype(np.uint8)


def tone_curve_label(curve: str | float | None) -> str:
    """The curve as the records and the command line write it."""
    if curve is None:
        return "linear (not given)"
    return curve if isinstance(curve, str) else f"{curve:g}"
