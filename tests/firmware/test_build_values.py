"""build_firmware's bookkeeping without a compiler: the sources it hashes, the folder it names,
cached / built / rebuilt, the flags each product gets, the refusals; and the toolchain
module's lookups (generation and compilation replaced by fakes that record their input)."""

from __future__ import annotations

import hashlib
from pathlib import Path
from types import SimpleNamespace

import pytest

from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.firmware import build as B
from ballbot_casadi.firmware import toolchain as T


@pytest.fixture()
def fake(monkeypatch):
    """build_firmware with generation, the cross compiler and the tool versions faked."""
    state = SimpleNamespace(compiled=[], sources={"ballbot_fw_cg.c": "int x;", "ballbot_fw.c": "f"},
                            version="gcc 1", generated=[])
    monkeypatch.setattr(B, "require", lambda qemu: state.generated.append(("require", qemu)))
    monkeypatch.setattr(B, "firmware_function", lambda c, e, g, lat: ("f", c, e, g, lat))
    monkeypatch.setattr(B, "scenario_values", lambda f, sc, law, path: ("values", sc.controller,
                                                                        sc.estimator, law, path))
    monkeypatch.setattr(B, "default_guidance_path", lambda: "path")
    monkeypatch.setattr(B, "firmware_guidance", lambda g, c, lat: None if g is None else SimpleNamespace(
        name=g, latency=lat))
    monkeypatch.setattr(B, "guidance_every", lambda law: 20)

    def generate(f, precision, values, every, law, estimator):
        state.generated.append((f, precision, values, every, law, estimator))
        return dict(state.sources)
    monkeypatch.setattr(B, "generate_sources", generate)
    monkeypatch.setattr(B, "csrc_path", lambda n: SimpleNamespace(read_text=lambda: f"<{n}>"))
    monkeypatch.setattr(B, "compiler_command", lambda: ["cc"])
    monkeypatch.setattr(B, "tool_version", lambda tool: f"{tool} {state.version}")

    def compile_(tmp, files, precision, cpu, lib_cpu, host_cc):
        state.compiled.append(SimpleNamespace(files=files, precision=precision, cpu=cpu,
                                              lib_cpu=lib_cpu, host_cc=host_cc))
        for p in B._PRODUCTS:
            (tmp / p).write_text(f"{p} {len(state.compiled)}")
    monkeypatch.setattr(B, "_compile", compile_)
    return state


def _digest(files: dict, cpu, lib_cpu, version="gcc 1") -> str:
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(name.encode() + b"\0" + files[name].encode() + b"\0")
    h.update("\0".join([*cpu, *lib_cpu, *B.FW_CFLAGS, *B.SINGLE_CFLAGS, "cc",
                        f"arm-none-eabi-gcc {version}", f"cc {version}"]).encode())
    return h.hexdigest()[:16]


def test_build_names_hashes_and_caches(fake, tmp_path):
    fw = B.build_firmware("flc", "ukf", "single", root=tmp_path)
    files = {**fake.sources, **{n: f"<{n}>" for n in B._TARGET_FILES}}
    cpu = T.ARM_CPU_FLAGS["single"]
    digest = _digest(files, cpu, cpu)
    assert fw.digest == digest and fw.status == "built"
    assert fw.folder == tmp_path / "firmware" / f"flc_ukf_single-{digest}"
    assert (fw.controller, fw.estimator, fw.precision, fw.guidance, fw.latency) == (
        "flc", "ukf", "single", None, 0)
    c = fake.compiled[0]
    assert c.files == files and c.precision == "single" and c.cpu == cpu == c.lib_cpu
    assert c.host_cc == ["cc"]
    assert fake.generated[0] == ("require", False)
    assert fake.generated[1] == (("f", "flc", "ukf", None, 0), "single",
                                 ("values", "flc", "ukf", None, None), 0, None, "ukf")
    # intact: cached, not compiled again
    again = B.build_firmware("flc", "ukf", "single", root=tmp_path)
    assert again.status == "cached" and again.folder == fw.folder and len(fake.compiled) == 1
    # a damaged product: rebuilt, the reason in the status
    (fw.folder / "replay.elf").write_text("damaged")
    fixed = B.build_firmware("flc", "ukf", "single", root=tmp_path)
    assert fixed.status.startswith("rebuilt: ") and "replay.elf" in fixed.status
    assert len(fake.compiled) == 2 and (fw.folder / "replay.elf").read_text() == "replay.elf 2"
    assert not [p for p in (tmp_path / "firmware").iterdir() if p.name.startswith(".flc")
                and p.is_dir()]  # no temporary folder left
    # the hash covers the sources, the flags and the compilers' versions
    fake.sources["ballbot_fw.c"] = "g"
    assert B.build_firmware("flc", "ukf", "single", root=tmp_path).digest != digest
    fake.sources["ballbot_fw.c"] = "f"
    fake.version = "gcc 2"
    assert B.build_firmware("flc", "ukf", "single", root=tmp_path).digest != digest
    fake.version = "gcc 1"
    other = B.build_firmware("flc", "ukf", "single", root=tmp_path, lib_cpu_flags=("-mthumb",))
    assert other.digest == _digest(files, cpu, ("-mthumb",))
    assert fake.compiled[-1].lib_cpu == ("-mthumb",) and fake.compiled[-1].cpu == cpu


