"""What `fluids-bench demo` writes, shared by the Gymnasium and the PettingZoo demos: the video,
the snapshot PNG and the progress bar."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

VIDEO_NAME, SNAPSHOT_NAME = "episode.mp4", "episode.png"
DRAW_BUDGET_S = 15.0  # the default stride keeps a video's drawing to about this long


def write_png(path: Path, frame) -> None:
    import cv2

    if not cv2.imwrite(str(path), cv2.cvtColor(frame, cv2.COLOR_RGB2BGR)):
        raise FileNotFoundError(f"could not write {path}")


class Recorder:
    """The frames of one episode: every `every`-th step and the last into the video (when
    there is one), and the snapshot. `render` draws the current state."""

    def __init__(self, render, out: Path, fps: float, video: bool, every: int | None, limit: int):
        self.render, self.out, self.writer = render, out, None
        self.snapshot, self.drawn = None, 0
        self.every = 1
        if video:
            if every is None:
                render()  # the first frame sets the renderer up: not representative
                t0 = time.perf_counter()
                render()
                cost = time.perf_counter() - t0
                every = max(1, math.ceil(limit * cost / DRAW_BUDGET_S))
            self.every = every
            self.writer = open_video(out / VIDEO_NAME, max(fps / every, 1.0))

    def frame(self, step: int, last: bool) -> Any:
        """Draw step `step` into the video when it is due (and always the last step);
        returns the frame drawn, or None."""
        if self.writer is None or not (last or step % self.every == 0):
            return None
        frame = self.render()
        self.writer.append_data(_padded(frame))
        self.drawn += 1
        return frame

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()

    def wrote(self) -> list[str]:
        files = []
        if self.writer is not None:
            stride = "every step" if self.every == 1 else f"every {self.every} steps"
            files.append(f"{self.out / VIDEO_NAME} ({self.drawn} frames, {stride} and the last)")
        return files + [str(self.out / SNAPSHOT_NAME)]


def _padded(frame):
    """`frame` padded (edge colour) to multiples of 16 pixels: H.264 wants them, and imageio
    would otherwise resize it, warning on every video (DrivingTrack's 500 x 500)."""
    import numpy as np

    h, w = frame.shape[:2]
    pad = ((0, -h % 16), (0, -w % 16)) + ((0, 0),) * (frame.ndim - 2)
    return np.pad(frame, pad, mode="edge") if pad[0][1] or pad[1][1] else frame


def open_video(path: Path, fps: float):
    import imageio.v2 as imageio

    return imageio.get_writer(
        path,
        fps=fps,
        codec="libx264",
        quality=7,
        macro_block_size=16,
        pixelformat="yuv420p",
        ffmpeg_params=["-preset", "veryfast"],
    )


def progress_bar(total: int | None, env_id: str, disable: bool):
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=f"demo {env_id}", unit="step", disable=disable, leave=False)
