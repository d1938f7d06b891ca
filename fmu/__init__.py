"""Hand-written FMI 2.0 C sources (the shared layer ``fmi2_common.c|h`` and its parts
``fmi2_instance.c``, ``fmi2_values.c``, ``fmi2_state.c``, ``fmi2_modes.c``,
``fmi2_internal.h``; the per-model parts; the C tools ``host.c``, ``controller_host.c``,
``fuzz.c`` and their ``fmi2_host.h``), installed as package data
(``ballbot_casadi.fmu_src``) so ``ballbot_casadi.fmi.package`` finds them outside a checkout."""
