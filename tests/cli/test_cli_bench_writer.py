"""`srg bench writer`: the real writer grown with synthetic clips, put on a virtual clock."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
from cli_helpers import SRG, ok, one_line_error, srg
from sqlalchemy import text
from sqlalchemy.engine import make_url

from app.bench.writer import _virtual_clock, bench_writer
from app.config import Settings
from app.db.engines import make_engine


def test_the_virtual_clock_adds_the_clips_rounds_and_the_writer() -> None:
    # 2 expansions x 3 controls = 6 clips on 3 workers: two rounds of 10 s; the writer
    # measured 2 s and the liquid adds 0.5 s to each of the 2 integrations
    clock = _virtual_clock(
        [(100, 2.0)], batch=2, n_controls=3, workers=3, clip_seconds=10.0, liquid_seconds=0.5
    )
    assert clock["writer_share"] == round(3 / 23, 4)
    assert clock["virtual_hours"] == round(23 / 3600, 2)
    assert clock["slices"] == [{"up_to_frames": 100, "writer_share": round(3 / 23, 4)}]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--frames", "0"], "'--frames': Input should be greater than or equal to 1"),
        (["--workers", "10,x"], "--workers takes comma-separated positive integers"),
        (["--clip-seconds", "nan"], "'--clip-seconds': must be a finite number above 0"),
        (["--liquid-seconds", "-1"], "'--liquid-seconds': Input should be greater than or equal"),
    ],
)
def test_bad_options_fail_in_one_line(tmp_path: Path, args: list[str], message: str) -> None:
    done = srg(tmp_path, "bench", "writer", *args)
    one_line_error(done, message)
    assert done.stdout == ""


@pytest.mark.slow
def test_more_workers_leave_the_writer_a_larger_share(tmp_path: Path) -> None:
    out = ok(tmp_path, "bench", "writer", "--frames", "600", "--batch", "4", "--workers", "2,1000")
    result = json.loads(out)
    assert result["frames"] >= 600
    few, many = result["by_workers"]
    assert 0 < few["writer_share"] < many["writer_share"] < 1
    assert many["virtual_hours"] < few["virtual_hours"]
    assert result["integration_median_ms_last_tenth"] > 0


def test_an_interrupted_run_reports_the_epochs_it_grew(tmp_path: Path) -> None:
    """Ctrl-C during a long run (here: raised by the progress callback after the second
    epoch) ends the growth, not the bench: the report covers the epochs measured."""
    epochs_seen = []

    def interrupt_after_two(grown: int) -> None:
        epochs_seen.append(grown)
        if len(epochs_seen) == 2:
            raise KeyboardInterrupt

    result = bench_writer(
        settings=Settings(var_dir=tmp_path),
        frames=100_000,
        batch=2,
        workers=[4],
        clip_seconds=1.0,
        liquid_seconds=0.0,
        progress=interrupt_after_two,
    )
    assert result["interrupted"] is True and result["target_frames"] == 100_000
    assert result["epochs"] == 2
    assert result["by_workers"][0]["slices"][-1]["up_to_frames"] == result["frames"]
    assert result["frames"] > 120  # the toy's tree (120 frames) and two epochs more


def _epochs_planned(database: str) -> int:
    """Growth epochs in the bench's scratch database (0 before its schema exists)."""
    url = make_url(Settings().scratch_postgres_url).set(database=database)
    engine = make_engine(url.render_as_string(False))
    try:
        with engine.connect() as connection:
            exists = connection.scalar(text("SELECT to_regclass('growth_epochs') IS NOT NULL"))
            return (
                int(connection.scalar(text("SELECT count(*) FROM growth_epochs"))) if exists else 0
            )
    finally:
        engine.dispose()


def _scratch_databases() -> set[str]:
    server = make_url(Settings().scratch_postgres_url).set(database="postgres")
    admin = make_engine(server.render_as_string(False), isolation_level="AUTOCOMMIT")
    try:
        with admin.connect() as connection:
            names = connection.execute(
                text("SELECT datname FROM pg_database WHERE datname LIKE 'srg_bench_%'")
            )
            return set(names.scalars())
    finally:
        admin.dispose()


def test_a_killed_run_reports_what_it_grew_and_drops_its_database(tmp_path: Path) -> None:
    """SIGTERM (``kill``) unwinds a bench as Ctrl-C does: the report of the epochs grown,
    and no scratch database left behind on the server."""
    before = _scratch_databases()
    env = {**os.environ, "SRG_VAR_DIR": str(tmp_path)}
    args = [str(SRG), "bench", "writer", "--frames", "100000", "--batch", "2", "--workers", "4"]
    process = subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not (new := _scratch_databases() - before):
        assert process.poll() is None and time.monotonic() < deadline
        time.sleep(0.2)
    # a state, not a clock: the second epoch is planned only once the first is grown
    while _epochs_planned(*new) < 2:
        assert process.poll() is None and time.monotonic() < deadline
        time.sleep(0.2)
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=120)
    assert process.returncode == 0, err.decode()
    report = json.loads(out)
    assert report["interrupted"] is True and report["epochs"] >= 1
    assert not (_scratch_databases() & new)