def test_guided_builds_are_tagged_and_get_the_path(fake, tmp_path):
    fw = B.build_firmware("flc", "ukf", "double", root=tmp_path, guidance="mpc", latency=5)
    assert fw.folder.name.startswith("flc_ukf_mpc_l5_double-")
    assert (fw.guidance, fw.latency) == ("mpc", 5)
    f, precision, values, every, law, est = fake.generated[-1]
    assert f == ("f", "flc", "ukf", "mpc", 5) and every == 20 and law.latency == 5
    assert values[3] is law and values[4] == "path"
    fw0 = B.build_firmware("flc", "ukf", "double", root=tmp_path, guidance="mpc")
    assert fw0.folder.name.startswith("flc_ukf_mpc_double-")
    given = B.build_firmware("flc", "ukf", "double", root=tmp_path, values="mine")
    assert fake.generated[-1][2] == "mine" and given.folder.name.startswith("flc_ukf_double-")


def test_build_refusals(fake, tmp_path):
    with pytest.raises(ScenarioError, match=r"^unknown precision 'half'; allowed: double, single$"):
        B.build_firmware(precision="half", root=tmp_path)
    with pytest.raises(ScenarioError, match=r"^a guidance latency \(5\) needs a guidance block "
                       r"\(guidance 'mpc'\)$"):
        B.build_firmware(latency=5, root=tmp_path)
    assert fake.compiled == [] and fake.generated == []  # refused before the toolchain


def test_build_paths_and_flags():
    fw = B.FirmwareBuild(Path("/b/x"), "flc", "ukf", "double", "d" * 16)
    assert (fw.library, fw.include, fw.replay_elf, fw.example_elf, fw.host_replay,
            fw.stack_usage) == tuple(Path("/b/x") / n for n in (
                "libballbot_fw.a", "include", "replay.elf", "example.elf", "replay_host",
                "stack_usage.txt"))
    assert fw.status == "cached" and fw == B.FirmwareBuild(Path("/b/x"), "flc", "ukf", "double",
                                                           "d" * 16, status="built")
    assert B._cflags("double", ("-m",)) == ["-m", *B.FW_CFLAGS]
    assert B._cflags("single", ("-m",)) == ["-m", *B.FW_CFLAGS, *B.SINGLE_CFLAGS]
    assert "-Werror" in B.FW_CFLAGS and "-std=c99" in B.FW_CFLAGS
    assert B.SINGLE_CFLAGS == ("-fsingle-precision-constant", "-Wdouble-promotion")
    assert T.PRECISIONS == {"double": "double", "single": "float"}
    assert T.ARM_CPU_FLAGS["single"][1] == "-mfpu=fpv5-sp-d16"
    assert T.ARM_CPU_FLAGS["double"][1] == "-mfpu=fpv5-d16"


def test_missing_tools_and_versions(monkeypatch):
    present = {"arm-none-eabi-gcc"}
    monkeypatch.setattr(T.shutil, "which", lambda t: f"/usr/bin/{t}" if t in present else None)
    assert T.missing_tools() == ["arm-none-eabi-size", "qemu-system-arm"]
    assert T.missing_tools(qemu=False) == ["arm-none-eabi-size"]
    with pytest.raises(T.ToolchainMissing, match=r"^arm-none-eabi-size not found; install"):
        T.require(qemu=False)
    with pytest.raises(T.ToolchainMissing, match=r"^arm-none-eabi-size, qemu-system-arm not found"):
        T.require()
    present.add("arm-none-eabi-size")
    T.require(qemu=False)
    outs = {"a": "a 1.2\nmore\n", "b": "\n"}

    def run(cmd, **kw):
        if cmd[0] == "gone":
            raise OSError("no such file")
        return SimpleNamespace(stdout=outs[cmd[0]])
    monkeypatch.setattr(T.subprocess, "run", run)
    assert (T.tool_version("a"), T.tool_version("b"), T.tool_version("gone")) == (
        "a 1.2", "unknown", "missing")
