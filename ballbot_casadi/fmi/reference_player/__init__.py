"""The reference player FMU ``BallbotReference.fmu``: a scenario's per-period reference
signals and wheel-torque disturbance played back to the SIL system (``player``)."""
