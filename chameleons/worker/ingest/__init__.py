"""Face-capture ingest: wire parsers, normalisation and the UDP/TCP receivers.

Importing this package has no side effects; the receivers start only when asked.
"""

from chameleons.worker.ingest.errors import IngestError

__all__ = ["IngestError"]
