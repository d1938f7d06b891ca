"""Hand-written FMI C sources, one folder per part, installed as package data
(``ballbot_casadi.fmu_src``) so ``ballbot_casadi.fmi.package`` finds them outside a checkout:

* ``layer/`` - the shared FMI 2.0 layer (``fmi2_common.c|h`` and its parts
  ``fmi2_instance.c``, ``fmi2_values.c``, ``fmi2_state.c``, ``fmi2_modes.c``,
  ``fmi2_internal.h``) and the one call of CasADi Functions (``fmu_casadi.c|h``);
* ``plant/``, ``controller/``, ``reference/`` - the per-model part of each FMU;
* ``tools/`` - the C hosts ``host.c``, ``controller_host.c`` (with ``fmi2_host.h``) and
  the API fuzzer ``fuzz.c``."""
