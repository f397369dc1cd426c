"""srg installed from its wheel, with no source checkout: the migrations travel inside the
distribution, and ``srg db upgrade`` and the toy demo run from the installed package; in
a checkout, srg and the ``alembic`` command (``alembic.ini``) run the same migrations.

Nothing is downloaded: the wheel is built by this virtual environment's own hatchling (no
build isolation; pip checks it against pyproject's build requirement) from a copy of the
sources, and installed without its dependencies into a fresh virtual environment, which
then sees this one's site-packages through a ``.pth`` line placed after its own. The
commands run in a directory outside the checkout, so the source tree is not importable,
and ``app`` is checked to come from the wheel.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import venv
import zipfile
from pathlib import Path

import pytest
from alembic.config import Config

from app.db.migrations import alembic_config

ROOT = Path(__file__).resolve().parents[2]
#: what the distribution is built from: the package, its migrations, their metadata
SOURCES = ("pyproject.toml", "README.md", "LICENSE", "app", "alembic")
IGNORED = shutil.ignore_patterns("__pycache__", "*.pyc")


@pytest.fixture(scope="module")
def sources(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the sources, so that the build's own files stay out of the checkout."""
    copy = tmp_path_factory.mktemp("sources")
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, copy / name, ignore=IGNORED)
        else:
            shutil.copy2(ROOT / name, copy / name)
    return copy


@pytest.fixture(scope="module")
def wheel(sources: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    pip_wheel = [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-index"]
    build = [*pip_wheel, "--no-build-isolation", "--check-build-dependencies", "-w", str(out)]
    done = subprocess.run([*build, str(sources)], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "Warning" not in done.stdout + done.stderr, done.stdout + done.stderr
    (built,) = out.glob("srg-*.whl")
    return built


@pytest.mark.slow
def test_the_wheel_says_its_licence_and_what_it_is(wheel: Path) -> None:
    with zipfile.ZipFile(wheel) as archive:
        (name,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
        metadata = archive.read(name).decode()
        assert any(n.endswith("licenses/LICENSE") for n in archive.namelist())
    assert "License-Expression: Apache-2.0" in metadata
    assert "Classifier: Programming Language :: Python :: 3.11" in metadata


@pytest.mark.slow
def test_the_wheel_carries_every_file_of_app_and_the_migrations(sources: Path, wheel: Path) -> None:
    def files(top: str) -> set[str]:
        return {p.relative_to(sources / top).as_posix() for p in (sources / top).rglob("*")}

    with zipfile.ZipFile(wheel) as archive:
        carried = set(archive.namelist())
    package = {f"app/{name}" for name in files("app") if not (sources / "app" / name).is_dir()}
    migrations = {
        f"app/migrations/{name}"
        for name in files("alembic")
        if not (sources / "alembic" / name).is_dir()
    }
    assert package and migrations
    assert package - carried == set() and migrations - carried == set()


@pytest.mark.slow
def test_the_installed_wheel_migrates_and_runs_the_toy_demo_outside_the_checkout(
    wheel: Path, tmp_path: Path
) -> None:
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(symlinks=True, with_pip=False).create(env_dir)
    python = env_dir / "bin" / "python"
    install = [sys.executable, "-m", "pip", "--python", str(python), "install", "-q"]
    done = subprocess.run([*install, "--no-deps", "--no-index", str(wheel)], capture_output=True)
    assert done.returncode == 0, done.stderr
    purelib = subprocess.run(
        [python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    # written after the install, so that pip did not see this environment's srg there
    (Path(purelib) / "srg_test_dependencies.pth").write_text(sysconfig.get_path("purelib"))

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("SRG_", "PYTHON"))}
    env.update(
        PATH=f"{env_dir / 'bin'}{os.pathsep}{env['PATH']}",
        SRG_VAR_DIR=str(elsewhere / "var"),
        SRG_DATABASE_URL=f"sqlite:///{elsewhere / 'srg.sqlite3'}",  # configured: not migrated
    )

    def run(*args: str | Path) -> subprocess.CompletedProcess[str]:
        done = subprocess.run(args, cwd=elsewhere, env=env, capture_output=True, text=True)
        assert done.returncode == 0, done.stdout + done.stderr
        return done

    where = (
        "import app, app.db.migrations; "
        "print(app.__file__); print(app.db.migrations.migrations_dir())"
    )
    package, migrations = run(python, "-c", where).stdout.split()
    assert Path(package).is_relative_to(purelib) and Path(migrations).is_relative_to(purelib)

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert run("srg", "--version").stdout == f"srg {project['version']}\n"
    assert "database at head" in run("srg", "db", "upgrade").stderr
    demo = ["demo", "--dynamics", "toy", "--checkpoints", "60,120", "--sessions", "2"]
    assert "report: " in run("srg", *demo).stdout
    assert (elsewhere / "var" / "demo" / "report.md").is_file()


@pytest.mark.slow
def test_the_editable_install_of_the_set_up_is_built_without_a_warning(
    sources: Path, tmp_path: Path
) -> None:
    """infra/venv.sh installs srg editable; its backend, called as pip calls it (PEP 660),
    says nothing, and the editable wheel only points Python at the checkout."""
    backend = tomllib.loads((sources / "pyproject.toml").read_text())["build-system"]
    call = (
        f"import sys, {backend['build-backend']} as backend; "
        "print(backend.build_editable(sys.argv[1]))"
    )
    done = subprocess.run(
        [sys.executable, "-W", "always", "-c", call, str(tmp_path)],
        cwd=sources,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "warning" not in (done.stdout + done.stderr).lower(), done.stdout + done.stderr
    with zipfile.ZipFile(tmp_path / done.stdout.strip()) as archive:
        (pth,) = [n for n in archive.namelist() if n.endswith(".pth")]
        assert archive.read(pth).decode().split() == [str(sources)]


def test_in_a_checkout_srg_and_alembic_ini_name_the_same_migrations() -> None:
    ini = Config(str(ROOT / "alembic.ini"))
    scripts = [
        ini.get_main_option("script_location"),
        alembic_config().get_main_option("script_location"),
    ]
    assert [Path(str(s)).resolve() for s in scripts] == [ROOT / "alembic"] * 2
