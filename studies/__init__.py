"""The thesis experiments behind ``ballbot study`` and ``ballbot analyze`` (plots live here only).

Installed as the package ``ballbot_casadi.studies``.
"""
