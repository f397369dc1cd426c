"""infra/compose.yaml and the Dockerfile hold together (no Docker engine here, so they are
read, not run): every srg service runs a command the CLI parses, from the one image the
Dockerfile builds, after the migration; Redis and the artifacts live on volumes; Flower
asks for a password; the API's healthcheck asks its health route."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

import pytest
import typer
import yaml

from app.cli.main import app

ROOT = Path(__file__).resolve().parents[2]
COMPOSE = ROOT / "infra" / "compose.yaml"
DOCKERFILE = ROOT / "Dockerfile"
SRG_SERVICES = {"migrate", "worker", "beat", "flower", "api"}


@pytest.fixture(scope="module")
def services() -> dict[str, Any]:
    document = yaml.safe_load(COMPOSE.read_text())
    assert set(document["services"]) == SRG_SERVICES | {"postgres", "redis"}
    return dict(document["services"])


def parse_srg(args: list[str]) -> Any:
    """The context of ``srg args`` as the CLI parses it, without running it: an unknown
    command, option or bad value raises click's usage error."""
    command: Any = typer.main.get_command(app)
    name, context = "srg", None
    while True:
        context = command.make_context(name, list(args), parent=context)
        if not hasattr(command, "resolve_command"):
            return context
        # a group keeps its subcommand's words where typer's own completion reads them
        name, command, args = command.resolve_command(
            context, [*context._protected_args, *context.args]
        )


def test_every_srg_service_runs_a_command_the_cli_parses(services: dict[str, Any]) -> None:
    for name in SRG_SERVICES:
        command = services[name]["command"]
        assert command[0] == "srg", name
        parse_srg(command[1:])  # raises on an unknown command or option
    with pytest.raises(Exception, match="No such option"):
        parse_srg(["worker", "--no-such-option"])


def test_srg_services_share_the_image_the_dockerfile_builds(services: dict[str, Any]) -> None:
    for name in SRG_SERVICES:
        service = services[name]
        assert service["image"] == "srg:latest", name
        context = (COMPOSE.parent / service["build"]["context"]).resolve()
        assert context / service["build"]["dockerfile"] == DOCKERFILE, name
    for name in ("postgres", "redis"):
        assert "build" not in services[name] and ":" in services[name]["image"], name


def test_the_migration_runs_once_before_every_other_srg_service(
    services: dict[str, Any],
) -> None:
    migrate = services["migrate"]
    assert migrate["command"] == ["srg", "db", "upgrade"]
    assert migrate["restart"] == "no"
    assert migrate["depends_on"]["postgres"] == {"condition": "service_healthy"}
    for name in SRG_SERVICES - {"migrate"}:
        depends = services[name]["depends_on"]
        assert depends["migrate"] == {"condition": "service_completed_successfully"}, name


def test_redis_and_the_artifacts_are_on_volumes(services: dict[str, Any]) -> None:
    declared = set(yaml.safe_load(COMPOSE.read_text())["volumes"])
    redis = services["redis"]
    command = redis["command"]
    assert command[command.index("--appendonly") + 1] == "yes"
    data_dir = command[command.index("--dir") + 1]
    assert f"redisdata:{data_dir}" in redis["volumes"]
    assert "pgdata:/var/lib/postgresql/data" in services["postgres"]["volumes"]
    for name in SRG_SERVICES:
        artifact_dir = services[name]["environment"]["SRG_ARTIFACT_DIR"]
        assert f"artifacts:{artifact_dir}" in services[name]["volumes"], name
    assert declared == {"pgdata", "redisdata", "artifacts"}


def test_flower_needs_a_password_from_the_environment(services: dict[str, Any]) -> None:
    flower = services["flower"]
    assert re.fullmatch(
        r"\$\{SRG_FLOWER_BASIC_AUTH:\?.+\}", flower["environment"]["SRG_FLOWER_BASIC_AUTH"]
    )
    assert not any("basic" in word for word in flower["command"])  # not in `ps`
    assert "FLOWER_UNAUTHENTICATED_API" not in COMPOSE.read_text()
    assert all(port.startswith("127.0.0.1:") for port in flower["ports"])


def test_the_api_healthcheck_asks_the_health_route_on_the_served_port(
    services: dict[str, Any],
) -> None:
    api = services["api"]
    port = parse_srg(api["command"][1:]).params["port"]
    check = " ".join(api["healthcheck"]["test"])
    assert f"http://127.0.0.1:{port}/api/health" in check
    assert f"{port}:{port}" in api["ports"]


def test_every_long_running_service_has_a_healthcheck_of_its_own(
    services: dict[str, Any],
) -> None:
    """Compose restarts and orders by health: a worker, beat or Flower that hangs must
    show as unhealthy. Each check asks what its own command serves or writes."""
    import app.tasks

    for name, service in services.items():
        if name != "migrate":
            assert "healthcheck" in service, name
    worker = " ".join(services["worker"]["healthcheck"]["test"])
    module, attribute = re.search(r"-A (\S+)", worker).group(1).split(":")  # type: ignore[union-attr]
    assert module == "app.tasks" and hasattr(app.tasks, attribute)
    assert "inspect ping -d celery@$$HOSTNAME" in worker  # its own node, not any worker
    beat = services["beat"]
    schedule = parse_srg(beat["command"][1:]).params["schedule"]
    assert f"glob.glob('{schedule}*')" in " ".join(beat["healthcheck"]["test"])
    flower = services["flower"]
    port = parse_srg(flower["command"][1:]).params["port"]
    check = " ".join(flower["healthcheck"]["test"])
    assert f"http://127.0.0.1:{port}/healthcheck" in check


def test_the_image_is_a_normal_pinned_install_as_a_user_with_libllvm_and_pocl() -> None:
    text = DOCKERFILE.read_text()
    installs = [line for line in text.splitlines() if "pip install" in line]
    assert installs and not any(" -e " in line or "--editable" in line for line in installs)
    assert all("-c /tmp/srg-src/requirements/constraints.txt" in line for line in installs)
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"
    ]
    assert any("[all]" in line for line in installs) and "all" in extras
    assert "libllvm19" in text and "pocl-opencl-icd" in text
    users = re.findall(r"^USER\s+(\S+)", text, flags=re.MULTILINE)
    assert users and users[-1] not in {"root", "0"}
