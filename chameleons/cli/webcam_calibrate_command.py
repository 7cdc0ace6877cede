"""``chameleons webcam-calibrate``: the iPhone as the webcam's teacher, from the command line.

The lab records a few minutes with both sources at once: the webcam as a video (the first
seconds with a relaxed face, looking into the camera: the neutral face) and the iPhone as
a Live Link Face take (the app's own recording, CSV). The video is tracked with the Python
tracker; the iPhone's values are read at each tracked frame's time (``--offset``: the
take's time at the video's start; the fit finds the rest of the delay, within 0.5 s);
:func:`chameleons.facemesh.teacher.fit_map` fits a ridge regression per channel and
reports its agreement on the held-out last quarter. The map is written as JSON with its
hash; ``chameleons worker --webcam-map MAP.json`` uses it for that booth's webcam.
"""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

_FILE = click.Path(exists=True, dir_okay=False, path_type=Path)


@click.command("webcam-calibrate")
@click.argument("video", type=_FILE)
@click.argument("take", type=_FILE)
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The map to write (JSON; its name says its hash).")  # fmt: skip
@click.option("--offset", type=float, default=0.0, show_default=True,
              help="Seconds into the iPhone take at which the video starts.")  # fmt: skip
@click.option("--neutral-seconds", type=float, default=3.0, show_default=True,
              help="The video's first seconds, a relaxed face: the neutral face.")  # fmt: skip
@click.option("--threads", type=int, default=2, show_default=True,
              help="CPU threads for the face models.")  # fmt: skip
def webcam_calibrate(video: Path, take: Path, out: Path, offset: float,
                     neutral_seconds: float, threads: int) -> None:  # fmt: skip
    """Teach a booth's webcam with its iPhone: fit, per ARKit channel, the map from the
    webcam's landmark features to the iPhone's values and write it for `chameleons worker
    --webcam-map`.

    VIDEO and TAKE (a Live Link Face CSV) are recorded at the same time, the video's first
    seconds a relaxed face; each channel's agreement on held-out frames (R², correlation,
    lag) is printed.
    """
    from chameleons.facemesh.arkit import neutral_from
    from chameleons.facemesh.mapping import read_face
    from chameleons.facemesh.teacher import fit_map, map_to_json
    from chameleons.facemesh.tracker import FaceTracker, TrackerUnavailableError
    from chameleons.worker.ingest.video import VideoError, video_frames, video_info
    from chameleons.worker.takes import TakeError, read_take

    try:
        iphone = read_take(take)
        info = video_info(video)
        tracker = FaceTracker(threads=threads)
        times, rows = [], []
        for frame in video_frames(video):
            face = tracker.process(frame.image)
            if face is None:
                continue
            try:
                reading = read_face(face.landmarks, face.width, face.height)
            except ValueError:
                continue
            times.append(frame.time)
            rows.append(reading.features)
    except (TakeError, VideoError, TrackerUnavailableError) as exc:
        raise click.ClickException(str(exc)) from exc
    if not rows:
        raise click.ClickException(f"{video}: no face found in any frame; nothing to teach.")
    at = np.asarray(times) + offset
    inside = (at >= iphone.times[0]) & (at <= iphone.times[-1])
    if inside.sum() < 40:
        raise click.ClickException(
            f"Only {int(inside.sum())} of the video's frames with a face fall inside the "
            f"iPhone take ({iphone.duration:.1f} s): record both at once, for minutes, and "
            "set --offset to the take's time at the video's start."
        )
    features = np.asarray(rows)[inside]
    targets = np.stack([np.interp(at[inside], iphone.times, iphone.blendshapes[:, c])
                        for c in range(iphone.blendshapes.shape[1])], axis=1)  # fmt: skip
    still = np.asarray(times) <= times[0] + neutral_seconds
    try:
        teaching = fit_map(features, targets, neutral_from(np.asarray(rows)[still]),
                           rate=info.frame_rate or 30.0)  # fmt: skip
    except ValueError as exc:
        raise click.ClickException(f"Cannot teach a map: {exc}.") from exc
    out.write_text(map_to_json(teaching.mapping, teaching), "utf-8")
    click.echo(f"{'channel':<22} {'R²':>6} {'r':>6} {'lag s':>6}")
    for report in teaching.channels:
        click.echo(f"{report.channel:<22} {report.r2:>6.2f} {report.correlation:>6.2f} "
                   f"{report.lag_s:>6.2f}")  # fmt: skip
    click.echo(
        f"{out}: map {teaching.mapping.name}, taught on {teaching.train_frames} frames, "
        f"tested on {teaching.test_frames}; the webcam trailed the iPhone by "
        f"{teaching.aligned_s:.2f} s. Use it: chameleons worker --webcam-map {out}"
    )
