"""The cross toolchain of the firmware: ``arm-none-eabi-gcc`` (newlib) and ``qemu-system-arm``.

Both come from the distribution (Debian: ``gcc-arm-none-eabi``, ``libnewlib-arm-none-eabi``,
``qemu-system-arm``).  Missing tools raise :class:`ToolchainMissing` whose message says how
to install them; the command line turns it into exit code 3.
"""

from __future__ import annotations

import shutil
import subprocess
from typing import Mapping

from ballbot_casadi.errors import BuildError

__all__ = [
    "PRECISIONS",
    "ARM_CPU_FLAGS",
    "INSTALL_HINT",
    "ToolchainMissing",
    "missing_tools",
    "require",
    "tool_version",
]

#: Precision name -> C type of ``casadi_real``.
PRECISIONS: Mapping[str, str] = {"double": "double", "single": "float"}
#: Cortex-M7 code generation flags per precision (hard-float ABI; the FPU of each variant).
ARM_CPU_FLAGS: Mapping[str, tuple[str, ...]] = {
    "double": ("-mcpu=cortex-m7", "-mfpu=fpv5-d16", "-mfloat-abi=hard", "-mthumb"),
    "single": ("-mcpu=cortex-m7", "-mfpu=fpv5-sp-d16", "-mfloat-abi=hard", "-mthumb"),
}
#: Programs and the Debian packages that provide them.
_TOOLS = {"arm-none-eabi-gcc": "gcc-arm-none-eabi", "arm-none-eabi-size": "binutils-arm-none-eabi",
          "qemu-system-arm": "qemu-system-arm"}
#: How to install the toolchain (one line).
INSTALL_HINT = ("install the Cortex-M toolchain and emulator: sudo apt-get install -y "
                "gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm")


class ToolchainMissing(BuildError):
    """A program of the cross toolchain is not installed (message: how to install it)."""


def missing_tools(qemu: bool = True) -> list[str]:
    """The toolchain programs not on ``PATH`` (``qemu``: include the emulator)."""
    return [t for t in _TOOLS if (qemu or t != "qemu-system-arm") and shutil.which(t) is None]


def require(qemu: bool = True) -> None:
    """Raise :class:`ToolchainMissing` unless the cross compiler (and ``qemu``) are installed."""
    missing = missing_tools(qemu)
    if missing:
        raise ToolchainMissing(f"{', '.join(missing)} not found; {INSTALL_HINT}")


def tool_version(tool: str) -> str:
    """First line of ``tool --version`` (part of the build hash)."""
    try:
        out = subprocess.run([tool, "--version"], capture_output=True, text=True, check=False)
    except OSError:
        return "missing"
    return (out.stdout.strip().splitlines() or ["unknown"])[0]
