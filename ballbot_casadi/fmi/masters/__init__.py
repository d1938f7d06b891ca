"""Co-simulation masters: one fmpy adapter (``adapter``) under the Python masters (the
plant-FMU loop ``plant_loop``, the Gauss-Seidel SSP master ``gauss_seidel``), libcosim
(``libcosim``) and running an SSP with either (``ssp_run``)."""
