"""A plant FMU binary that breaks one FMI rule on request, for the tests of the C tools
(the fuzzer, the plain-C host) that must fail such an FMU.

A thin shared library stands in front of the plant's binary (it is linked against it, so
every function it does not define is the plant's own) and breaks the rule named by the
environment variable ``BROKEN_RULE``:

- ``guid``: instantiates with the GUID in ``PLANT_GUID`` whatever GUID it is given;
- ``state``: reports a serialised state of ``STATE_SIZE`` bytes;
- ``null``: ``fmi2GetDerivatives`` on a NULL instance returns fmi2OK;
- ``getreal``: ``fmi2GetReal`` refuses (fmi2Error, no log message) on every instance;
- ``silent``: ``fmi2Terminate`` refuses without a log message.

Any other value (e.g. ``none``) keeps every rule."""

from __future__ import annotations

import subprocess
from pathlib import Path

from _fmu_support import plant_build

from ballbot_casadi.core.toolchain import compiler_command
from ballbot_casadi.fmi.package import fmi_headers_dir

WRAPPER = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2FunctionTypes.h"

static int rule(const char *name) {
    const char *r = getenv("BROKEN_RULE");
    return r != NULL && strcmp(r, name) == 0;
}
static void *plant(const char *name) { return dlsym(RTLD_NEXT, name); }

fmi2Component fmi2Instantiate(fmi2String n, fmi2Type t, fmi2String guid, fmi2String res,
                              const fmi2CallbackFunctions *cb, fmi2Boolean vis, fmi2Boolean log) {
    fmi2InstantiateTYPE *f = (fmi2InstantiateTYPE *)plant("fmi2Instantiate");
    if (rule("guid")) guid = getenv("PLANT_GUID");
    return f(n, t, guid, res, cb, vis, log);
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) {
    fmi2SerializedFMUstateSizeTYPE *f =
        (fmi2SerializedFMUstateSizeTYPE *)plant("fmi2SerializedFMUstateSize");
    fmi2Status st = f(c, s, size);
    if (rule("state") && st == fmi2OK) *size = (size_t)atol(getenv("STATE_SIZE"));
    return st;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t nx) {
    fmi2GetDerivativesTYPE *f = (fmi2GetDerivativesTYPE *)plant("fmi2GetDerivatives");
    if (rule("null") && c == NULL) return fmi2OK;
    return f(c, dx, nx);
}
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    fmi2GetRealTYPE *f = (fmi2GetRealTYPE *)plant("fmi2GetReal");
    if (rule("getreal") && c != NULL) return fmi2Error;
    return f(c, vr, nvr, value);
}
fmi2Status fmi2Terminate(fmi2Component c) {
    fmi2TerminateTYPE *f = (fmi2TerminateTYPE *)plant("fmi2Terminate");
    if (rule("silent") && c != NULL) return fmi2Error;
    return f(c);
}
"""


def build_broken_plant(directory: Path) -> Path:
    """Compile the rule-breaking library in front of the plant FMU's binary into ``directory``."""
    build = plant_build()
    (directory / "broken.c").write_text(WRAPPER)
    lib = directory / "broken.so"
    subprocess.run([*compiler_command(), "-shared", "-fPIC", "-I", str(fmi_headers_dir()),
                    "-o", str(lib), str(directory / "broken.c"), "-Wl,--no-as-needed",
                    str(build.binary), f"-Wl,-rpath,{build.binary.parent}", "-ldl"], check=True,
                   capture_output=True)
    return lib
