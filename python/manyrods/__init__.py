"""manyrods: many Cosserat rods with Kelvin–Voigt damping, from Python.

    import manyrods
    scene = manyrods.load_scene("tools/scenes/seed_cantilever.toml")
    batch = scene.build_batch()
    x = batch.node_position          # (3, slots) NumPy view of the batch's memory, no copy
    batch.step(batch.dt, count=1000)  # x now holds the new positions
    tip = x[:, batch.node_range(0)][:, -1]

Rods built in code:

    rod = manyrods.Rod.straight([0, 0, 0], [1, 0, 0], length=1.0, elements=32,
                                section=manyrods.Section.circle(0.01),
                                material=manyrods.Material(density=1000, youngs_modulus=1e6, poisson_ratio=0.5),
                                damping=manyrods.Damping.shear_extension(0.01, 0.01))
    batch = manyrods.Batch([rod], precision="double", gravity=[0, 0, -9.81])

Errors: invalid input raises ValueError with the library's message (a scene's
`file:line:column: key:`); a state that stops being finite raises
manyrods.NonFiniteError naming the rod, node or element, step and time; a
static solve without equilibrium raises manyrods.StaticError (a
RuntimeError) naming the rod, node and residual.
docs/python.md has the whole interface.
"""

from ._core import (  # noqa: F401
    Batch,
    CmaEs,
    Damping,
    Material,
    NonFiniteError,
    Rod,
    Scene,
    Section,
    StaticError,
    ValidityError,
    __version__,
    load_scene,
    parse_scene,
    read_output,
)

__all__ = [
    "Batch",
    "Damping",
    "Material",
    "NonFiniteError",
    "Rod",
    "Scene",
    "Section",
    "StaticError",
    "ValidityError",
    "load_scene",
    "parse_scene",
    "read_output",
]
