"""No Docker engine runs here, so the deployment files are checked instead of run."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import click
import pytest
import yaml

from chameleons.cli.main import cli
from chameleons.settings import InsecureSettingsError, Settings

ROOT = Path(__file__).resolve().parents[2]
COMPOSE = yaml.safe_load((ROOT / "docker-compose.yml").read_text())
SERVICES: dict[str, dict[str, Any]] = COMPOSE["services"]
APP_SERVICES = {name: svc for name, svc in SERVICES.items() if "build" in svc}


def _env_example() -> dict[str, str]:
    pairs = {}
    for line in (ROOT / ".env.example").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            key, _, value = line.partition("=")
            pairs[key.strip()] = value.strip()
    return pairs


def _resolve(ctx: click.Context, args: list[str]) -> click.Command:
    command: click.Command = cli
    rest = list(args)
    while isinstance(command, click.Group) and rest and not rest[0].startswith("-"):
        sub = command.get_command(ctx, rest.pop(0))
        assert sub is not None, f"`chameleons {' '.join(args)}`: no such command"
        command = sub
    options = {opt for param in command.params for opt in getattr(param, "opts", [])}
    for token in rest:
        if token.startswith("--"):
            assert token in options, f"`chameleons {' '.join(args)}`: unknown option {token}"
    return command


def test_app_services_exist() -> None:
    assert {"db", "server"} <= set(SERVICES)
    assert any(name.startswith("worker") for name in APP_SERVICES)


@pytest.mark.parametrize("name", sorted(APP_SERVICES))
def test_every_command_exists_in_the_cli(name: str) -> None:
    command = APP_SERVICES[name]["command"]
    assert command[0] == "chameleons"
    with click.Context(cli) as ctx:
        _resolve(ctx, command[1:])


@pytest.mark.parametrize("name", sorted(APP_SERVICES))
def test_every_environment_variable_is_a_setting(name: str) -> None:
    fields = {f"CHAMELEONS_{field.upper()}" for field in Settings.model_fields}
    for key in APP_SERVICES[name].get("environment", {}):
        assert key in fields, f"{name}: {key} is not a setting"


def test_env_example_names_real_settings_and_is_refused() -> None:
    fields = {f"CHAMELEONS_{field.upper()}" for field in Settings.model_fields}
    example = _env_example()
    for key in example:
        if key.startswith("CHAMELEONS_"):
            assert key in fields, f".env.example: {key} is not a setting"
    settings = Settings(
        database_url=example["CHAMELEONS_DATABASE_URL"],
        secret_key=example["CHAMELEONS_SECRET_KEY"],
        _env_file=None,
    )
    with pytest.raises(InsecureSettingsError):
        settings.require_secure()
    strong = settings.model_copy(update={"secret_key": Settings(secret_key="x" * 40).secret_key})
    with pytest.raises(InsecureSettingsError, match="database password"):
        strong.require_secure()


def _container_ports(service: dict[str, Any]) -> set[str]:
    return {str(p).split(":")[-1] for p in service.get("ports", [])}


def test_ports_agree_with_setting_defaults() -> None:
    defaults = Settings(_env_file=None)
    server_ports = _container_ports(SERVICES["server"])
    assert str(defaults.port) in server_ports
    for endpoint in (defaults.worker_command_endpoint, defaults.worker_telemetry_endpoint):
        port = re.search(r":(\d+)$", endpoint)
        assert port
        assert port.group(1) in server_ports
        worker_env = SERVICES["worker-booth-1"]["environment"]
        assert any(v.endswith(":" + port.group(1)) for v in worker_env.values())
    worker_ports = _container_ports(SERVICES["worker-booth-1"])
    assert f"{defaults.livelink_port}/udp" in worker_ports
    assert str(defaults.facecapturex_port) in worker_ports


def test_dockerfile_installs_the_package() -> None:
    dockerfile = (ROOT / "Dockerfile").read_text()
    assert "pip install" in dockerfile
    assert re.search(r'CMD \["chameleons", "serve"', dockerfile)
    fields = {f"CHAMELEONS_{field.upper()}" for field in Settings.model_fields}
    for name in re.findall(r"\b(CHAMELEONS_[A-Z_]+)=", dockerfile):
        assert name in fields, f"Dockerfile sets {name}, which is not a setting"
    # The image ships the prompt catalogue and points the server at it.
    assert "COPY prompts ./prompts" in dockerfile
    assert "CHAMELEONS_PROMPTS_DIR=/app/prompts" in dockerfile
