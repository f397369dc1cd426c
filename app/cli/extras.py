"""Which extra of the distribution brings a module, and the one line for one not installed.

srg installs as a small core plus extras (pyproject.toml; docs/design.md, "Packaging"),
and the modules of an extra are imported only where a command first needs them. So a
command run without its extra meets a ``ModuleNotFoundError`` naming the module, which
:mod:`app.cli.output` turns into one line naming the extra to install. The table holds
every module ``app`` imports from an extra, each under its first-level name (the one
``ModuleNotFoundError`` names when the whole distribution is absent);
tests/unit/test_extras.py holds it to pyproject.toml.
"""

from __future__ import annotations

#: the extra that brings each module srg imports outside its core dependencies
EXTRA_OF_MODULE = {
    "pyopencl": "sim",
    "skimage": "sim",
    "mitsuba": "sim",
    "drjit": "sim",
    "celery": "cluster",
    "kombu": "cluster",
    "redis": "cluster",
    "flower": "cluster",
    "tornado": "cluster",
    "fastapi": "api",
    "fastapi_offline": "api",
    "starlette": "api",
    "uvicorn": "api",
    "h11": "api",
    "httpx": "api",
    "limits": "api",
    "cachetools": "api",
    "matplotlib": "plots",
    "networkx": "bench",
    "playwright": "bench",
}


def missing_extra_message(exc: BaseException) -> str | None:
    """What to install when ``exc`` says a module of an extra is missing; else ``None``
    (a module of the core missing is a broken install, and keeps its traceback)."""
    if not isinstance(exc, ModuleNotFoundError) or not exc.name:
        return None
    module = exc.name.partition(".")[0]
    extra = EXTRA_OF_MODULE.get(module)
    if extra is None:
        return None
    return (
        f"this command needs the {extra!r} extra ({module} is not installed): "
        f"pip install 'srg[{extra}]'"
    )
