"""How many bits a secret key carries, estimated from above (``estimated_bits``).

Three estimates, each an upper bound on what an attacker has to guess, and the smallest
wins:

- *variety*: the key's length times the Shannon entropy of its characters; a key of one
  repeated character has 0 bits however long it is;
- *repetition*: a key that repeats a shorter part (``"ab" * 64``, ``"changeme" * 6``) is
  worth no more than that part; found with the prefix function (Knuth-Morris-Pratt) in one
  pass;
- *compression*: what DEFLATE needs for the key's bytes, or for the differences between
  neighbouring bytes (``"abcdef..."``, a keyboard run), at 8 bits per byte; catches a
  near repetition with a different last character, or a word repeated with numbers.

Random keys are incompressible, so for them the variety estimate is the one that counts:
``secrets.token_urlsafe(32)`` (43 characters, 256 bits) estimates at about 210 bits. A
22-character key cannot reach 128 by variety (22 x log2 22 < 100): its characters look
like a four-word passphrase's, so such short keys are refused whatever made them.
"""

from __future__ import annotations

import itertools
import math
import zlib
from collections import Counter


def _shannon_bits(text: str) -> float:
    n = len(text)
    return -sum(count * math.log2(count / n) for count in Counter(text).values())


def smallest_period(text: str) -> int:
    """The length of the shortest part whose repetition spells ``text`` (the last copy may
    be cut short); ``len(text)`` when there is none."""
    border = [0] * len(text)  # the prefix function: longest proper prefix that is a suffix
    for i in range(1, len(text)):
        k = border[i - 1]
        while k and text[i] != text[k]:
            k = border[k - 1]
        border[i] = k + (text[i] == text[k])
    return len(text) - border[-1] if text else 0


def _deflated_bits(data: bytes) -> int:
    packer = zlib.compressobj(9, zlib.DEFLATED, -15)  # raw DEFLATE: no header or checksum
    return 8 * len(packer.compress(data) + packer.flush())


def _compressed_bits(text: str) -> int:
    data = text.encode()
    steps = bytes((b - a) % 256 for a, b in itertools.pairwise(data))
    return min(_deflated_bits(data), 8 + _deflated_bits(steps))


def estimated_bits(secret: str) -> float:
    """An upper estimate of a key's entropy in bits (0 for an empty key)."""
    if not secret:
        return 0.0
    period = smallest_period(secret)
    bits = min(
        _shannon_bits(secret),
        _shannon_bits(secret[:period]),
        float(_compressed_bits(secret)),
    )
    return max(bits, 0.0)  # 0.0, not -0.0, for one repeated character
