"""Cross-compile the firmware library for Cortex-M7 (cached by hash, verified before use).

One build lives in
``<build>/firmware/<controller>_<estimator>[_<guidance>[_l<latency>]]_<precision>-<hash>/``
(``guidance``: the period with the guided mission's path-following block, ``mpc``;
``latency``: its sample split off into a background task, applied that many periods later):

* ``include/``: ``ballbot_fw.h`` (the stable API), ``ballbot_fw_config.h`` and the generated
  ``ballbot_fw_cg.h``; ``src/``: every C file;
* ``libballbot_fw.a``: the library (``arm-none-eabi-gcc``, :data:`FW_CFLAGS` and the
  precision's :data:`~ballbot_casadi.firmware.toolchain.ARM_CPU_FLAGS`), with the
  ``-fstack-usage`` reports of its objects in ``stack_usage.txt``;
* ``replay.elf``: the QEMU replay program (newlib + rdimon semihosting, own start-up and
  linker script for ``mps2-an500``); ``example.elf``: the 200 Hz timer-interrupt example
  linked for the same board (never run); ``replay_host``: the same replay program built
  for this PC with ``gcc`` (the host reference of :mod:`~ballbot_casadi.firmware.replay`).

``<hash>`` covers the generated and hand-written sources, the flags and the compilers'
versions; ``MANIFEST.json`` (written last) records every file, a damaged build is rebuilt.
"""

from __future__ import annotations

import hashlib
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from ballbot_casadi.core.files import check_manifest, write_manifest
from ballbot_casadi.core.toolchain import build_lock, build_root, compiler_command, run_tool
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.firmware.sources import (
    CG_NAME,
    FirmwareValues,
    csrc_path,
    default_guidance_path,
    firmware_function,
    firmware_guidance,
    generate_sources,
    guidance_every,
    scenario_values,
)
from ballbot_casadi.firmware.toolchain import ARM_CPU_FLAGS, PRECISIONS, require, tool_version
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["FW_CFLAGS", "SINGLE_CFLAGS", "FirmwareBuild", "build_firmware", "default_scenario"]

#: Strict C99 flags of every firmware object (plus -fstack-usage for the library).
FW_CFLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror",
             "-ffunction-sections", "-fdata-sections")
#: Extra flags of the single-precision build: float constants, no silent double arithmetic.
SINGLE_CFLAGS = ("-fsingle-precision-constant", "-Wdouble-promotion")
_LIB_SOURCES = (f"{CG_NAME}.c", "ballbot_fw.c", "ballbot_fw_defaults.c")
_HEADERS = ("ballbot_fw.h", "ballbot_fw_config.h", f"{CG_NAME}.h")
_TARGET_FILES = ("startup.c", "cortex_m7.ld", "replay_main.c", "example_main.c")
_PRODUCTS = ("libballbot_fw.a", "replay.elf", "example.elf", "replay_host", "stack_usage.txt")


@dataclass(frozen=True)
class FirmwareBuild:
    """Paths of one firmware build (see module docstring); ``status``: cached, built, rebuilt."""

    folder: Path
    controller: str
    estimator: str
    precision: str
    digest: str
    status: str = field(default="cached", compare=False)
    guidance: str | None = None
    latency: int = 0

    @property
    def library(self) -> Path:
        return self.folder / "libballbot_fw.a"

    @property
    def include(self) -> Path:
        return self.folder / "include"

    @property
    def replay_elf(self) -> Path:
        return self.folder / "replay.elf"

    @property
    def example_elf(self) -> Path:
        return self.folder / "example.elf"

    @property
    def host_replay(self) -> Path:
        return self.folder / "replay_host"

    @property
    def stack_usage(self) -> Path:
        return self.folder / "stack_usage.txt"


def default_scenario(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR) -> Scenario:
    """The scenario of the library's default parameters: upright at rest, velocity cascade
    on, the package's default gains and the thesis's filter tuning (the controller FMU's)."""
    return Scenario(name="firmware_default", controller=controller, estimator=estimator,
                    cascade=True, duration=0.005)


def _cflags(precision: str, cpu: Sequence[str]) -> list[str]:
    return [*cpu, *FW_CFLAGS, *(SINGLE_CFLAGS if precision == "single" else ())]


