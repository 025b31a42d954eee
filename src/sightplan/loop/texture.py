"""The procedural surface texture of the synthetic photographs: a colour and a noise pattern per element, fixed in
the world so that a surface point looks the same from every view.

Each element's pattern is seeded from its GlobalId (not its index, which changes with the model's order), so an
element keeps its look across models, dates and plans. The pattern is a sum of octaves of 3-D value noise evaluated
at the world point a pixel sees: octave k has lattice cell ``cell_m · 2^k``, so with ``cell_m`` a few times the
plan's surface sampling distance every octave is resolved in the images and SIFT finds corners at several scales.
Octaves finer than the pixel footprint are faded out (the averaging a lens and a sensor do), which keeps far or
oblique surfaces from aliasing into features no other view would see. The sky is a smooth gradient with nothing in it
to detect.
"""

from __future__ import annotations

import hashlib

import numpy as np
from numpy.typing import NDArray

OCTAVES = 6
AMBIENT = 0.3  # the share of light that does not depend on the surface's angle to the view
FADE_FROM_PX, FADE_TO_PX = 2.0, 4.0  # an octave fades in between these wavelengths per pixel footprint

_M1, _M2, _M3 = np.uint64(0x9E3779B97F4A7C15), np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_PRIMES = (np.uint64(0x8DA6B343), np.uint64(0xD8163841), np.uint64(0xCB1AB31F))


def element_seed(global_id: str) -> int:
    """A 63-bit seed from an element's GlobalId (stable across runs, platforms and model orders)."""
    return int.from_bytes(hashlib.sha256(str(global_id).encode()).digest()[:8], "little") >> 1


def element_colour(seed: int) -> NDArray[np.float64]:
    """(3,) RGB in 0..1: a mid-light colour of a hue and saturation picked by the seed."""
    rng = np.random.default_rng(seed)
    hue, sat, val = rng.uniform(0, 1), rng.uniform(0.25, 0.6), rng.uniform(0.75, 0.95)
    k = (np.array([5.0, 3.0, 1.0]) + hue * 6) % 6
    return val - val * sat * np.clip(np.minimum(k, 4 - k), 0, 1)


def _mix(x: NDArray[np.uint64]) -> NDArray[np.uint64]:
    """A 64-bit integer mixer (splitmix64's finaliser): lattice corner → uniform bits."""
    x = (x ^ (x >> np.uint64(30))) * _M2
    x = (x ^ (x >> np.uint64(27))) * _M3
    return x ^ (x >> np.uint64(31))


def lattice(ix: NDArray[np.int64], iy: NDArray[np.int64], iz: NDArray[np.int64], seed: NDArray[np.uint64]
             ) -> NDArray[np.float64]:
    """The value in 0..1 at integer lattice corners, for per-point seeds."""
    with np.errstate(over="ignore"):
        h = seed * _M1 + ix.astype(np.uint64) * _PRIMES[0] + iy.astype(np.uint64) * _PRIMES[1] \
            + iz.astype(np.uint64) * _PRIMES[2]
        return (_mix(h) >> np.uint64(11)).astype(np.float64) / float(1 << 53)


def value_noise(p: NDArray[np.float64], seed: NDArray[np.uint64]) -> NDArray[np.float64]:
    """(n,) smooth noise in 0..1 at points ``p`` (n, 3) in lattice units: the corner values interpolated with a
    quintic fade, so the pattern and its first two derivatives are continuous."""
    base = np.floor(p)
    f = p - base
    w = f * f * f * (f * (f * 6 - 15) + 10)
    i = base.astype(np.int64)
    out = np.zeros(len(p))
    for dx in (0, 1):
        wx = w[:, 0] if dx else 1 - w[:, 0]
        for dy in (0, 1):
            wy = w[:, 1] if dy else 1 - w[:, 1]
            for dz in (0, 1):
                wz = w[:, 2] if dz else 1 - w[:, 2]
                out += wx * wy * wz * lattice(i[:, 0] + dx, i[:, 1] + dy, i[:, 2] + dz, seed)
    return out


