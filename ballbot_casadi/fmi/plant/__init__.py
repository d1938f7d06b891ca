"""The plant FMU ``BallbotPlant.fmu``: its variable table, Functions and spec (``plant``) and
the independent Python oracle of its sensor readings (``oracle``)."""
