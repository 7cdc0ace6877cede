from __future__ import annotations

from pathlib import Path

from chameleons.launch.embedded import DEMO_MAX_JITTER_P99_MS, demo_settings
from chameleons.settings import Settings


def test_demo_settings_run_a_local_worker_with_a_persistent_key(tmp_path: Path) -> None:
    first = demo_settings(Settings(data_dir=tmp_path, _env_file=None))
    again = demo_settings(Settings(data_dir=tmp_path, _env_file=None))
    assert first.demo_mode
    assert first.embedded_worker
    assert len(first.secret_key.get_secret_value()) >= 32
    assert first.secret_key == again.secret_key  # logins survive a restart


def test_demo_relaxes_the_jitter_alarm_unless_configured(tmp_path: Path) -> None:
    assert Settings(_env_file=None).health_max_jitter_p99_ms < DEMO_MAX_JITTER_P99_MS
    relaxed = demo_settings(Settings(data_dir=tmp_path, _env_file=None))
    assert relaxed.health_max_jitter_p99_ms == DEMO_MAX_JITTER_P99_MS
    chosen = Settings(data_dir=tmp_path, health_max_jitter_p99_ms=3.0, _env_file=None)
    assert demo_settings(chosen).health_max_jitter_p99_ms == 3.0
