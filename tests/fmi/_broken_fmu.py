"""An FMU binary that breaks one FMI rule on request, for the tests of the C tools (the
fuzzer, the plain-C hosts) that must fail such an FMU.

A thin shared library stands in front of an FMU's binary (the plant's by default; it is
linked against it, so every function it does not define is the FMU's own) and breaks the
rule named by the environment variable ``BROKEN_RULE``:

- ``guid``: instantiates with the GUID in ``PLANT_GUID`` whatever GUID it is given;
- ``state``: reports a serialised state of ``STATE_SIZE`` bytes;
- ``null``: ``fmi2GetDerivatives`` on a NULL instance returns fmi2OK;
- ``getreal``: ``fmi2GetReal`` refuses (fmi2Error, no log message) on every instance;
- ``nanreal``: ``fmi2GetReal`` answers, with NaN as its first value;
- ``setreal``: ``fmi2SetReal`` refuses every call after the first ``SETREAL_OK`` (in this
  process);
- ``init``: ``fmi2ExitInitializationMode`` refuses;
- ``silent``: ``fmi2Terminate`` refuses without a log message.

Any other value (e.g. ``none``) keeps every rule."""

from __future__ import annotations

import subprocess
from pathlib import Path

from _fmu_support import plant_build

from ballbot_casadi.core.toolchain import compiler_command
from ballbot_casadi.fmi.build import FmuBuild
from ballbot_casadi.fmi.package import fmi_headers_dir

WRAPPER = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2FunctionTypes.h"

static int rule(const char *name) {
    const char *r = getenv("BROKEN_RULE");
    return r != NULL && strcmp(r, name) == 0;
}
/* the FMU's own function of that name */
static void *own(const char *name) { return dlsym(RTLD_NEXT, name); }

fmi2Component fmi2Instantiate(fmi2String n, fmi2Type t, fmi2String guid, fmi2String res,
                              const fmi2CallbackFunctions *cb, fmi2Boolean vis, fmi2Boolean log) {
    fmi2InstantiateTYPE *f = (fmi2InstantiateTYPE *)own("fmi2Instantiate");
    if (rule("guid")) guid = getenv("PLANT_GUID");
    return f(n, t, guid, res, cb, vis, log);
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    fmi2SerializedFMUstateSizeTYPE *f =
        (fmi2SerializedFMUstateSizeTYPE *)own("fmi2SerializedFMUstateSize");
    fmi2Status st = f(c, s, size);
    if (rule("state") && st == fmi2OK) *size = (size_t)atol(getenv("STATE_SIZE"));
    return st;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t nx) {
    fmi2GetDerivativesTYPE *f = (fmi2GetDerivativesTYPE *)own("fmi2GetDerivatives");
    if (rule("null") && c == NULL) return fmi2OK;
    return f(c, dx, nx);
}
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    fmi2GetRealTYPE *f = (fmi2GetRealTYPE *)own("fmi2GetReal");
    fmi2Status st;
    if (rule("getreal") && c != NULL) return fmi2Error;
    st = f(c, vr, nvr, value);
    if (rule("nanreal") && st == fmi2OK && nvr > 0) value[0] = NAN;
    return st;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    static long calls = 0;
    fmi2SetRealTYPE *f = (fmi2SetRealTYPE *)own("fmi2SetReal");
    if (rule("setreal") && c != NULL && calls++ >= atol(getenv("SETREAL_OK"))) return fmi2Error;
    return f(c, vr, nvr, value);
}
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    fmi2ExitInitializationModeTYPE *f =
        (fmi2ExitInitializationModeTYPE *)own("fmi2ExitInitializationMode");
    if (rule("init") && c != NULL) return fmi2Error;
    return f(c);
}
fmi2Status fmi2Terminate(fmi2Component c) {
    fmi2TerminateTYPE *f = (fmi2TerminateTYPE *)own("fmi2Terminate");
    if (rule("silent") && c != NULL) return fmi2Error;
    return f(c);
}
"""


def _shared_library(directory: Path, stem: str, source: str, *flags: str) -> Path:
    """Compile ``source`` (C text, written to ``directory/stem.c``) into ``directory/stem.so``
    with the compiler's extra ``flags`` (include paths, what to link)."""
    (directory / f"{stem}.c").write_text(source)
    lib = directory / f"{stem}.so"
    subprocess.run([*compiler_command(), "-shared", "-fPIC", "-o", str(lib), str(directory / f"{stem}.c"),
                    *flags], check=True, capture_output=True)
    return lib


def build_broken(directory: Path, build: FmuBuild | None = None) -> Path:
    """Compile the rule-breaking library in front of ``build``'s binary (default: the plant
    FMU's) into ``directory``."""
    build = build or plant_build()
    return _shared_library(directory, "broken", WRAPPER, "-I", str(fmi_headers_dir()), "-Wl,--no-as-needed",
                           str(build.binary), f"-Wl,-rpath,{build.binary.parent}", "-ldl")


def build_not_an_fmu(directory: Path) -> Path:
    """A shared library that loads but defines no FMI function (the tools must exit 3
    naming the first symbol they miss)."""
    return _shared_library(directory, "not_fmu", "int not_an_fmu(void) { return 0; }\n")
