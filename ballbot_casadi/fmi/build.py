"""Build the native FMI 2.0 plant FMU ``BallbotPlant.fmu`` (Model Exchange + Co-Simulation).

The plant is one :class:`~ballbot_casadi.fmi.spec.FmuSpec`
(:func:`~ballbot_casadi.fmi.plant.plant.plant_spec`) built by the generic
:func:`~ballbot_casadi.fmi.package.build_fmu_from_spec`; this module is the plant's
entry point (``ballbot fmu build``, the co-simulation master, the benchmarks).

Where things are:

* :mod:`ballbot_casadi.fmi.spec` - variable table (:class:`FmuVar`, :class:`VarTable`)
  and :class:`FmuSpec`;
* :mod:`ballbot_casadi.fmi.model_description` - ``modelDescription.xml``;
* :mod:`ballbot_casadi.fmi.cheaders` - the generated C headers;
* :mod:`ballbot_casadi.fmi.package` - CasADi codegen, compile, cache with manifest, zip;
* :mod:`ballbot_casadi.fmi.plant.plant` - the plant's table, Functions and spec
  (per-model C: ``fmu/plant/plant_model.c``);
* :mod:`ballbot_casadi.fmi.plant.oracle` - the plant's sensor readings in Python.

A second FMU supplies its own table, Functions and per-model C file in an
:class:`FmuSpec` and calls :func:`build_fmu_from_spec`.
"""

from __future__ import annotations

from pathlib import Path

from ballbot_casadi.fmi import package
from ballbot_casadi.fmi.package import (
    FmuBuild,
    build_fmu_from_spec,
    build_tool,
    fmi_headers_dir,
    fmu_source_dir,
    validate_fmu_archive,
)
from ballbot_casadi.fmi.plant.plant import (
    H_INTERNAL_DEFAULT,
    MODEL_IDENTIFIER,
    plant_functions,
    plant_spec,
    plant_variables,
)
from ballbot_casadi.fmi.spec import FmuVar

__all__ = [
    "MODEL_IDENTIFIER",
    "FmuVar",
    "FmuBuild",
    "plant_variables",
    "plant_functions",
    "plant_spec",
    "fmi_headers_dir",
    "fmu_source_dir",
    "build_fmu",
    "build_tool",
    "binary_member",
    "validate_fmu_archive",
    "verify_cache",
    "H_INTERNAL_DEFAULT",
]


def binary_member() -> str:
    """Archive path of the plant binary, ``binaries/<platform>/BallbotPlant.so``."""
    return package.binary_member(MODEL_IDENTIFIER)


def verify_cache(cache: Path) -> str | None:
    """``None`` if the cached plant build in ``cache`` is intact, else the reason."""
    return package.verify_cache(Path(cache), MODEL_IDENTIFIER)


def build_fmu(out: str | Path | None = None, cc: str | None = None,
              fmi_version: int = 2) -> FmuBuild:
    """Generate, compile and zip ``BallbotPlant.fmu`` (cached by content hash, verified).

    See :func:`~ballbot_casadi.fmi.package.build_fmu_from_spec`; ``out`` defaults to
    ``<build>/fmu`` (FMI 3.0: ``<build>/fmu3``) and ``cc`` to ``$CC`` or ``gcc``.

    Raises
    ------
    BuildError
        Missing compiler, headers or sources, or a compile error.
    """
    return build_fmu_from_spec(plant_spec(), out, cc, fmi_version)
