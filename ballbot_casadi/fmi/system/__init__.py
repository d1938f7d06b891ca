"""Systems of FMUs: SSP archives (``ssp``), the SIL composition (``sil``), its log in the
mission's layout (``sil_log``) and the SIL as one container FMU (``container``)."""
