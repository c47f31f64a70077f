"""A small learned check of the still finder's candidates: is the patch around a candidate a ball or not?

The classical stages (still_ball) propose candidates; the verifier looks at a fixed-size patch around each one,
scaled so that the ball the field predicts there has PATCH_BALL_RADIUS pixels, and gives the chance that a ball is
at the patch's centre. It is a tiny convolutional net (three 3x3 convolutions with max pooling, one hidden layer),
trained by the project on the simulated camera's renders only (foos_vision.verifier_training,
`scripts/train_ball_verifier`), and run here in numpy from an .npz file of its weights: no runtime dependency beyond
numpy and OpenCV, and nothing is fetched.

The patch is the candidate's colours less its surroundings' (the median of the patch's border, per channel), so that
the felt's colour and the light's level count as little as they can: the net sees what differs from the felt.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Sequence

import cv2
import numpy as np

from ..errors import VisionError

PATCH = 32  # px: the patch's side
PATCH_BALL_RADIUS = 7.0  # px: the predicted ball's radius in the patch (the patch reaches 16 / 7 = 2.3 radii out)
PATCH_SCALE = 64.0  # 8-bit levels: the patch's differences from its surroundings are divided by this
DEFAULT_WEIGHTS = Path(__file__).resolve().parent.parent / "models" / "ball_verifier.npz"
LAYERS = ("conv1", "conv2", "conv3", "fc1", "fc2")


class VerifierError(VisionError):
    """A weights file the verifier cannot use."""


def raw_patches(bgr: np.ndarray, centres: Sequence[tuple[float, float]], radius_px: float) -> np.ndarray:
    """(N, PATCH, PATCH, 3) uint8: around each centre (full-frame px), the image scaled so that a ball of radius_px
    has PATCH_BALL_RADIUS px."""
    out = np.zeros((len(centres), PATCH, PATCH, 3), np.uint8)
    if not len(centres):
        return out
    scale = PATCH_BALL_RADIUS / max(radius_px, 1e-3)
    # Shrinking by more than 2x: smooth first, as INTER_AREA would (warpAffine samples, it does not average).
    source = bgr if scale >= 0.5 else cv2.GaussianBlur(bgr, (0, 0), 0.5 / scale)
    half = (PATCH - 1) / 2.0
    for i, (u, v) in enumerate(centres):
        m = np.array([[scale, 0.0, half - scale * u], [0.0, scale, half - scale * v]], np.float32)
        out[i] = cv2.warpAffine(source, m, (PATCH, PATCH), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out


def normalise(raw: np.ndarray) -> np.ndarray:
    """(N, 3, P, P) float32 of (N, P, P, 3) patches: less each one's border median per channel, over PATCH_SCALE."""
    p = raw.astype(np.float32)
    border = np.concatenate([p[:, 0], p[:, -1], p[:, 1:-1, 0], p[:, 1:-1, -1]], axis=1)  # (N, 4P - 4, 3)
    return ((p - np.median(border, axis=1)[:, None, None, :]) / PATCH_SCALE).transpose(0, 3, 1, 2)


class BallVerifier:
    """The net's weights, and its forward pass in numpy."""

    def __init__(self, weights: Optional[str | Path] = None):
        path = Path(weights) if weights is not None else DEFAULT_WEIGHTS
        try:
            with np.load(path, allow_pickle=False) as data:
                self.params = {name: np.asarray(data[name], np.float32) for name in data.files}
        except FileNotFoundError:
            raise VerifierError(f"{path}: no such ball verifier weights file") from None
        except Exception as error:  # np.load's errors for a file that is not an .npz: ValueError, OSError, zip errors
            raise VerifierError(f"{path}: not a ball verifier weights file ({type(error).__name__})") from None
        self._check(path)
        self.path = path

    def _check(self, path: Path) -> None:
        for layer in LAYERS:
            for part in ("w", "b"):
                if f"{layer}.{part}" not in self.params:
                    raise VerifierError(f"{path}: not a ball verifier weights file (no {layer}.{part})")
        p = self.params
        channels = 3
        for layer in LAYERS[:3]:
            w = p[f"{layer}.w"]
            if w.ndim != 4 or w.shape[1] != channels or w.shape[2:] != (3, 3) or p[f"{layer}.b"].shape != w.shape[:1]:
                raise VerifierError(f"{path}: {layer} has shape {w.shape}, not (C, {channels}, 3, 3)")
            channels = w.shape[0]
        side = PATCH // 8
        if p["fc1.w"].shape[1:] != (channels * side * side,) or p["fc2.w"].shape != (1, p["fc1.w"].shape[0]):
            raise VerifierError(f"{path}: fc1/fc2 have shapes {p['fc1.w'].shape}, {p['fc2.w'].shape}, "
                                f"not (H, {channels * side * side}), (1, H)")
        if not all(np.all(np.isfinite(v)) for v in p.values()):
            raise VerifierError(f"{path}: the weights are not all finite")

    def probability(self, x: np.ndarray) -> np.ndarray:
        """(N,) the chance of a ball at each patch's centre, for (N, 3, PATCH, PATCH) patches."""
        if len(x) == 0:
            return np.zeros(0, np.float32)
        p = self.params
        for layer in LAYERS[:3]:
            x = _max_pool(np.maximum(_conv3x3(x, p[f"{layer}.w"], p[f"{layer}.b"]), 0.0))
        x = np.maximum(x.reshape(len(x), -1) @ p["fc1.w"].T + p["fc1.b"], 0.0)
        logit = (x @ p["fc2.w"].T + p["fc2.b"])[:, 0]
        return 1.0 / (1.0 + np.exp(-np.clip(logit, -30.0, 30.0)))

    def score(self, bgr: np.ndarray, centres: Sequence[tuple[float, float]], radius_px: float) -> np.ndarray:
        return self.probability(normalise(raw_patches(bgr, centres, radius_px)))


def _conv3x3(x: np.ndarray, w: np.ndarray, b: np.ndarray) -> np.ndarray:
    """'Same' 3x3 convolution (cross-correlation, as torch's Conv2d) of (N, C, H, W) with (K, C, 3, 3)."""
    n, c, h, wd = x.shape
    padded = np.pad(x, ((0, 0), (0, 0), (1, 1), (1, 1)))
    windows = np.lib.stride_tricks.sliding_window_view(padded, (3, 3), axis=(2, 3))  # (N, C, H, W, 3, 3)
    return np.einsum("nchwij,kcij->nkhw", windows, w, optimize=True) + b[None, :, None, None]


def _max_pool(x: np.ndarray) -> np.ndarray:
    n, c, h, w = x.shape
    return x.reshape(n, c, h // 2, 2, w // 2, 2).max(axis=(3, 5))
