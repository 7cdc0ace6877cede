"""A small writer of XDF files (the format LabRecorder writes; XDF specification 1.0), so
the import is tested on a real file that pyxdf reads: the ``XDF:`` magic, then chunks of
``[NumLengthBytes][Length][Tag][content]`` — FileHeader (1), StreamHeader (2), Samples (3),
ClockOffset (4), Boundary (5), StreamFooter (6). Not a test module."""

from __future__ import annotations

import struct
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

FILE_HEADER, STREAM_HEADER, SAMPLES, CLOCK_OFFSET, BOUNDARY, STREAM_FOOTER = 1, 2, 3, 4, 5, 6
FORMATS = {"float32": "<f", "double64": "<d", "int32": "<i", "int16": "<h"}


def varlen(value: int) -> bytes:
    """A variable-length integer: its byte count (1, 4 or 8), then the value."""
    if value < 256:
        return struct.pack("<BB", 1, value)
    if value < 2**32:
        return struct.pack("<BI", 4, value)
    return struct.pack("<BQ", 8, value)


def chunk(tag: int, content: bytes) -> bytes:
    return varlen(len(content) + 2) + struct.pack("<H", tag) + content


@dataclass
class XdfStream:
    """One stream: samples (rows of values, or of strings) at times on its own clock, and
    the clock offsets (recorder clock - stream clock) measured while recording."""

    stream_id: int
    name: str
    type: str
    channel_format: str
    nominal_srate: float
    times: list[float]
    samples: list[list[float]] | list[list[str]]
    labels: list[str] = field(default_factory=list)
    source_id: str = ""
    offset: float = 0.0  # recorder clock minus this stream's clock

    @property
    def channel_count(self) -> int:
        return len(self.samples[0]) if self.samples else max(1, len(self.labels))

    def header_xml(self) -> str:
        channels = "".join(f"<channel><label>{escape(label)}</label><unit>uV</unit></channel>"
                           for label in self.labels)  # fmt: skip
        desc = f"<desc><channels>{channels}</channels></desc>" if channels else "<desc/>"
        return (f'<?xml version="1.0"?><info><name>{escape(self.name)}</name>'
                f"<type>{escape(self.type)}</type><channel_count>{self.channel_count}"
                f"</channel_count><nominal_srate>{self.nominal_srate}</nominal_srate>"
                f"<channel_format>{self.channel_format}</channel_format>"
                f"<source_id>{escape(self.source_id)}</source_id><version>1.1</version>"
                f"<created_at>{self.times[0] if self.times else 0}</created_at>"
                f"<uid>{uuid.uuid4()}</uid><hostname>lab</hostname>{desc}</info>")  # fmt: skip

    def value_bytes(self, sample: list[float] | list[str]) -> bytes:
        if self.channel_format == "string":
            out = b""
            for text in sample:
                data = str(text).encode()
                out += varlen(len(data)) + data
            return out
        return np.asarray(sample, dtype=FORMATS[self.channel_format]).tobytes()

    def samples_chunks(self, per_chunk: int = 500) -> list[bytes]:
        chunks = []
        for first in range(0, len(self.times), per_chunk):
            rows = range(first, min(first + per_chunk, len(self.times)))
            body = struct.pack("<I", self.stream_id) + varlen(len(rows))
            for i in rows:
                body += struct.pack("<Bd", 8, self.times[i]) + self.value_bytes(self.samples[i])
            chunks.append(chunk(SAMPLES, body))
        return chunks

    def offset_chunks(self, every_s: float = 5.0) -> list[bytes]:
        """Offsets every ``every_s`` of the recording, as LabRecorder measures them (the
        collection time on the stream's clock, as pyxdf fits them against its times)."""
        if not self.times:
            return []
        start, end = self.times[0], self.times[-1]
        count = max(2, int((end - start) / every_s) + 2)
        return [chunk(CLOCK_OFFSET, struct.pack("<Idd", self.stream_id,
                                                start + k * every_s, self.offset))
                for k in range(count)]  # fmt: skip

    def footer_xml(self) -> str:
        first, last = (self.times[0], self.times[-1]) if self.times else (0.0, 0.0)
        return (f'<?xml version="1.0"?><info><first_timestamp>{first}</first_timestamp>'
                f"<last_timestamp>{last}</last_timestamp><sample_count>{len(self.times)}"
                "</sample_count><clock_offsets></clock_offsets></info>")  # fmt: skip


def write_xdf(path: Path, streams: list[XdfStream]) -> Path:
    out = bytearray(b"XDF:")
    out += chunk(FILE_HEADER, b'<?xml version="1.0"?><info><version>1.0</version></info>')
    for stream in streams:
        out += chunk(STREAM_HEADER, struct.pack("<I", stream.stream_id)
                     + stream.header_xml().encode())  # fmt: skip
    out += chunk(BOUNDARY, uuid.UUID("6a6e3a5e-0f4a-4f1c-9a55-8e4f3ad2b1c7").bytes)
    for stream in streams:
        for data in stream.offset_chunks():
            out += data
        for data in stream.samples_chunks():
            out += data
    for stream in streams:
        out += chunk(STREAM_FOOTER, struct.pack("<I", stream.stream_id)
                     + stream.footer_xml().encode())  # fmt: skip
    path.write_bytes(bytes(out))
    return path
