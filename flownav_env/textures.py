"""Procedural textures for the scene, generated in code (no downloaded assets).

Every texture is a pure function of a random generator and a size, returning an RGB ``uint8`` array. They
are built to give optical flow something to track: broadband detail at several scales, like real bark,
brushed metal, rock and grass.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np


def value_noise(
    rng: np.random.Generator, size: int, octaves: tuple[int, ...] = (4, 8, 16, 32, 64)
) -> np.ndarray:
    """Multi-octave value noise in [0, 1], shape (size, size), tileable along both axes.

    Each octave is a random grid of ``n × n`` values upsampled with cubic interpolation; wrapping the grid
    before resizing makes the result tile seamlessly, so repeated textures show no seams for FAST to find.
    """
    total = np.zeros((size, size), np.float32)
    weight_sum = 0.0
    for n in octaves:
        grid = rng.random((n, n), dtype=np.float32)
        wrapped = np.pad(grid, ((0, 1), (0, 1)), mode="wrap")
        scale = size / n
        big = cv2.resize(
            wrapped, (round((n + 1) * scale), round((n + 1) * scale)), interpolation=cv2.INTER_CUBIC
        )
        weight = 1.0 / np.sqrt(n)
        total += weight * big[:size, :size]
        weight_sum += weight
    total /= weight_sum
    low, high = float(total.min()), float(total.max())
    return (total - low) / max(high - low, 1e-6)


def sharp_patches(
    rng: np.random.Generator, size: int, coverage: float, octaves: tuple[int, ...]
) -> np.ndarray:
    """Boolean mask of blotches with hard edges covering about ``coverage`` of the texture.

    Thresholded noise gives the crisp, high-contrast corners (lichen, rust, knots, soil) that FAST fires on;
    smooth noise alone blurs away at the camera's low resolution.
    """
    noise = value_noise(rng, size, octaves)
    return noise > np.quantile(noise, 1.0 - coverage)


def _colourise(
    intensity: np.ndarray, dark: tuple[float, float, float], light: tuple[float, float, float]
) -> np.ndarray:
    dark_rgb = np.asarray(dark, np.float32)
    light_rgb = np.asarray(light, np.float32)
    rgb = dark_rgb + intensity[..., None] * (light_rgb - dark_rgb)
    return np.clip(rgb * 255.0, 0, 255).astype(np.uint8)


def wood_texture(rng: np.random.Generator, size: int) -> np.ndarray:
    """Bark-like grain: wavy vertical streaks over knotty noise, in browns."""
    noise = value_noise(rng, size)
    columns = np.arange(size, dtype=np.float32)[None, :]
    frequency = rng.uniform(6, 12) * 2 * np.pi / size
    grain = 0.5 + 0.5 * np.sin(frequency * columns + 8.0 * noise)
    intensity = 0.55 * grain + 0.45 * value_noise(rng, size, (16, 32, 64))
    intensity[sharp_patches(rng, size, 0.12, (16, 32))] *= 0.35  # knots and bark fissures
    tone = rng.uniform(0.8, 1.2)
    return _colourise(intensity, (0.20 * tone, 0.11 * tone, 0.05), (0.70 * tone, 0.48 * tone, 0.27))


def metal_texture(rng: np.random.Generator, size: int) -> np.ndarray:
    """Brushed, weathered metal: horizontal streaks, rust blotches and rivet-like dots, in greys."""
    rows = rng.random(size).astype(np.float32)
    rows = (rows + np.roll(rows, 1) + np.roll(rows, -1)) / 3.0  # wrap-around smoothing keeps it tileable
    streaks = np.repeat(rows[:, None], size, axis=1)
    blotches = value_noise(rng, size, (4, 8, 16, 32))
    intensity = 0.5 * (streaks - streaks.min()) / max(float(np.ptp(streaks)), 1e-6) + 0.5 * blotches
    intensity[sharp_patches(rng, size, 0.15, (8, 16, 32))] *= 0.4  # rust and paint flakes
    dots = rng.random((size, size)) > 0.995
    intensity[dots] = 1.0
    hue = rng.uniform(0.0, 0.1)
    return _colourise(intensity, (0.18, 0.19 + hue, 0.22 + hue), (0.78, 0.80, 0.84))


def stone_texture(rng: np.random.Generator, size: int) -> np.ndarray:
    """Rock: blotchy noise with dark cracks where a second noise field crosses mid-grey."""
    base = value_noise(rng, size, (4, 8, 16, 32, 64))
    cracks = np.abs(value_noise(rng, size, (8, 16)) - 0.5) < 0.02
    intensity = 0.25 + 0.75 * base
    intensity[cracks] *= 0.3
    intensity[sharp_patches(rng, size, 0.2, (16, 32, 64))] = 0.95  # pale lichen spots
    warm = rng.uniform(0.0, 0.12)
    return _colourise(intensity, (0.16 + warm, 0.15 + warm / 2, 0.13), (0.80, 0.77, 0.70))


def grass_texture(rng: np.random.Generator, size: int) -> np.ndarray:
    """Grass-like ground: green value noise with bright and dark speckle (blades and soil)."""
    base = value_noise(rng, size, (8, 16, 32, 64))
    speckle = rng.random((size, size), dtype=np.float32)
    intensity = 0.5 * base + 0.5 * speckle
    intensity[sharp_patches(rng, size, 0.15, (16, 32, 64))] *= 0.3  # bare soil between the tufts
    return _colourise(intensity, (0.07, 0.18, 0.04), (0.45, 0.70, 0.25))


TEXTURE_GENERATORS: dict[str, Callable[[np.random.Generator, int], np.ndarray]] = {
    "wood": wood_texture,
    "metal": metal_texture,
    "stone": stone_texture,
}
