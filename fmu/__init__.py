"""Hand-written FMI 2.0 C sources (the shared layer ``fmi2_common.c|h``, the per-model
parts, the C tools ``host.c`` and ``fuzz.c``), installed as package data
(``ballbot_casadi.fmu_src``) so ``ballbot_casadi.fmi.package`` finds them outside a checkout."""
