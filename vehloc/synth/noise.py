"""Fresh Gaussian sensor noise for 8-bit frames, drawn cheaply.

Adding float noise to an 8-bit frame and truncating gives frame + floor(noise) per pixel, so the noise is
drawn directly as floor(sigma * z): a 16-bit uniform draw looked up in the inverse normal CDF at the
centres of 65536 equal-probability bins (tails cut at 4.2 sigma). On a 1280x720 frame this costs about
a third of drawing float32 normals, which dominated the cost of a scene's frames without a moving car.
"""

from __future__ import annotations

from statistics import NormalDist

import numpy as np

_LEVELS = 1 << 16


class SensorNoise:
    """Adds independent Gaussian noise of standard deviation ``sigma`` (grey levels) to each frame."""

    def __init__(self, sigma: float, rng: np.random.Generator) -> None:
        if sigma < 0:
            raise ValueError(f"noise sigma must be >= 0, got {sigma}")
        normal = NormalDist()
        quantiles = np.array([normal.inv_cdf((k + 0.5) / _LEVELS) for k in range(_LEVELS)])
        self._steps = np.floor(sigma * quantiles).astype(np.int16)
        self._rng = rng

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """A new uint8 image: ``image`` plus fresh noise, clipped to 0..255."""
        draws = self._rng.integers(0, _LEVELS, image.shape, dtype=np.uint16)
        noisy = np.take(self._steps, draws)
        noisy += image
        return np.clip(noisy, 0, 255, out=noisy).astype(np.uint8)
