"""The booth's webcam in a browser: the capture page and its WebSocket.

- ``pages``: ``/capture/<booth>/<key>`` (no login: the key is the credential, like the
  robot display's link, and rotates and retires with it);
- ``endpoints``: ``/ws/capture/<booth>?token=<key>`` (protocol in :mod:`.relay`);
- ``links``: the keys; ``relay``: the page's messages -> envelopes for the booth's worker
  (``chameleons.worker.ingest.browser``).
"""

from chameleons.backend.capture.links import capture_url, current_capture_path

__all__ = ["capture_url", "current_capture_path"]
