"""All configuration: one pydantic-settings class, environment prefix ``CHAMELEONS_``.

Settings are built explicitly (``Settings()`` in ``create_app``/CLI), never at import.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field, SecretStr, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict
from sqlalchemy.engine import make_url

from chameleons.key_entropy import estimated_bits

# Secrets that ship in the repository (demo, .env.example). They never work outside demo mode.
KNOWN_INSECURE_SECRETS = frozenset(
    {"", "change-me", "changeme", "change-me-db-password", "secret", "password", "postgres"}
)
DEFAULT_DATA_DIR = Path("data")


MIN_SECRET_BITS = 128


class InsecureSettingsError(ValueError):
    """Raised when a secret is missing or a known example value outside demo mode."""


class Settings(BaseSettings):
    model_config = SettingsConfigDict(
        env_prefix="CHAMELEONS_", env_file=".env", env_file_encoding="utf-8", extra="ignore"
    )

    # Demo mode (`chameleons demo` sets it): runs without a secret key, with demo content.
    demo_mode: bool = False
    # Database file, recordings, CURVE keys, demo credentials, a lab's 3D heads (heads/).
    data_dir: Path = DEFAULT_DATA_DIR
    database_url: str | None = Field(
        default=None, description="SQLAlchemy URL; default: SQLite file under data_dir"
    )
    # Signs staff sessions and display links; required outside demo mode: at least 128 bits
    # (python -c 'import secrets; print(secrets.token_urlsafe(32))'), not an example value.
    secret_key: SecretStr = SecretStr("")
    # Where `chameleons serve` listens (`chameleons demo` takes --host / --port).
    host: str = "127.0.0.1"
    port: int = Field(default=8000, ge=1, le=65535)
    public_url: str | None = Field(
        default=None, description="Base URL phones use (QR codes); default http://host:port"
    )
    # None: Secure cookies exactly when CHAMELEONS_PUBLIC_URL is https (cookie_secure).
    session_cookie_secure: bool | None = None
    # Request threads (sync endpoints and dependencies). Never more than the database pool's
    # connections (chameleons.backend.db.request_threads); None: anyio's 40, capped so.
    request_threads: int | None = Field(default=None, ge=1)
    # How long a staff login lasts (server-side: logout and deactivation end it at once).
    staff_session_hours: float = Field(default=12.0, gt=0, le=24 * 30)
    # How often each server process re-checks the sessions of its open staff WebSockets
    # (an ended session closes them at once anyway; this catches expiry and
    # `chameleons user deactivate` on SQLite, which has no live channel to the server).
    staff_socket_recheck_s: float = Field(default=30.0, gt=0)
    # WebSocket compression (permessage-deflate). Off: on a lab's network the console's
    # updates cost more to compress than to send (docs/performance.md, "Fewer statements,
    # no compression").
    ws_compression: bool = False
    # Every WebSocket (chameleons.backend.events.guard): outgoing messages queued per socket,
    # incoming messages per second (sustained, and at once), and how long one send may wait
    # for a client that is not reading before it is disconnected.
    ws_queue_limit: int = Field(default=256, ge=8)
    # (A page sends ~1 a second; a rehearsal's display bot answers every prompt at once.)
    ws_message_rate: float = Field(default=200.0, gt=0)
    ws_message_burst: int = Field(default=400, ge=1)
    ws_send_timeout_s: float = Field(default=10.0, gt=0)
    # Failed logins before a user name is locked out from that address, and the first wait
    # (it doubles with every further failure, at most 15 minutes).
    login_max_failures: int = Field(default=5, ge=1)
    login_lockout_seconds: float = Field(default=30.0, ge=0)
    # Reverse proxies whose X-Forwarded-For / -Proto headers say who the client is
    # (comma-separated addresses or networks, "*" for any; uvicorn's forwarded_allow_ips).
    # Empty: none, the connection's own address counts (the login and join throttles key on
    # it). Set it only for a proxy nothing else can reach the server around.
    forwarded_allow_ips: str = ""

    # ZeroMQ endpoints between server and workers (loopback unless configured otherwise).
    worker_command_endpoint: str = "tcp://127.0.0.1:5555"
    worker_telemetry_endpoint: str = "tcp://127.0.0.1:5556"
    # CURVE keys of that link (`chameleons keys create`); default <data_dir>/keys. With keys
    # the link is authenticated and encrypted; without, server and worker refuse to use an
    # endpoint that is not on loopback (chameleons.worker.curve).
    zmq_keys_dir: Path | None = None
    worker_key_name: str = Field(default="worker", pattern=r"^[A-Za-z0-9_.-]{1,64}$")

    # The server's ZeroMQ link to workers; off for tests that need no worker and for extra
    # server processes that only serve phones (docs/deployment.md: more than one server
    # process).
    bridge_enabled: bool = True
    # PostgreSQL only: carry live updates to other server processes on the same database
    # (LISTEN/NOTIFY, chameleons.backend.events.pg_fanout). Costs two connections.
    live_fanout: bool = True
    # Embedded setup (`chameleons demo`): the server runs and supervises a local worker.
    embedded_worker: bool = False
    embedded_worker_booth: str = "booth-1"
    # The robot display's face where neither the study's condition, the display link
    # (?renderer=) nor the booth's own default (the PI's /display page) chooses: the 2D
    # cartoon or the 3D head (docs/hardware/virtual-robot.md).
    display_renderer: Literal["2d", "3d"] = "2d"

    # Face capture inputs of a worker.
    livelink_port: int = Field(default=11111, ge=0, le=65535)  # 0: any free port
    facecapturex_port: int = Field(default=19977, ge=0, le=65535)
    capture_bind_host: str = "0.0.0.0"  # the iPhone is on the LAN by design
    # The only phone a worker accepts capture from (IP address or host name). Unset: the
    # first phone that sends after a session starts (or the wizard's "pair again") is
    # locked in; packets from any other sender are dropped and counted.
    capture_sender: str | None = None
    # Unit of Live Link head/eye rotations on the wire and in take CSVs: "radians" (what the
    # Live Link Face app sends; evidence in docs/livelink.md), "degrees/180" (an Unreal app's
    # own publisher), "degrees", or a plain factor. The booth check's head-turn step shows it.
    livelink_rotation_scale: str = Field(
        default="radians",
        pattern=r"^(degrees/180|radians|degrees|[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?)$",
    )
    # Rotation of the phone about its viewing axis (degrees, counter-clockwise seen from the
    # front); the original study's mount needed 90.
    mounting_rotation_deg: float = Field(default=0.0, ge=-360, le=360)
    # Mirror the participant (swap left/right, negate yaw and roll) rather than same side.
    mirror: bool = True
    # The copy behaviour re-centres the copied head on the participant's mean pose (measured
    # over head_calibration_s of frames from each session's start), so a phone below or
    # beside the face does not make the robot look down or aside at rest (docs/livelink.md).
    head_recentre: bool = True
    head_calibration_s: float = Field(default=20.0, gt=0, le=600)

    # The realtime worker of a booth (`chameleons worker`; options on its command line win).
    worker_booth: str = "booth-1"
    worker_driver: Literal["virtual", "furhat", "record", "null"] = "virtual"
    worker_robot_url: str = "ws://127.0.0.1:9000/v1/events"  # Furhat Realtime API
    worker_robot_key: SecretStr | None = None
    worker_tick_rate: float = Field(default=125.0, gt=0, le=1000)
    worker_face_rate: float = Field(default=25.0, gt=0, le=1000)  # at most the tick rate
    worker_fir_taps: int = Field(default=15, ge=1, le=255)  # head smoothing; odd = linear phase
    worker_fir_cutoff_hz: float = Field(default=6.0, gt=0)
    worker_crossfade_seconds: float = Field(default=0.3, ge=0, le=5)
    worker_copy_delay: float = Field(default=4.0, ge=0, le=11.5)
    # Study face id -> the Furhat's own face name (e.g. {"face-1": "Isabel"}); an id not
    # listed is sent to the robot unchanged (and reported in the worker's telemetry).
    worker_furhat_faces: dict[str, str] = Field(default_factory=dict)

    # The wizard console's health strip: a check outside these limits shows amber
    # ("degraded") and turns red (the alarm) once it has lasted health_alarm_after_s; a
    # disconnected worker or robot is an alarm at once. A bare Python loop on a 2-core PC
    # measures ~3 ms p99 jitter (docs/performance.md), so the jitter limit sits above that.
    health_max_jitter_p99_ms: float = Field(default=5.0, gt=0)
    health_min_face_fps: float = Field(default=20.0, ge=0)
    health_min_tick_ratio: float = Field(default=0.9, ge=0, le=1)  # of the nominal tick rate
    health_alarm_after_s: float = Field(default=3.0, ge=0)

    # What one session's recordings need on disk, for the booth check's disk-space warning:
    # recording rate x session length. The default rate covers the participant's stream
    # (60 fps x 260 bytes a frame) and the robot's (up to 125 Hz), doubled because a
    # recording's journal and its Parquet file both exist while it is closed.
    recording_rate_bytes_per_s: int = Field(default=100_000, gt=0)
    session_length_minutes: float = Field(default=60.0, gt=0)
    # The actor whose first recorded prompt the booth check plays (None: the first actor).
    booth_check_actor: str | None = None
    # How long the booth check asks to hold still (the resting pose the movement is judged
    # against), then for each head movement (turn left, then nod) while the robot runs the
    # copy behaviour; the copy is then waited for (the study's delay).
    booth_check_rest_seconds: float = Field(default=2.0, gt=0, le=10)
    booth_check_turn_seconds: float = Field(default=4.0, gt=0, le=30)
    booth_check_nod_seconds: float = Field(default=4.0, gt=0, le=30)

    # Synchrony of the recorded faces (issue 32, docs/science.md "Synchrony"): rMEA's
    # windowed lagged cross-correlation, computed in the background when a recording stops.
    # Window, increment and lag in seconds (whole samples at 25 Hz); pseudo-pairs per
    # interaction; how long a stopping server waits for queued computations (the rest:
    # `chameleons synchrony`). Every result stores the parameters it was computed with.
    sync_window_s: float = Field(default=30.0, gt=0)
    sync_increment_s: float = Field(default=15.0, gt=0)
    sync_max_lag_s: float = Field(default=6.0, gt=0)
    sync_surrogates: int = Field(default=40, ge=0, le=1000)
    sync_enabled: bool = True
    sync_drain_s: float = Field(default=60.0, ge=0)

    # The lab's other instruments (issue 33, docs/instruments.md). Lab Streaming Layer
    # outlets, off by default: the server publishes each booth's timeline as a Markers
    # stream (chameleons-<booth>-events), and `chameleons worker` its faces (or --lsl).
    # Turn it on in one server process only (each would publish the same markers).
    lsl: bool = False

    # Prompt catalogue: one folder per actor (manifest.csv, actor.yaml, audio/, lipsync/).
    # None: <data_dir>/prompts when it holds actors, else the repository's prompts/.
    prompts_dir: Path | None = None

    # The server's and the worker's log level.
    log_level: Literal["debug", "info", "warning", "error"] = "info"

    @model_validator(mode="after")
    def _resolve_paths(self) -> Settings:
        self.data_dir = self.data_dir.expanduser()
        return self

    @property
    def effective_database_url(self) -> str:
        if self.database_url:
            return self.database_url
        return f"sqlite:///{(self.data_dir / 'chameleons.sqlite3').resolve()}"

    @property
    def keys_dir(self) -> Path:
        return (self.zmq_keys_dir or self.data_dir / "keys").expanduser()

    @property
    def session_disk_bytes(self) -> int:
        """Free disk space one session's recordings need (the booth check warns below it)."""
        return int(self.recording_rate_bytes_per_s * self.session_length_minutes * 60)

    @property
    def cookie_secure(self) -> bool:
        """Send cookies over HTTPS only: on when the public URL is https, unless set."""
        if self.session_cookie_secure is not None:
            return self.session_cookie_secure
        return bool(self.public_url and self.public_url.lower().startswith("https://"))

    @property
    def effective_public_url(self) -> str:
        if self.public_url:
            return self.public_url.rstrip("/")
        host = "127.0.0.1" if self.host in ("0.0.0.0", "::") else self.host
        return f"http://{host}:{self.port}"

    def require_secure(self) -> None:
        """Refuse to run outside demo mode with a missing or example secret key."""
        if self.demo_mode:
            return
        db_password = make_url(self.effective_database_url).password
        if db_password is not None and str(db_password) in KNOWN_INSECURE_SECRETS:
            raise InsecureSettingsError(
                "The database password in CHAMELEONS_DATABASE_URL is an example value "
                "(from .env.example). Set a real password for PostgreSQL and in the URL."
            )
        secret = self.secret_key.get_secret_value()
        if secret in KNOWN_INSECURE_SECRETS or estimated_bits(secret) < MIN_SECRET_BITS:
            raise InsecureSettingsError(
                "CHAMELEONS_SECRET_KEY is missing, guessable (under 128 bits by its length, "
                "variety of characters and repetition) or an example value. "
                "Generate one with: python -c 'import secrets; "
                "print(secrets.token_urlsafe(32))' and set it in the environment or .env. "
                "(`chameleons demo` runs without one, for trying the system out.)"
            )
