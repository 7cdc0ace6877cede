"""The server side of the ZeroMQ link to the booth workers.

Wiring it into the app (``chameleons/backend/app.py``, the lifespan)::

    from chameleons.backend.bridge import Bridge, WorkerSupervisor

    bridge = Bridge.from_settings(settings)          # binds ROUTER + SUB on start
    await bridge.start()
    app.state.bridge = bridge                        # wizard.worker_link reads it
    bridge.add_listener("display.", lambda m: relay_envelope(display_channel, m))
    forward_speech_events(display_channel, bridge.send_command)
    supervisor = None
    if settings.demo_mode:                           # embedded: a local worker
        supervisor = WorkerSupervisor(bridge, "booth-1", ["--driver", "virtual"])
        await supervisor.start()
    yield
    if supervisor is not None:
        await supervisor.stop()
    await bridge.stop()

``await bridge.send_command(booth, "set_behaviour", {"name": "copy"}, timeout=1.5)``
returns an :class:`~chameleons.worker.control.Ack` (``ok``, ``result``, ``error``,
``detail``) or raises :class:`WorkerTimeoutError` (a ``TimeoutError``) /
:class:`WorkerUnavailableError`. ``bridge.latest_telemetry(booth)`` gives the last
heartbeat and its age; ``bridge.subscribe(booth)`` an async iterator of telemetry, events,
display frames and ``worker.<booth>`` connection messages (connected/restarted/lost).
"""

from chameleons.backend.bridge.bridge import (
    Bridge,
    BridgeError,
    WorkerTimeoutError,
    WorkerUnavailableError,
)
from chameleons.backend.bridge.state import BoothState, WorkerInfo
from chameleons.backend.bridge.subscriptions import Subscription
from chameleons.backend.bridge.supervisor import WorkerSupervisor

__all__ = [
    "BoothState",
    "Bridge",
    "BridgeError",
    "Subscription",
    "WorkerInfo",
    "WorkerSupervisor",
    "WorkerTimeoutError",
    "WorkerUnavailableError",
]
