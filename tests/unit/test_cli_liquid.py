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

from app.cli.main import app as srg_app
from app.core.errors import InvalidInput
from app.core.liquid.defaults import DEFAULT_FLUID
from app.liquid import adapter as liquid
from app.liquid.devices import LiquidDevices
from app.services.dynamics import (
    DYNAMICS_NAMES,
    LIQUID_FLUIDS,
    LIQUID_PRESETS,
    UnknownFluid,
    UnknownPreset,
    check_fluid,
    make_dynamics,
)


@pytest.fixture(scope="module")
def cli() -> typer.Typer:
    """The whole ``srg`` app, run without the console script's error mapping."""
    return srg_app


DEVICES = LiquidDevices()
UNKNOWN = "unknown preset 'huge' (known: tiny, small, paper)"
UNKNOWN_FLUID = "unknown fluid 'bogus' (known: low, high)"
#: the parser's refusals (tests/cli/test_cli_choices.py has one for every option)
PARSER_PRESET = "Invalid value for '--preset': 'huge' is not one of 'tiny', 'small', 'paper'."
PARSER_FLUID = "Invalid value for '--fluid': 'bogus' is not one of 'low', 'high'."


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["calibrate", "--preset", "tiny", "--figures", "out"],
            "--figures and --records go with --only threshold",
        ),
        (["bench", "rank", "--edges", "10"], "--edges must be at least 30"),
    ],
)
def test_bad_input_raises_a_one_line_invalid_input_before_any_work(
    cli: typer.Typer, args: list[str], message: str
) -> None:
    result = CliRunner().invoke(cli, args)
    assert result.exit_code != 0
    assert isinstance(result.exception, InvalidInput)
    assert str(result.exception) == message
    assert result.output == ""  # nothing started


def test_main_prints_srg_error_and_exits_2(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import app.cli.main

    monkeypatch.setattr(sys, "argv", ["srg", "bench", "sph", "--preset", "huge"])
    with pytest.raises(SystemExit) as exit_info:
        app.cli.main.main()
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err == f"srg: error: {PARSER_PRESET} (see srg bench sph --help)\n"


@pytest.mark.parametrize(
    "args",
    [
        ["calibrate", "--preset", "tiny", "--fluid", "bogus"],
        ["init", "--dynamics", "liquid", "--preset", "tiny", "--fluid", "bogus", "g"],
    ],
)
def test_an_unknown_fluid_is_one_line_and_exit_2(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], args: list[str]
) -> None:
    """The whole ``srg`` app: refused before any simulation or database work."""
    import app.cli.main

    monkeypatch.setattr(sys, "argv", ["srg", *args])
    with pytest.raises(SystemExit) as exit_info:
        app.cli.main.main()
    assert exit_info.value.code == 2
    help_page = " ".join(args[:1])
    assert capsys.readouterr().err == f"srg: error: {PARSER_FLUID} (see srg {help_page} --help)\n"


