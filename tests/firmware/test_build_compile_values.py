"""The commands build_firmware's compile step runs (the compilers replaced by a recorder):
which sources go into the library, the archive, the two target programs and the host
replay, with which flags; and what is left in the build folder."""

from __future__ import annotations

from pathlib import Path

from ballbot_casadi.firmware import build as B
from ballbot_casadi.firmware.toolchain import ARM_CPU_FLAGS


def test_compile_commands(monkeypatch, tmp_path):
    cmds = []

    def run_tool(cmd, what):
        cmds.append((cmd, what))
        if "-c" in cmd:  # an object and its stack-usage report
            obj = Path(cmd[cmd.index("-o") + 1])
            obj.write_text("o")
            obj.with_suffix(".su").write_text(f"{obj.stem}.c:1:f_{obj.stem}\t{len(cmds)}\tstatic\n")
    monkeypatch.setattr(B, "run_tool", run_tool)
    files = {n: f"/* {n} */" for n in (*B._LIB_SOURCES, *B._HEADERS, *B._TARGET_FILES)}
    cpu, lib_cpu = tuple(ARM_CPU_FLAGS["single"]), ("-mcpu=x",)
    B._compile(tmp_path, files, "single", cpu, lib_cpu, ["hostcc", "-q"])
    src, inc = tmp_path / "src", tmp_path / "include"
    assert sorted(p.name for p in inc.iterdir()) == sorted(B._HEADERS)
    assert sorted(p.name for p in src.iterdir()) == sorted(set(files) - set(B._HEADERS))
    assert (src / "ballbot_fw.c").read_text() == "/* ballbot_fw.c */"
    objs = [str(tmp_path / n.replace(".c", ".o")) for n in B._LIB_SOURCES]
    flags = [*lib_cpu, *B.FW_CFLAGS, *B.SINGLE_CFLAGS]
    for (cmd, what), name, obj in zip(cmds[:3], B._LIB_SOURCES, objs):
        assert cmd == ["arm-none-eabi-gcc", *flags, "-fstack-usage", "-I", str(inc), "-c", "-o", obj,
                       str(src / name)]
        assert what == f"cross-compiling {name}"
    assert cmds[3] == (["arm-none-eabi-ar", "rcs", str(tmp_path / "libballbot_fw.a"), *objs],
                       "archiving libballbot_fw.a")
    link = [*cpu, *B.FW_CFLAGS, *B.SINGLE_CFLAGS, "-I", str(inc), "-nostartfiles", "-T",
            str(src / "cortex_m7.ld"), "-Wl,--gc-sections"]
    lib = str(tmp_path / "libballbot_fw.a")
    assert cmds[4] == (["arm-none-eabi-gcc", *link, "-DBALLBOT_FW_TARGET", "-DBALLBOT_FW_SEMIHOSTING",
                        "--specs=rdimon.specs", "-o", str(tmp_path / "replay.elf"),
                        str(src / "replay_main.c"), str(src / "startup.c"), lib, "-lm"],
                       "linking the QEMU replay program")
    assert cmds[5] == (["arm-none-eabi-gcc", *link, "--specs=nosys.specs", "-o",
                        str(tmp_path / "example.elf"), str(src / "example_main.c"),
                        str(src / "startup.c"), lib, "-lm"], "linking the 200 Hz example")
    assert cmds[6] == (["hostcc", "-q", *B.FW_CFLAGS, *B.SINGLE_CFLAGS, "-I", str(inc), "-o",
                        str(tmp_path / "replay_host"), str(src / "replay_main.c"),
                        *(str(src / n) for n in B._LIB_SOURCES), "-lm"],
                       "compiling the host replay program")
    assert len(cmds) == 7
    # the stack-usage reports gathered in the library's order, the objects removed
    assert (tmp_path / "stack_usage.txt").read_text() == "".join(
        f"{Path(o).stem}.c:1:f_{Path(o).stem}\t{i + 1}\tstatic\n" for i, o in enumerate(objs))
    assert not list(tmp_path.glob("*.o")) and not list(tmp_path.glob("*.su"))


def test_double_builds_have_no_single_flags(monkeypatch, tmp_path):
    cmds = []

    def run_tool(cmd, what):
        cmds.append(cmd)
        if "-c" in cmd:
            obj = Path(cmd[cmd.index("-o") + 1])
            obj.write_text("o")
            obj.with_suffix(".su").write_text("")
    monkeypatch.setattr(B, "run_tool", run_tool)
    files = {n: "" for n in (*B._LIB_SOURCES, *B._HEADERS, *B._TARGET_FILES)}
    B._compile(tmp_path, files, "double", ("-a",), ("-b",), ["cc"])
    assert all("-Wdouble-promotion" not in c for c in cmds)
    assert cmds[0][:2] == ["arm-none-eabi-gcc", "-b"] and cmds[4][:2] == ["arm-none-eabi-gcc", "-a"]
