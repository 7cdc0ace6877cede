"""How many bits a secret key carries, estimated from above (``estimated_bits``).

Three estimates, each an upper bound on what an attacker has to guess, and the smallest
wins:

- *variety*: the key's length times the Shannon entropy of its characters; a key of one
  repeated character has 0 bits however long it is;
- *repetition*: a key that repeats a shorter part at least twice (``"ab" * 64``,
  ``"changeme" * 6``) is worth no more than that part; found with the prefix function
  (Knuth-Morris-Pratt) in one pass;
- *compression*: what DEFLATE needs for the key's bytes (for a hex key, the bytes it
  spells), or for the differences between neighbouring bytes (``"abcdef..."``, a keyboard
  run), at 8 bits per byte; catches a near repetition with a different last character, or
  a word repeated with numbers.

Random keys are incompressible, so for them the variety estimate is the one that counts:
``secrets.token_urlsafe(32)`` (43 characters, 256 bits) estimates at about 210 bits. A
22-character key cannot reach 128 by variety (22 x log2 22 < 100): its characters look
like a four-word passphrase's, so such short keys are refused whatever made them.

Hex keys are the exception (``openssl rand -hex 16``, ``secrets.token_hex(16)``: 32 digits,
exactly 128 bits). The variety of a short sample falls short of its source's by chance: 32
random hex digits show 3.61 bits a character on average, not 4, so the estimate refused
nearly every such key. A key made only of hex digits (one case) whose variety is what a
random one shows, within ``HEX_MARGIN_BITS`` of the expected value, is credited with the
4 bits a character a hex digit can carry at most: still an upper bound. Keys people make
from hex letters (``"deadbeef" * 4``, ``"decafbadbeefcafe..."``: 2.2-2.6 bits a character)
fall under that threshold (2.61 bits at 32 digits) or are caught by the repetition and
compression estimates. Two million random 32-digit
keys came no lower than 0.81 bits under the expected value (mean 3.611, sd 0.132). A
random key's end also matches its start by chance (one hex key in 16 by a digit): only a
part repeated twice or more counts as repetition.
"""

from __future__ import annotations

import itertools
import math
import zlib
from collections import Counter

HEX_DIGITS = (frozenset("0123456789abcdef"), frozenset("0123456789ABCDEF"))
HEX_MARGIN_BITS = 1.0


def shannon_bits(text: str) -> float:
    n = len(text)
    return -sum(count * math.log2(count / n) for count in Counter(text).values())


def expected_shannon_per_char(n: int, alphabet: int) -> float:
    """The mean per-character Shannon entropy (bits) of ``n`` characters drawn uniformly
    from ``alphabet`` symbols: log2(n) - E[sum of N log2 N] / n, where each symbol's count
    N is Binomial(n, 1/alphabet) (computed in logs: no overflow for long keys)."""
    p = 1.0 / alphabet
    expected = 0.0
    for count in range(2, n + 1):  # counts 0 and 1 add nothing (N log N = 0)
        log_mass = (math.lgamma(n + 1) - math.lgamma(count + 1) - math.lgamma(n - count + 1)
                    + count * math.log(p) + (n - count) * math.log1p(-p))  # fmt: skip
        expected += math.exp(log_mass) * count * math.log2(count)
    return math.log2(n) - alphabet * expected / n


def _variety_bits(text: str) -> float:
    """Length times the characters' Shannon entropy; for a random-looking hex key, the 4
    bits a character its source gives (see the module's docstring)."""
    bits = shannon_bits(text)
    n = len(text)
    if _hex_only(text) and bits / n >= expected_shannon_per_char(n, 16) - HEX_MARGIN_BITS:
        return max(bits, 4.0 * n)
    return bits


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


def _hex_only(text: str) -> bool:
    return len(text) > 1 and any(set(text) <= digits for digits in HEX_DIGITS)


def _compressed_bits(text: str) -> int:
    # A hex key is compressed as the bytes it spells: DEFLATE's Huffman coding would
    # otherwise find the 4 bits a hex digit carries and count its own block header as
    # the key's (random 32-digit keys came out as low as 116 bits).
    data = bytes.fromhex(text) if _hex_only(text) and len(text) % 2 == 0 else text.encode()
    steps = bytes((b - a) % 256 for a, b in itertools.pairwise(data))
    return min(_deflated_bits(data), 8 + _deflated_bits(steps))


def estimated_bits(secret: str) -> float:
    """An upper estimate of a key's entropy in bits (0 for an empty key)."""
    if not secret:
        return 0.0
    period = smallest_period(secret)
    if period > len(secret) // 2:
        # Not two whole copies: a random key's end matches its start by chance (1 in 16
        # hex keys by one digit), which is no repetition; a real near-repetition is what
        # the compression estimate finds.
        period = len(secret)
    bits = min(
        _variety_bits(secret),
        _variety_bits(secret[:period]),
        float(_compressed_bits(secret)),
    )
    return max(bits, 0.0)  # 0.0, not -0.0, for one repeated character
