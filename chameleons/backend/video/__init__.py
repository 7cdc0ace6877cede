"""Participant video (issue 33; docs/instruments.md, *Participant video*).

- ``pages``: the booth's recording page ``/video/<booth>/<key>`` (the capture link's key)
  and, for the PI, the video file and the replay's face curves;
- ``endpoints``: the recording page's API under ``/api/video/<booth>/`` (the key in the
  ``X-Booth-Key`` header): what to record now, a new video, its chunks, its end;
- ``service``: who may be filmed, storing chunks in order; ``storage``: the files;
  ``curves``: the face recordings on the server's clock for the replay.
"""
