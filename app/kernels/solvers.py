"""The liquid solvers srg can make clips with, by the name a scene gives (docs/sph.md,
"Solvers"). PCISPH is the one there is; another is one class beside it and one entry here."""

from __future__ import annotations

from collections.abc import Callable

from app.core.errors import InvalidInput
from app.core.liquid.scene import Scene
from app.core.liquid.solver import LiquidSolver
from app.kernels.pcisph import PcisphSolver

#: a scene's ``solver`` to the class that runs it on an OpenCL device
SOLVERS: dict[str, Callable[..., LiquidSolver]] = {PcisphSolver.name: PcisphSolver}


def make_solver(scene: Scene, device: str = "", batch: int = 1) -> LiquidSolver:
    """The solver ``scene`` names, on ``device``, with room for ``batch`` clips at once."""
    if scene.solver not in SOLVERS:
        raise InvalidInput(
            f"scene {scene.name!r} names the liquid solver {scene.solver!r}; srg has "
            f"{', '.join(sorted(SOLVERS))}"
        )
    return SOLVERS[scene.solver](scene, device=device, batch=batch)
