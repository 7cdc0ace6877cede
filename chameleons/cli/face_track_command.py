"""``chameleons face-track``: a recorded video -> a Live Link Face take, by the Python tracker."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import click

from chameleons.worker.take_writer import TakeRow, write_take

_VIDEO = click.Path(exists=True, dir_okay=False, path_type=Path)


@click.command("face-track")
@click.argument("video", type=_VIDEO)
@click.option("--out", "out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The take CSV to write (Live Link Face's 63 columns).")  # fmt: skip
@click.option("--threads", type=int, default=2, show_default=True,
              help="CPU threads for the face models.")  # fmt: skip
def face_track(video: Path, out: Path, threads: int) -> None:
    """Track the face in a video (MP4, WebM, MOV, MJPEG AVI) and write it as a Live Link
    Face take: ARKit's 52 values and head and eye rotations in radians, the video's time as
    the timecode, frames without a face left out.

    The take imports with `chameleons prompts import` as a prompt's face or a natural clip.
    Channels a webcam cannot measure (cheekPuff, jawForward, tongueOut; the eyes' look) are
    written as 0.
    """
    from chameleons.facemesh.mapping import read_face
    from chameleons.facemesh.tracker import FaceTracker, TrackerUnavailableError
    from chameleons.worker.ingest.video import VideoError, video_frames, video_info

    try:
        info = video_info(video)
        tracker = FaceTracker(threads=threads)
    except (VideoError, TrackerUnavailableError) as exc:
        raise click.ClickException(str(exc)) from exc
    seen = [0]

    def rows() -> Iterator[TakeRow]:
        for frame in video_frames(video):
            seen[0] += 1
            face = tracker.process(frame.image)
            if face is None:
                continue
            try:
                reading = read_face(face.landmarks, face.width, face.height)
            except ValueError:
                continue  # landmarks too degenerate for a pose: as if no face
            yield TakeRow(frame.time, reading.blendshapes, reading.head, reading.eyes)

    try:
        written = _write_if_any(out, rows(), info.frame_rate or 30.0)
    except VideoError as exc:
        raise click.ClickException(str(exc)) from exc
    if not written:
        raise click.ClickException(f"{video}: no face found in any of its {seen[0]} frames; "
                                   "nothing written.")  # fmt: skip
    click.echo(f"{out}: {written} of {seen[0]} frames with a face "
               f"({info.width}x{info.height} {info.codec}, {info.frame_rate:.3g} fps)")


def _write_if_any(out: Path, rows: Iterator[TakeRow], frame_rate: float) -> int:
    """Write the take only when there is a row to write (a face-less video leaves no file)."""
    first = next(rows, None)
    if first is None:
        return 0

    def chained() -> Iterator[TakeRow]:
        yield first
        yield from rows

    return write_take(out, chained(), frame_rate)