def build_firmware(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR,
                   precision: str = "double",
                   values: FirmwareValues | None = None, root: Path | None = None,
                   lib_cpu_flags: Sequence[str] | None = None,
                   guidance: str | None = None, latency: int = 0) -> FirmwareBuild:
    """Generate and cross-compile the firmware of ``controller`` with ``estimator``.

    Parameters
    ----------
    values
        Default parameters and power-on state compiled into the library (default: those
        of :func:`default_scenario`; with guidance on
        :func:`~ballbot_casadi.firmware.sources.default_guidance_path`, which is also the
        library's default guidance data).
    guidance
        ``None`` (the embedded period alone) or a guidance law of the guided mission
        (``mpc``, ``pursuit``) in the period's guidance slot
        (:func:`~ballbot_casadi.firmware.sources.firmware_guidance`).
    latency
        ``0``: the guidance sample runs inside the period; ``L >= 1`` (the MPC): the split
        build, the sample in a background task (``ballbot_fw_guidance_background``), its
        result applied ``L`` periods after its snapshot (the guided mission with latency
        ``L``).
    lib_cpu_flags
        Replace the library's CPU/ABI flags (the programs keep the precision's): a test
        hook to build a deliberately mismatched library.

    Raises
    ------
    ScenarioError
        Unknown controller, estimator, precision or guidance.
    ToolchainMissing
        ``arm-none-eabi-gcc`` is not installed (the message says how to install it).
    BuildError
        A compile or link step failed.
    """
    if precision not in PRECISIONS:
        raise ScenarioError(f"unknown precision {precision!r}; allowed: {', '.join(PRECISIONS)}")
    if latency and guidance is None:
        raise ScenarioError(f"a guidance latency ({latency!r}) needs a guidance block "
                            "(guidance 'mpc')")
    law = firmware_guidance(guidance, controller, latency)  # refused before the toolchain
    require(qemu=False)
    f = firmware_function(controller, estimator, guidance, latency)
    if values is None:
        values = scenario_values(f, default_scenario(controller, estimator), law,
                                 None if law is None else default_guidance_path())
    files = generate_sources(f, precision, values, 0 if law is None else guidance_every(law),
                             law, estimator)
    files.update({n: csrc_path(n).read_text() for n in _TARGET_FILES})
    cpu = tuple(ARM_CPU_FLAGS[precision])
    lib_cpu = cpu if lib_cpu_flags is None else tuple(lib_cpu_flags)
    host_cc = compiler_command()
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(name.encode() + b"\0" + files[name].encode() + b"\0")
    h.update("\0".join([*cpu, *lib_cpu, *FW_CFLAGS, *SINGLE_CFLAGS, *host_cc,
                        tool_version("arm-none-eabi-gcc"), tool_version(host_cc[0])]).encode())
    digest = h.hexdigest()[:16]
    out = (build_root() if root is None else Path(root)) / "firmware"
    guided = "" if guidance is None else f"_{guidance}{f'_l{latency}' if latency else ''}"
    tag = f"{controller}_{estimator}{guided}_{precision}"
    fw = FirmwareBuild(out / f"{tag}-{digest}", controller, estimator, precision, digest,
                       guidance=guidance, latency=latency)
    if check_manifest(fw.folder, _PRODUCTS) is None:
        return fw
    with build_lock(out / f".{fw.folder.name}.lock"):
        problem = check_manifest(fw.folder, _PRODUCTS)
        if problem is None:
            return fw
        first = not fw.folder.exists()
        tmp = Path(tempfile.mkdtemp(prefix=f".{fw.folder.name}-", dir=out))
        try:
            _compile(tmp, files, precision, cpu, lib_cpu, host_cc)
            shutil.rmtree(fw.folder, ignore_errors=True)
            tmp.rename(fw.folder)
            write_manifest(fw.folder, _PRODUCTS)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return FirmwareBuild(fw.folder, controller, estimator, precision, digest,
                         "built" if first else f"rebuilt: {problem}", guidance, latency)


def _compile(tmp: Path, files: dict[str, str], precision: str, cpu: tuple[str, ...],
             lib_cpu: tuple[str, ...], host_cc: list[str]) -> None:
    """Write the sources and build every product into ``tmp``."""
    src, inc = tmp / "src", tmp / "include"
    src.mkdir()
    inc.mkdir()
    for name, text in files.items():
        (inc if name in _HEADERS else src).joinpath(name).write_text(text)
    cc = "arm-none-eabi-gcc"
    objs = []
    for name in _LIB_SOURCES:
        obj = tmp / name.replace(".c", ".o")
        run_tool([cc, *_cflags(precision, lib_cpu), "-fstack-usage", "-I", str(inc), "-c",
                  "-o", str(obj), str(src / name)], f"cross-compiling {name}")
        objs.append(obj)
    run_tool(["arm-none-eabi-ar", "rcs", str(tmp / "libballbot_fw.a"), *map(str, objs)],
             "archiving libballbot_fw.a")
    (tmp / "stack_usage.txt").write_text("".join(o.with_suffix(".su").read_text() for o in objs))
    link = [*_cflags(precision, cpu), "-I", str(inc), "-nostartfiles", "-T",
            str(src / "cortex_m7.ld"), "-Wl,--gc-sections"]
    run_tool([cc, *link, "-DBALLBOT_FW_TARGET", "-DBALLBOT_FW_SEMIHOSTING", "--specs=rdimon.specs",
              "-o", str(tmp / "replay.elf"), str(src / "replay_main.c"), str(src / "startup.c"),
              str(tmp / "libballbot_fw.a"), "-lm"], "linking the QEMU replay program")
    run_tool([cc, *link, "--specs=nosys.specs", "-o", str(tmp / "example.elf"),
              str(src / "example_main.c"), str(src / "startup.c"), str(tmp / "libballbot_fw.a"),
              "-lm"], "linking the 200 Hz example")
    host = [*host_cc, *FW_CFLAGS, *(SINGLE_CFLAGS if precision == "single" else ()), "-I", str(inc)]
    run_tool([*host, "-o", str(tmp / "replay_host"), str(src / "replay_main.c"),
              *(str(src / n) for n in _LIB_SOURCES), "-lm"], "compiling the host replay program")
    for o in objs:
        o.unlink()
        o.with_suffix(".su").unlink()
