"""The controller FMU ``BallbotController[_<ctrl>_<est>].fmu``: the embedded software's period
as an FMU (``controller``)."""
