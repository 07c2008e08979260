"""Animated GIFs: real-time timing, faithful frames, atomic saves, inline display."""

import base64
import io
import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image, ImageSequence

from warehouse_phys.drawing.animation import GIF_MAX_FPS, Animation


def frames(count, height=24, width=32):
    """Distinct frames: a white square walking across a dark background."""
    out = []
    for i in range(count):
        frame = np.full((height, width, 3), (30, 60, 90), dtype=np.uint8)
        x = (2 * i) % (width - 4)
        frame[4:10, x : x + 4] = 255
        out.append(frame)
    return out


def decode(gif):
    with Image.open(io.BytesIO(gif)) as image:
        assert image.format == "GIF"
        assert image.info.get("loop") == 0  # loops for ever
        return [
            (np.asarray(frame.convert("RGB")), frame.info["duration"])
            for frame in ImageSequence.Iterator(image)
        ]


def test_grid_rate_frames_each_last_a_quarter_second_with_holds():
    animation = Animation(frames(3), fps=4)
    assert animation.gif_timing() == ([0, 1, 2], [750, 250, 1250])
    decoded = decode(animation.gif)
    assert [delay for _, delay in decoded] == [750, 250, 1250]
    for (got, _), want in zip(decoded, frames(3), strict=True):
        assert np.array_equal(got, want)  # few colours: the palette holds them exactly


def test_physics_rate_keeps_every_second_frame_and_the_last():
    animation = Animation(frames(16), fps=60, hold_start=0, hold_end=0)
    kept, delays = animation.gif_timing()
    assert kept == [0, 2, 4, 6, 8, 10, 12, 14, 15]
    # 16 frames at 60 fps last 26.7 cs: 3 or 4 cs per kept pair of frames on the
    # cumulative clock; the last two frames, 1/60 s each, get the 2 cs minimum.
    assert sum(delays) == 270
    assert set(delays[:-2]) <= {30, 40}
    assert delays[-2:] == [20, 20]
    assert len(decode(animation.gif)) == len(kept)


@given(
    count=st.integers(1, 150),
    fps=st.floats(0.5, 240),
    hold_start=st.floats(0, 2),
    hold_end=st.floats(0, 2),
)
def test_timing_plays_in_real_time_at_a_rate_every_browser_honours(
    count, fps, hold_start, hold_end
):
    animation = Animation(frames(1) * count, fps=fps, hold_start=hold_start, hold_end=hold_end)
    kept, delays = animation.gif_timing()
    assert kept[0] == 0
    assert kept[-1] == count - 1
    assert all(b > a for a, b in itertools.pairwise(kept))
    assert len(delays) == len(kept)
    assert all(d % 10 == 0 and d >= 20 for d in delays)  # whole centiseconds, at least 2
    # Kept frames are evenly spaced at no more than GIF_MAX_FPS, but for the last
    # frame, always kept, which may come sooner.
    stride = max(1, math.ceil(fps / GIF_MAX_FPS - 1e-9))
    assert fps / stride <= GIF_MAX_FPS + 1e-9
    assert kept[:-1] == list(range(0, count - 1, stride))[: len(kept) - 1]
    assert all(b - a == stride for a, b in itertools.pairwise(kept[:-1]))
    # The whole GIF lasts as long as the frames and holds, to the centisecond
    # (or longer where a frame had to be stretched to the 2 cs minimum).
    total = hold_start + count / fps + hold_end
    assert sum(delays) >= round(total * 100) * 10 - 10
    if all(d > 20 for d in delays):
        assert math.isclose(sum(delays), round(total * 100) * 10, abs_tol=10)


def test_physics_frames_survive_the_palette_closely(tmp_path):
    rng = np.random.default_rng(0)
    noisy = [rng.integers(0, 256, (20, 20, 3), dtype=np.uint8) for _ in range(3)]
    decoded = decode(Animation(noisy, fps=4).gif)
    assert len(decoded) == 3
    for (got, _), want in zip(decoded, noisy, strict=True):
        assert got.shape == want.shape
        assert np.abs(got.astype(int) - want).mean() < 40  # 256 colours for noise: close


def test_save_writes_the_gif_atomically(tmp_path):
    animation = Animation(frames(4), fps=4)
    path = animation.save(tmp_path / "a.gif")
    assert path.read_bytes() == animation.gif
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif"]
    with pytest.raises(FileNotFoundError):
        animation.save(tmp_path / "missing" / "a.gif")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif"]


def test_shows_inline_in_jupyter_as_the_same_gif():
    animation = Animation(frames(2), fps=4)
    html = animation._repr_html_()
    prefix = '<img src="data:image/gif;base64,'
    assert html.startswith(prefix)
    encoded = html[len(prefix) : html.index('"', len(prefix))]
    assert base64.b64decode(encoded) == animation.gif
    assert 'width="32"' in html


def test_frames_are_copied_so_the_gif_cannot_go_stale():
    source = frames(2)
    animation = Animation(source, fps=4)
    before = animation.gif
    source.append(frames(3)[2])
    assert len(animation.frames) == 2
    assert animation.gif == before


def test_duration_counts_the_frames_and_the_holds():
    assert Animation(frames(8), fps=4, hold_start=0.5, hold_end=1).duration == 3.5


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"frames": []}, "at least one frame"),
        ({"frames": [np.zeros((4, 4), np.uint8)]}, r"frame 0 must be an \(H, W, 3\) uint8"),
        ({"frames": [np.zeros((4, 4, 3), np.float32)]}, "dtype float32"),
        ({"frames": [np.zeros((4, 4, 3), np.uint8), np.zeros((4, 5, 3), np.uint8)]},
         r"frame 1 has shape \(4, 5, 3\), frame 0 has \(4, 4, 3\)"),
        ({"fps": 0}, "fps must be a positive number, got 0"),
        ({"fps": math.nan}, "fps must be a positive number"),
        ({"hold_end": -1}, "hold_end must be a non-negative number of seconds, got -1"),
        ({"hold_start": math.inf}, "hold_start must be a non-negative"),
    ],
)  # fmt: skip
def test_bad_arguments_are_named(kwargs, message):
    arguments = {"frames": frames(1), "fps": 4, **kwargs}
    with pytest.raises(ValueError, match=message):
        Animation(**arguments)
