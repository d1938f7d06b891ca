"""Hand-written FMI 2.0 C sources of the plant FMU, installed as package data
(``ballbot_casadi.fmu_src``) so ``ballbot_casadi.fmu_build`` finds them outside a checkout."""
