"""The virtual robot: the booth screen's display page, its WebSocket and prompt media.

- ``pages``: ``/display`` (staff: every booth's link), ``/display/<booth>/<token>`` (the
  booth screen, no login), ``/display/<booth>`` (staff);
- ``endpoints``: ``/ws/display/<booth>`` (protocol in :mod:`.protocol`);
- ``media``: ``/media/prompts/<actor>/<file>[?lang=<language folder>]`` (MP3 for browsers,
  WAV for a Furhat);
- ``channel``: :class:`DisplayChannel`, the hub the worker bridge publishes into;
- ``relay``: worker ``display.<booth>`` envelopes -> page messages, speech events -> worker.
"""

from chameleons.backend.display.channel import DisplayChannel, get_display_channel
from chameleons.backend.display.media import media_path, prompt_audio_url_builder
from chameleons.backend.display.relay import forward_speech_events, relay_envelope
from chameleons.backend.display.tokens import display_path, signing_key

__all__ = [
    "DisplayChannel",
    "display_path",
    "forward_speech_events",
    "get_display_channel",
    "media_path",
    "prompt_audio_url_builder",
    "relay_envelope",
    "signing_key",
]
