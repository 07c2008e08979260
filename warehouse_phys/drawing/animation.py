"""Animated GIFs of rendered frames, for run folders, the README and notebooks.

An :class:`Animation` is a sequence of ``(H, W, 3)`` uint8 frames and the
rate they were rendered at. It encodes to a looping GIF that plays in real
time, saves that GIF atomically, and shows itself inline in Jupyter.

GIF stores each frame's delay in whole centiseconds, and browsers slow any
delay under 2 cs down to 10 cs. So faster frame rates (the physics-backed
environment renders 60 frames per second) are played by keeping every k-th
frame, and delays are rounded on the cumulative clock: the whole animation
lasts as long as the frames did, to the centisecond.
"""

from __future__ import annotations

import base64
import io
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from warehouse_phys.files.atomic import atomic_write

#: The highest frame rate a GIF plays at in every browser [frames/s]: a 2 cs delay.
GIF_MAX_FPS = 50
#: Frames sampled to build the one palette every frame of a GIF shares.
_PALETTE_SAMPLES = 8


@dataclass(frozen=True, eq=False)
class Animation:
    """Frames rendered at ``fps`` frames per second, played as a looping GIF.

    Args:
        frames: ``(H, W, 3)`` uint8 arrays, all of one shape, in playing order.
        fps: The rate the frames stand for [frames/s]; 4 for the grid twin,
            60 for the physics-backed environment (its ``metadata["render_fps"]``).
        hold_start: How long the first frame stays before the motion starts [s].
        hold_end: How long the last frame stays before the GIF loops [s].

    Raises:
        ValueError: if there are no frames, they differ in shape or are not
            ``(H, W, 3)`` uint8 images, or ``fps`` or ``hold_end`` is out of range.
    """

    frames: Sequence[np.ndarray]
    fps: float
    hold_start: float = 0.5
    hold_end: float = 1.0

    def __post_init__(self) -> None:
        # A tuple of its own, so that the cached GIF cannot go stale behind the caller's list.
        object.__setattr__(self, "frames", tuple(self.frames))
        if not self.frames:
            raise ValueError("an animation needs at least one frame")
        shape = np.shape(self.frames[0])
        for i, frame in enumerate(self.frames):
            frame = np.asarray(frame)
            if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
                raise ValueError(
                    f"frame {i} must be an (H, W, 3) uint8 image, "
                    f"got shape {frame.shape} and dtype {frame.dtype}"
                )
            if frame.shape != shape:
                raise ValueError(f"frame {i} has shape {frame.shape}, frame 0 has {shape}")
        if not (isinstance(self.fps, (int, float)) and math.isfinite(self.fps) and self.fps > 0):
            raise ValueError(f"fps must be a positive number, got {self.fps!r}")
        for name in ("hold_start", "hold_end"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a non-negative number of seconds, got {value!r}")

    @property
    def duration(self) -> float:
        """How long the GIF plays before it loops, holds included [s]."""
        return self.hold_start + len(self.frames) / self.fps + self.hold_end

    def gif_timing(self) -> tuple[list[int], list[int]]:
        """The frames the GIF keeps (their indices) and each one's delay [ms, whole cs].

        Every k-th frame is kept, with ``k`` the smallest that brings the rate
        to at most :data:`GIF_MAX_FPS`, and the last frame always; each kept
        frame lasts until the next one's time, the first one ``hold_start``
        longer and the last one ``hold_end`` longer, so that the whole GIF
        lasts :attr:`duration` to the centisecond.
        """
        count = len(self.frames)
        stride = max(1, math.ceil(self.fps / GIF_MAX_FPS - 1e-9))
        kept = list(range(0, count, stride))
        if kept[-1] != count - 1:
            kept.append(count - 1)
        # Frame boundaries on the cumulative clock, rounded to centiseconds.
        ends = [*kept[1:], count]
        seconds = np.array([0.0] + [self.hold_start + end / self.fps for end in ends])
        seconds[-1] += self.hold_end
        centis = np.round(seconds * 100).astype(np.int64)
        delays = np.maximum(np.diff(centis), 2) * 10
        return kept, [int(d) for d in delays]

    @cached_property
    def gif(self) -> bytes:
        """The animation as a looping GIF file's bytes, every frame on one shared palette."""
        from PIL import Image

        kept, delays = self.gif_timing()
        images = [Image.fromarray(np.asarray(self.frames[i])) for i in kept]
        # One palette for all frames, from a few frames stacked: colours stay put
        # from frame to frame, and unchanged regions compress to nothing.
        samples = images[:: max(1, len(images) // _PALETTE_SAMPLES)][:_PALETTE_SAMPLES]
        mosaic = Image.fromarray(np.concatenate([np.asarray(s) for s in samples], axis=0))
        palette = mosaic.quantize(colors=256, method=Image.Quantize.MEDIANCUT)
        quantized = [image.quantize(palette=palette, dither=Image.Dither.NONE) for image in images]
        buffer = io.BytesIO()
        quantized[0].save(
            buffer,
            format="GIF",
            save_all=True,
            append_images=quantized[1:],
            duration=delays,
            loop=0,
            optimize=False,
        )
        return buffer.getvalue()

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the GIF to ``path`` atomically (no half-written file on failure)."""
        data = self.gif
        return atomic_write(path, lambda file: file.write(data))

    def _repr_html_(self) -> str:
        """Jupyter shows the GIF inline, stored in the notebook as a data URL."""
        encoded = base64.b64encode(self.gif).decode("ascii")
        width = np.shape(self.frames[0])[1]
        return f'<img src="data:image/gif;base64,{encoded}" width="{width}" alt="animation">'
