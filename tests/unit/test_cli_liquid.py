"""The liquid's CLI: bad input fails at once in one line; one cheap real benchmark."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import typer
from typer.testing import CliRunner

from app.cli_liquid import register_liquid_commands
from app.services import liquid
from app.services.dynamics import (
    DYNAMICS_NAMES,
    LIQUID_PRESETS,
    UnknownPreset,
    make_dynamics,
)


@pytest.fixture(scope="module")
def cli() -> typer.Typer:
    """The liquid commands on their own app (``app.cli`` registers them the same way)."""
    app = typer.Typer(pretty_exceptions_enable=False)
    bench_app = typer.Typer()
    app.add_typer(bench_app, name="bench")
    register_liquid_commands(app, bench_app)
    return app


UNKNOWN = "unknown preset 'huge' (known: tiny, small, paper)"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["validate", "--preset", "huge"], UNKNOWN),
        (["calibrate", "--preset", "huge"], UNKNOWN),
        (["bench", "sph", "--preset", "huge"], UNKNOWN),
        (["bench", "clip", "--preset", "huge"], UNKNOWN),
        (["bench", "sph", "--steps", "0"], "--steps must be positive, got 0"),
        (["bench", "sph", "--preset", "tiny", "--steps", "-5"], "--steps must be positive, got -5"),
        (["bench", "store", "--edges", "0"], "--edges must be positive, got 0"),
    ],
)
def test_bad_input_raises_a_one_line_value_error_before_any_work(
    cli: typer.Typer, args: list[str], message: str
) -> None:
    result = CliRunner().invoke(cli, args)
    assert result.exit_code != 0
    assert isinstance(result.exception, ValueError)
    assert str(result.exception) == message
    assert result.output == ""  # nothing started


def test_main_prints_srg_error_and_exits_2(
    cli: typer.Typer, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import app.cli

    monkeypatch.setattr(app.cli, "app", cli)
    monkeypatch.setattr(sys, "argv", ["srg", "bench", "sph", "--preset", "huge"])
    with pytest.raises(SystemExit) as exit_info:
        app.cli.main()
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err == f"srg: error: {UNKNOWN}\n"


def test_make_dynamics_knows_the_liquid_and_names_its_errors(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert DYNAMICS_NAMES == ("toy", "liquid")
    assert LIQUID_PRESETS == ("tiny", "small", "paper")
    assert make_dynamics("liquid", "tiny").preset == "tiny"  # type: ignore[attr-defined]
    assert make_dynamics("liquid").preset == "small"  # type: ignore[attr-defined]
    with pytest.raises(UnknownPreset, match="unknown preset 'huge'"):
        make_dynamics("liquid", "huge")

    def missing(preset: str) -> liquid.LiquidCalibration:
        raise liquid.MissingCalibration(f"no calibration for preset {preset!r}")

    monkeypatch.setattr(liquid, "load_calibration", missing)
    with pytest.raises(LookupError, match=r"run `srg calibrate --preset tiny` first"):
        make_dynamics("liquid", "tiny")


def _fake_report(passed: bool) -> dict[str, Any]:
    checks = {"twins": {"passed": True}, "hydrostatic": {"passed": passed}}
    return {"preset": "tiny", "checks": checks, "passed": passed}


@pytest.mark.parametrize("passed", [True, False])
def test_validate_prints_the_report_and_exits_1_when_a_check_fails(
    cli: typer.Typer, monkeypatch: pytest.MonkeyPatch, passed: bool
) -> None:
    from app.services import sph_validation

    monkeypatch.setattr(sph_validation, "validate", lambda preset: _fake_report(passed))
    result = CliRunner().invoke(cli, ["validate", "--preset", "tiny", "--json", "-"])
    assert result.exit_code == (0 if passed else 1)
    assert json.loads(result.stdout) == _fake_report(passed)


def test_validate_json_file_gets_the_report_and_stdout_a_line_per_check(
    cli: typer.Typer, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from app.services import sph_validation

    monkeypatch.setattr(sph_validation, "validate", lambda preset: _fake_report(False))
    target = tmp_path / "out" / "validate.json"
    result = CliRunner().invoke(cli, ["validate", "--preset", "tiny", "--json", str(target)])
    assert result.exit_code == 1
    assert json.loads(target.read_text()) == _fake_report(False)
    assert result.stdout.splitlines()[:2] == ["twins: passed", "hydrostatic: FAILED"]


def test_importing_the_dynamics_registry_does_not_load_opencl_or_mitsuba() -> None:
    code = (
        "import sys, app.services.dynamics, app.cli_liquid; "
        "print(sorted(m for m in ('pyopencl', 'mitsuba') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_bench_sph_tiny_reports_positive_throughput(cli: typer.Typer) -> None:
    args = ["bench", "sph", "--preset", "tiny", "--steps", "5", "--no-splishsplash"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["preset"] == "tiny" and report["particles"] == 1920
    assert "splishsplash_pcisph" not in report
    for key in ("converged", "fixed_3_iterations"):
        assert report[key]["particle_steps_per_s"] > 0
        assert report[key]["substeps"] > 0
