"""Provenance: the commit of the checkout srg runs from, and none outside one."""

from __future__ import annotations

import subprocess
from dataclasses import asdict
from pathlib import Path

import pytest

from app.config import Settings
from app.reports import provenance as module
from app.reports.provenance import (
    UNKNOWN,
    Provenance,
    provenance,
    source_commit,
    with_provenance,
)


def test_the_commit_is_this_checkouts_head() -> None:
    head = subprocess.run(
        ["git", "-C", str(module._SOURCE_ROOT), "rev-parse", "HEAD"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    assert source_commit().removesuffix("-dirty") == head


def test_outside_a_checkout_the_commit_is_unknown(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(module, "_SOURCE_ROOT", tmp_path)  # a folder no repository holds
    assert source_commit() == UNKNOWN


def test_a_result_is_led_by_its_provenance_and_keeps_its_figures() -> None:
    stamped = with_provenance({"ratio": 0.5}, Settings())
    assert list(stamped) == ["provenance", "ratio"] and stamped["ratio"] == 0.5
    assert stamped["provenance"]["cpu"] == provenance(Settings()).cpu != ""


def test_an_opencl_device_that_does_not_exist_is_named_as_missing() -> None:
    pytest.importorskip("pyopencl")
    settings = Settings().replace(opencl_device="no-such-device-anywhere")
    assert provenance(settings).opencl_device.startswith("none (")


def test_growth_settings_off_their_defaults_are_written_and_older_results_still_read() -> None:
    changed = provenance(Settings().replace(crowd_eps=0.01, alpha=0.79))
    assert changed.growth == {"SRG_ALPHA": "0.79", "SRG_CROWD_EPS": "0.01"}
    assert "off their defaults: `SRG_ALPHA=0.79`, `SRG_CROWD_EPS=0.01`." in changed.markdown()
    stored = asdict(provenance(Settings()))
    assert stored.pop("growth") == {}
    assert "growth settings" not in Provenance(**stored).markdown()
