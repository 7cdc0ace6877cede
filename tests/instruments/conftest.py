"""LSL in tests stays on this machine: liblsl multicasts its stream queries on the network
by default, so every test process reads tests/instruments/lsl_api.cfg (``LSLAPICFG``,
``ResolveScope = machine``) before liblsl reads any configuration (it reads one, once)."""

from __future__ import annotations

import os
from pathlib import Path

LSL_CONFIG = Path(__file__).with_name("lsl_api.cfg")
os.environ["LSLAPICFG"] = str(LSL_CONFIG)