def octave_rotations(seeds: NDArray[np.uint64], octave: int) -> NDArray[np.float64]:
    """(u, 3, 3) a random rotation per seed for one octave: it turns the noise lattice off the model's axes, so walls
    and floors (usually axis-aligned) do not show the lattice's rows as repeated edges."""
    q = np.array([np.random.default_rng([int(s), octave]).normal(size=4) for s in seeds]).reshape(-1, 4)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], axis=1)


def noise_contrast(points: NDArray[np.float64], seeds: NDArray[np.uint64], cell_m: float | NDArray,
                   footprint_m: NDArray[np.float64] | None = None, octaves: int = OCTAVES) -> NDArray[np.float64]:
    """(n,) the multi-scale noise at world ``points`` (n, 3) for per-point ``seeds``: the weighted mean of the
    octaves' values less ½, so about −0.5..0.5 and mostly within ±0.15. ``cell_m`` (a length, or one per point):
    the finest octave's cell. ``footprint_m`` (n,), the size of a pixel on the surface, fades out the octaves it
    cannot resolve (None: every octave at full weight); where none is resolved the contrast is 0."""
    n = len(points)
    unique_seeds, which = np.unique(seeds, return_inverse=True)
    total = np.zeros(n)
    weight_sum = np.zeros(n)
    cell_m = np.asarray(cell_m, float)
    for k in range(octaves):
        cell = cell_m * 2.0**k
        amp = 1.0 / (1.0 + 0.35 * k)  # the fine octaves carry the most corners; the coarse ones give context
        if footprint_m is None:
            weight = np.full(n, amp)
        else:
            px = cell / np.maximum(footprint_m, 1e-12)
            weight = amp * np.clip((px - FADE_FROM_PX) / (FADE_TO_PX - FADE_FROM_PX), 0.0, 1.0)
        # each octave its own seed and a shifted lattice, so the octaves' corners do not line up
        with np.errstate(over="ignore"):
            octave_seed = seeds + np.uint64(k + 1) * np.uint64(0x632BE59BD9B4E019)
        turned = np.einsum("nij,nj->ni", octave_rotations(unique_seeds, k)[which], points)
        value = value_noise(turned / (cell if cell.ndim == 0 else cell[:, None]), octave_seed)
        total += weight * (value - 0.5)
        weight_sum += np.where(weight > 0, amp, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(weight_sum > 0, total / np.maximum(weight_sum, 1e-12), 0.0)


def albedo(points: NDArray[np.float64], seeds: NDArray[np.uint64], colours: NDArray[np.float64], cell_m: float,
           footprint_m: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """(n, 3) surface colour in 0..1 at world ``points`` (n, 3) of elements with ``seeds`` (n,) and ``colours``
    (n, 3): the element's colour, darker or lighter by the multi-scale noise (:func:`noise_contrast`)."""
    contrast = noise_contrast(points, seeds, cell_m, footprint_m)
    # the sum of octaves clusters around 0.5: stretch it to use the range, then map to 0.25..1.15 of the colour
    shade = np.clip(0.7 + 2.4 * contrast, 0.25, 1.15)
    return np.clip(colours * shade[:, None], 0.0, 1.0)


def shading(cos: NDArray[np.float64]) -> NDArray[np.float64]:
    """Light on a surface seen at |cos θ| to its normal: ambient plus a head-on share."""
    return AMBIENT + (1.0 - AMBIENT) * np.abs(cos)


def sky(directions: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, 3) RGB in 0..1 for rays that hit nothing: a gradient on the world's up component only (pale at and below
    the horizon, deeper blue overhead), smooth everywhere."""
    up = np.clip(directions[:, 2], -1.0, 1.0)
    s = 0.5 * (1 + np.tanh(2.0 * up))  # 0 looking down, 1 looking up, no kink at the horizon
    horizon = np.array([0.86, 0.88, 0.90])
    zenith = np.array([0.45, 0.62, 0.85])
    return horizon + s[:, None] * (zenith - horizon)
