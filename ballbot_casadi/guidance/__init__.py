"""Guidance: paths, path-following MPC and a pure-pursuit baseline (above the velocity loop)."""
