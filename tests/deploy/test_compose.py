"""No Docker engine runs here, so the deployment files are checked instead of run."""

from __future__ import annotations

import fnmatch
import importlib
import pkgutil
import re
from pathlib import Path
from typing import Any

import click
import pytest
import yaml
from fastapi import FastAPI

from chameleons.cli.main import cli
from chameleons.launch.web_server import web_config
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


# --- the scale profile: more server processes behind a proxy --------------------------------

CADDYFILE = ROOT / "deploy" / "Caddyfile"


def _phone_patterns() -> list[str]:
    match = re.search(r"^\s*@phones path (.+)$", CADDYFILE.read_text(), re.MULTILINE)
    assert match, "deploy/Caddyfile has no @phones path matcher"
    return match.group(1).split()


def _route_paths() -> dict[str, str]:
    """Every route path of the server (HTTP and WebSocket) -> the module that serves it."""
    import chameleons.backend as backend

    found = {}
    for module in pkgutil.walk_packages(backend.__path__, "chameleons.backend."):
        router = getattr(importlib.import_module(module.name), "router", None)
        for route in getattr(router, "routes", []):
            found[route.path] = module.name
    return found


def _matches(pattern: str, path: str) -> bool:
    """Caddy's path matcher: exact, or a prefix when it ends in ``*``."""
    concrete = re.sub(r"\{[^}]+\}", "x", path)
    return fnmatch.fnmatchcase(concrete, pattern)


def test_the_proxy_sends_every_phone_route_to_the_replicas_and_nothing_else() -> None:
    patterns, routes = _phone_patterns(), _route_paths()
    phone = {p for p, module in routes.items() if module.startswith("chameleons.backend.phone.")}
    assert {"/p/{token}", "/ws/p/{token}", "/api/phone/{token}/ranking"} <= phone
    for path in phone:
        assert any(_matches(pattern, path) for pattern in patterns), f"{path} goes to server"
    for path, module in routes.items():
        if path not in phone:
            assert not any(_matches(p, path) for p in patterns), f"{path} ({module}) to replicas"


def test_the_scale_profile_runs_replicas_behind_the_proxy() -> None:
    replicas, proxy = SERVICES["server-phones"], SERVICES["proxy"]
    assert replicas["profiles"] == proxy["profiles"] == ["scale"]
    assert replicas["environment"]["CHAMELEONS_BRIDGE_ENABLED"] == "false"  # one worker link
    # Replicas cannot share a host port, and they trust X-Forwarded-For: none published.
    assert "ports" not in replicas
    count = re.fullmatch(r"\$\{PHONE_SERVER_REPLICAS:-(\d+)\}", replicas["deploy"]["replicas"])
    assert count, "replicas: ${PHONE_SERVER_REPLICAS:-N}"
    assert int(count.group(1)) >= 2
    mount = next(v for v in proxy["volumes"] if v.endswith(":/etc/caddy/Caddyfile:ro"))
    assert (ROOT / mount.split(":")[0]).resolve() == CADDYFILE
    caddyfile = CADDYFILE.read_text()
    # The upstreams are the compose services, on the port their command serves.
    for name in ("server", "server-phones"):
        port = SERVICES[name]["command"][SERVICES[name]["command"].index("--port") + 1]
        assert re.search(rf"\b{name}[: ]{port}\b", caddyfile), f"{name}:{port} not proxied"
    assert "lb_policy cookie" in caddyfile  # a phone sticks to one replica


def test_the_replicas_believe_the_proxys_forwarded_addresses_and_the_server_none() -> None:
    trusted = SERVICES["server-phones"]["environment"]["CHAMELEONS_FORWARDED_ALLOW_IPS"]
    config = web_config(FastAPI(), Settings(forwarded_allow_ips=trusted, _env_file=None))
    assert (config.proxy_headers, config.forwarded_allow_ips) == (True, "*")
    # The main server (its port is published) believes no forwarded header.
    assert "CHAMELEONS_FORWARDED_ALLOW_IPS" not in SERVICES["server"].get("environment", {})
    config = web_config(FastAPI(), Settings(_env_file=None))  # how `chameleons serve` runs
    assert config.proxy_headers is False
