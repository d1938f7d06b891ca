"""The embedded software as a Cortex-M7 firmware library, verified in QEMU (issue 21).

:mod:`~ballbot_casadi.firmware.toolchain` finds ``arm-none-eabi-gcc`` and
``qemu-system-arm``; :mod:`~ballbot_casadi.firmware.sources` generates the C of the
embedded period (``casadi_real`` double or float) with the configuration header of the
stable C API (``csrc/ballbot_fw.h``); :mod:`~ballbot_casadi.firmware.build` cross-compiles
the static library, the QEMU replay program and the 200 Hz example (cached by hash);
:mod:`~ballbot_casadi.firmware.replay` replays a recorded sensor log in QEMU and on the
host; :mod:`~ballbot_casadi.firmware.cost` measures flash, RAM and instructions per step;
:mod:`~ballbot_casadi.firmware.single` runs the float build in the closed loop.
With ``guidance="mpc"`` the period carries the guided mission's path-following MPC (issue 18;
its path table and obstacles given at init by pointer), replayed from a guided mission;
with ``latency=L`` as well the split build: the 200 Hz step without the MPC, its sample in
a background task, the result applied ``L`` periods after its snapshot (the guided mission
with that latency).
"""