def test_make_dynamics_knows_the_liquid_and_names_its_errors(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert DYNAMICS_NAMES == ("toy", "liquid")
    assert LIQUID_PRESETS == ("tiny", "small", "paper")
    assert make_dynamics("liquid", "tiny", devices=DEVICES).preset == "tiny"  # type: ignore[attr-defined]
    assert make_dynamics("liquid", devices=DEVICES).preset == "small"  # type: ignore[attr-defined]
    with pytest.raises(UnknownPreset, match="unknown preset 'huge'"):
        make_dynamics("liquid", "huge", devices=DEVICES)

    def missing(preset: str, fluid: str = "low") -> liquid.LiquidCalibration:
        raise liquid.MissingCalibration(f"no calibration for preset {preset!r}; run this")

    monkeypatch.setattr(liquid, "load_calibration", missing)
    with pytest.raises(LookupError, match=r"^liquid, low viscosity: no .* 'tiny'; run this$"):
        make_dynamics("liquid", "tiny", devices=DEVICES)
    with pytest.raises(LookupError, match=r"^liquid, high viscosity: no .* 'tiny'; run this$"):
        make_dynamics("liquid", "tiny", "high", devices=DEVICES)


def test_make_dynamics_takes_a_fluid_for_the_liquid_only() -> None:
    assert LIQUID_FLUIDS == ("low", "high") and DEFAULT_FLUID == "low"
    assert check_fluid("high") == "high"
    high = make_dynamics("liquid", "tiny", "high", devices=DEVICES)
    assert high.fluid == "high"  # type: ignore[attr-defined]
    assert high.scene.name == "tilt-tank/tiny-high"  # type: ignore[attr-defined]
    assert make_dynamics("liquid", "tiny", devices=DEVICES).fluid == "low"  # type: ignore[attr-defined]
    with pytest.raises(UnknownFluid, match=r"^unknown fluid 'bogus' \(known: low, high\)$"):
        make_dynamics("liquid", "tiny", "bogus", devices=DEVICES)
    with pytest.raises(ValueError, match=r"^the toy has no fluid \(got 'high'\)"):
        make_dynamics("toy", fluid="high", devices=DEVICES)
    assert make_dynamics("toy", devices=DEVICES).name == "toy"


def test_each_fluid_reads_its_own_calibration_file(tmp_path: Path) -> None:
    assert liquid.calibration_path("tiny", "low").name == "tiny.json"
    assert liquid.calibration_path("tiny", "high").name == "tiny-high.json"
    assert liquid.load_calibration("tiny", "high") != liquid.load_calibration("tiny")
    with pytest.raises(liquid.MissingCalibration, match="--preset tiny --fluid high"):
        liquid.load_calibration("tiny", "high", tmp_path)


def _fake_report(passed: bool) -> dict[str, Any]:
    checks = {"twins": {"passed": True}, "hydrostatic": {"passed": passed}}
    return {"preset": "tiny", "checks": checks, "passed": passed}


def _fake_validate(passed: bool) -> Any:
    return lambda preset, fluid, device: _fake_report(passed)


@pytest.mark.parametrize("passed", [True, False])
def test_validate_prints_the_report_and_exits_1_when_a_check_fails(
    cli: typer.Typer, monkeypatch: pytest.MonkeyPatch, passed: bool
) -> None:
    from app.liquid import validation as sph_validation

    monkeypatch.setattr(sph_validation, "validate", _fake_validate(passed))
    result = CliRunner().invoke(cli, ["validate", "--preset", "tiny", "--json"])
    assert result.exit_code == (0 if passed else 1)
    printed = json.loads(result.stdout)
    assert printed.pop("provenance")["command"] and printed == _fake_report(passed)


def test_validate_result_file_gets_the_report_and_stdout_a_line_per_check(
    cli: typer.Typer, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from app.liquid import validation as sph_validation

    monkeypatch.setattr(sph_validation, "validate", _fake_validate(False))
    target = tmp_path / "out" / "validate.json"
    result = CliRunner().invoke(cli, ["validate", "--preset", "tiny", "--result", str(target)])
    assert result.exit_code == 1
    written = json.loads(target.read_text())
    assert written.pop("provenance")["srg_version"] and written == _fake_report(False)
    assert result.stdout.splitlines()[:2] == ["twins: passed", "hydrostatic: FAILED"]


def test_validate_reports_a_check_that_does_not_apply_as_skipped(
    cli: typer.Typer, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from app.liquid import validation as sph_validation

    seen = []

    def fake(preset: str, fluid: str, device: str) -> dict[str, Any]:
        seen.append((preset, fluid))
        checks = {"twins": {"passed": True}, "dam_break": {"skipped": "water only"}}
        passed = all(sph_validation.check_passed(c) is not False for c in checks.values())
        return {"preset": preset, "fluid": fluid, "checks": checks, "passed": passed}

    monkeypatch.setattr(sph_validation, "validate", fake)
    args = ["validate", "--preset", "tiny", "--fluid", "high", "--result", str(tmp_path / "v.json")]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0 and seen == [("tiny", "high")]
    lines = result.stdout.splitlines()
    assert lines[:2] == ["twins: passed", "dam_break: skipped (water only)"]


def test_importing_the_dynamics_registry_does_not_load_opencl_or_mitsuba() -> None:
    imports = "app.services.dynamics, app.cli.liquid"
    assert loaded_modules(imports, ("pyopencl", "mitsuba")) == []


def bench_report(cli: typer.Typer, args: list[str]) -> dict[str, Any]:
    """The JSON a ``srg bench`` command printed, after it exited 0."""
    result = CliRunner().invoke(cli, ["bench", *args])
    assert result.exit_code == 0, result.output
    report: dict[str, Any] = json.loads(result.output)
    return report


def loaded_modules(imports: str, names: tuple[str, ...]) -> list[str]:
    """Which of ``names`` a fresh interpreter has loaded after ``import imports``."""
    loaded = f"sorted(m for m in {names!r} if m in sys.modules)"
    code = f"import json, sys, {imports}; print(json.dumps({loaded}))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return list(json.loads(out.stdout))


def test_bench_sph_tiny_reports_positive_throughput(cli: typer.Typer) -> None:
    report = bench_report(cli, ["sph", "--preset", "tiny", "--steps", "5", "--no-splishsplash"])
    assert report["preset"] == "tiny" and report["particles"] == 1920
    assert "splishsplash_pcisph" not in report
    for key in ("converged", "fixed_3_iterations"):
        assert report[key]["particle_steps_per_s"] > 0
        assert report[key]["substeps"] > 0


def test_bench_sph_profile_accounts_for_every_kernel_of_a_substep(cli: typer.Typer) -> None:
    report = bench_report(cli, ["sph", "--preset", "tiny", "--steps", "24", "--profile"])
    assert report["substeps"] == 24 and report["particles"] == 1920
    kernels = report["kernels"]
    # the once-a-substep stages run once, the pressure loop once per iteration at least
    for name in ("count_cells", "scan_cells", "find_neighbours", "nonpressure_accel"):
        assert kernels[name]["launches_per_substep"] == 1.0
    assert kernels["density_pressure"]["launches_per_substep"] >= report["mean_iterations"]
    assert sum(k["share"] for k in kernels.values()) == pytest.approx(1.0)
    assert 0 < report["device_ms_per_substep"] <= report["span_ms_per_substep"]
    assert 0.0 <= report["gap_share"] < 1.0


def test_bench_sph_batch_reports_each_size_and_identity(cli: typer.Typer) -> None:
    report = bench_report(cli, ["sph", "--preset", "tiny", "--batch", "1,2,4"])
    rows = report["batches"]
    assert [row["batch"] for row in rows] == [1, 2, 4]
    # a batch of one times every clip of the largest batch, alone
    assert [row["clips_timed"] for row in rows] == [4, 2, 4]
    assert all(row["identical"] for row in rows) and report["identical"] is True
    assert rows[0]["speedup"] == 1.0
    for row in rows:
        assert row["clip_frames_per_s"] == pytest.approx(
            row["clips_timed"] * report["frames_per_clip"] / row["wall_s"]
        )


def test_bench_gpu_runs_on_any_device_and_judges_its_bars(cli: typer.Typer) -> None:
    args = ["gpu", "--frame-preset", "tiny", "--batch-preset", "tiny", "--batch", "1,2"]
    report = bench_report(cli, args)
    frame = report["frame"]
    assert frame["preset"] == "tiny" and frame["fluid"] == "high"
    assert frame["seconds_per_frame"] > 0 and frame["queued_equals_careful"] is True
    assert frame["queued_seconds_per_frame"] > 0  # the option it is the default over
    assert [row["batch"] for row in report["batches"]["batches"]] == [1, 2]
    assert report["profile"]["substeps"] == frame["substeps_per_frame"]
    bars = report["bars"]
    assert bars["identical"] is True
    assert bars["tiny high seconds a frame <= 0.05"] == (frame["seconds_per_frame"] <= 0.05)


def test_the_gpu_check_needs_only_numpy_scipy_and_pyopencl() -> None:
    """infra/gpu-bench.sh runs it where the project's environment is not installed."""
    frameworks = ("pydantic", "sqlalchemy", "typer", "celery", "mitsuba")
    assert loaded_modules("app.bench.gpu", frameworks) == []
    assert loaded_modules("app.bench.gpu", ("pyopencl",)) == ["pyopencl"]


def test_the_prepared_gpu_script_runs_on_any_device_where_asked() -> None:
    """`SRG_OPENCL_DEVICE=` (empty) means any device, not NVIDIA's; a machine without
    NVIDIA's library still runs; each part is logged before the report."""
    root = Path(__file__).resolve().parents[2]
    done = subprocess.run(
        ["bash", str(root / "infra/gpu-bench.sh"), "tiny", "tiny"],
        env={"PATH": "/usr/bin:/bin", "PYTHON": sys.executable, "SRG_OPENCL_DEVICE": ""},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert report["bars"]["identical"] is True
    assert report["frame"]["preset"] == "tiny"
    for part in ("frame", "batches", "profile"):
        assert f"gpu-bench: {part} done: " in done.stderr


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--batch", "0,3"], "--batch takes comma-separated positive integers, got '0,3'"),
        (["--batch", "3,x"], "--batch takes comma-separated positive integers, got '3,x'"),
        (["--batch", "3", "--profile"], "--batch and --profile are two benchmarks: give one"),
    ],
)
def test_bench_sph_batch_bad_values_are_one_line(
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    message: str,
) -> None:
    import app.cli.main

    monkeypatch.setattr(sys, "argv", ["srg", "bench", "sph", "--preset", "tiny", *extra])
    with pytest.raises(SystemExit) as exit_info:
        app.cli.main.main()
    assert exit_info.value.code == 2
    captured = capsys.readouterr()
    assert captured.err == f"srg: error: {message}\n" and captured.out == ""


def test_bench_clip_tiny_reports_the_rendered_clips_dark_pixels(cli: typer.Typer) -> None:
    report = bench_report(cli, ["clip", "--preset", "tiny", "--settle", "0.2", "--frames", "3"])
    dark = report["dark_fraction"]
    assert set(dark) == {"median", "p90", "p99", "max"}
    assert 0.0 <= dark["median"] <= dark["p90"] <= dark["p99"] <= dark["max"] <= 0.003
    assert report["dark_pixels_inside_water"] >= 0
    assert report["image"] == [480, 360] and report["render_seconds_per_frame"] > 0
    # the CPU seconds of each stage, and what a simulated clip costs growth in them
    assert set(report["cpu_seconds"]) == set(report["seconds"])
    cost = report["per_expansion"]
    stages = report["cpu_seconds"]
    twice = stages["render"] + stages["encode"]
    assert cost["cpu_seconds_per_clip"] == pytest.approx(sum(stages.values()) + twice)
    assert cost["frames_per_cpu_hour"] == pytest.approx(
        report["frames_per_clip"] * 3600 / cost["cpu_seconds_per_clip"]
    )
