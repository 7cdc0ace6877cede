"""The recording page's requests and the server's answers."""

from __future__ import annotations

from pydantic import BaseModel, Field


class Clock(BaseModel):
    """How the page's clock maps onto the server's: the page's ``performance.now()`` when
    the recorder started, the offset (server epoch ms minus page ms) measured over the
    quickest round trip of its state polls, and that round trip."""

    start_ms: float = Field(ge=0, le=1e12, description="performance.now() at the recorder's start")
    offset_ms: float = Field(ge=0, le=1e14, description="server epoch ms minus page ms")
    rtt_ms: float = Field(ge=0, le=600_000, description="the round trip the offset came from")


class VideoStart(BaseModel):
    session_id: int = Field(ge=1, le=2**31 - 1)
    mime_type: str = Field(max_length=128, description="MediaRecorder's mimeType (video/webm...)")
    audio: bool = Field(False, description="whether the recording has the microphone")
    clock: Clock


class BoothVideoState(BaseModel):
    """What the booth's recording page should do now."""

    server_ms: float = Field(description="the server's clock (epoch ms) when it answered")
    session_id: int | None = None
    record: bool = False
    audio: bool = False
    reason: str = ""


class VideoStarted(BaseModel):
    video_id: int
    started_at: str


class ChunkStored(BaseModel):
    video_id: int
    seq: int
    size: int
    chunks: int
    size_bytes: int
