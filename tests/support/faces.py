"""Real face photos turned into test video frames with known motion.

The photos (tests/data/faces, both public domain):

- ``astronaut.jpg``: Eileen Collins, NASA portrait, from scikit-image's ``data.astronaut()``
  ("No known copyright restrictions, released into the public domain"), saved as JPEG;
- ``grace_hopper.jpg``: Commodore Grace M. Hopper, US Navy photograph (a work of the US
  federal government), from matplotlib's sample data ``grace_hopper.jpg``.

:func:`scene` puts a photo's face crop on a plain 640x480 frame, turned in the image plane
by a known angle (counter-clockwise as seen: the image-right side of the head goes up,
which is a positive roll), scaled and moved; ``occlude`` paints a bar over part of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
from PIL import Image, ImageDraw

from chameleons.facemesh.mapping import read_face
from chameleons.facemesh.tracker import FaceTracker

FACES = Path(__file__).resolve().parents[1] / "data" / "faces"
BACKGROUND = (118, 120, 116)
SIZE = (640, 480)
# The face's square in each photo (left, top, right, bottom), about 1.3 face heights.
GLIDE, HOLD = 10, 3  # frames moving to a position (a third of a second at 30 fps), held
CROPS = {"astronaut": (110, 20, 350, 260), "grace_hopper": (80, 20, 460, 400)}


@dataclass(frozen=True)
class Motion:
    angle: float = 0.0  # degrees, counter-clockwise on the image (a positive roll)
    scale: float = 1.0
    dx: int = 0  # pixels, right
    dy: int = 0  # pixels, down
    occlude: str | None = None  # "mouth", "eye" or None
    face: bool = True  # False: the frame without the face


def photo(name: str) -> Image.Image:
    return Image.open(FACES / f"{name}.jpg").convert("RGB")


def scene(name: str, motion: Motion, size: tuple[int, int] = SIZE,
          face_px: int = 240) -> npt.NDArray[np.uint8]:  # fmt: skip
    """One RGB frame (H x W x 3, uint8)."""
    canvas = Image.new("RGB", size, BACKGROUND)
    if motion.face:
        crop = photo(name).crop(CROPS[name])
        side = max(8, round(face_px * motion.scale))
        crop = crop.resize((side, side), Image.Resampling.BILINEAR)
        if motion.occlude is not None:
            draw = ImageDraw.Draw(crop)
            band = (0.62, 0.85) if motion.occlude == "mouth" else (0.30, 0.45)
            draw.rectangle((side * 0.2, side * band[0], side * 0.55, side * band[1]),
                           fill=(40, 40, 40))  # fmt: skip
        turned = crop.rotate(motion.angle, resample=Image.Resampling.BILINEAR,
                             fillcolor=BACKGROUND)  # fmt: skip
        left = (size[0] - side) // 2 + motion.dx
        top = (size[1] - side) // 2 + motion.dy
        canvas.paste(turned, (left, top))
    return np.asarray(canvas, dtype=np.uint8).copy()


class Video:
    """Frames of one photo moving from position to position: ``GLIDE`` frames on the way
    (the tracker's ROI follows the face from frame to frame, as in a real video), then
    ``HOLD`` frames still."""

    def __init__(self, tracker: FaceTracker, name: str) -> None:
        self.tracker, self.name, self.at = tracker, name, Motion()
        tracker.reset()

    def go(self, motion: Motion) -> np.ndarray | None:
        """Yaw, pitch, roll on the last frame at ``motion`` (None: no face)."""
        start, head = self.at, None
        for k in range(1, GLIDE + HOLD + 1):
            f = min(1.0, k / GLIDE)
            frame = Motion(
                angle=start.angle + f * (motion.angle - start.angle),
                scale=start.scale + f * (motion.scale - start.scale),
                dx=round(start.dx + f * (motion.dx - start.dx)),
                dy=round(start.dy + f * (motion.dy - start.dy)),
                occlude=motion.occlude, face=motion.face,
            )  # fmt: skip
            face = self.tracker.process(scene(self.name, frame))
            head = None if face is None else np.array(read_face(face.landmarks, 640, 480).head)
        self.at = motion
        return head
