"""The Python side of the package's FMUs, one folder per FMU and one for systems and masters.

* ``plant/``, ``controller/``, ``reference_player/`` - each FMU's variable table,
  Functions and :class:`~ballbot_casadi.fmi.spec.FmuSpec` (its C lives in the matching
  folder of ``fmu/``);
* ``system/`` - systems of FMUs: SSP archives, the SIL composition and its log, the
  container FMU;
* ``masters/`` - co-simulation masters on one fmpy adapter, and libcosim;
* at this level, what every FMU shares: the variable table and spec (``spec``),
  ``modelDescription.xml`` (``model_description``), the C headers (``cheaders``),
  CasADi codegen, compile, cache and zip (``package``), and the plant's entry point
  (``build``).  They stay here rather than in a ``common/`` folder: every FMU folder
  imports them, a second FMI version's writer sits beside them, and the short paths keep
  the other branches' edits to them mechanical to merge.
"""
