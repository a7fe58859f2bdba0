"""The one FMI layer (fmu/fmi, fmil.h) behind every FMU: the same state table, value
reference checks, refusals and messages in navkit_firmware, navkit_plant (FMI 3.0 and 2.0)
and navkit_firmware_avr, and only the FMI API exported from each binary."""

from __future__ import annotations

import subprocess

import pytest

fmpy = pytest.importorskip("fmpy")
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402
from fmpy.fmi3 import FMU3Slave  # noqa: E402

from navkit.paths import build_dir  # noqa: E402

FMUS = ["navkit_firmware", "navkit_plant", "navkit_firmware_avr"]


def fmu_path(name):
    path = build_dir() / "fmus" / f"{name}.fmu"
    if not path.exists():
        pytest.skip(f"{path} not built")
    return path


class Instance:
    """An FMU instance with its log (messages as str)."""

    def __init__(self, name, tmp_path, token=None):
        path = fmu_path(name)
        self.md = fmpy.read_model_description(str(path))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.log = []
        unzipped = fmpy.extract(str(path), unzipdir=str(tmp_path / name))
        cls = FMU3Slave if self.md.fmiVersion.startswith("3") else FMU2Slave
        self.fmu = cls(guid=token or self.md.guid, unzipDirectory=unzipped,
                       modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)

    def instantiate(self):
        if isinstance(self.fmu, FMU3Slave):
            self.fmu.instantiate(logMessage=lambda env, st, cat, msg: self.log.append(msg.decode()))
        else:
            self.fmu.instantiate(loggingOn=False)

    def refused(self, call, *args, text=None):
        """call(*args) raises FMICallException, and the log has `text` when given."""
        del self.log[:]
        with pytest.raises(FMICallException):
            call(*args)
        if text is not None:
            assert any(text in m for m in self.log), (text, self.log)

    def vr(self, kind, causality, var_type="Float64"):
        return next(v.valueReference for v in self.md.modelVariables
                    if v.causality == causality and v.type == var_type and
                    (kind is None or kind in v.name))


@pytest.mark.parametrize("name", FMUS)
def test_state_table_and_refusals_are_the_layers(name, tmp_path):
    i = Instance(name, tmp_path)
    i.instantiate()
    f = i.fmu
    out_vr = i.vr(None, "output")
    i.refused(f.doStep, 0.0, 0.001, text="fmi3DoStep is not allowed in state 1")
    i.refused(f.getFloat64, [out_vr], text="fmi3Get<Type> is not allowed in state 1")
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    i.refused(f.getFloat64, [999], text="fmi3GetFloat64: no variable with value reference 999")
    i.refused(f.getInt32, [out_vr], text="is Float64, not Int32")
    i.refused(f.setFloat64, [out_vr], [1.0], text="is not an input or parameter and cannot be set")
    param = next(v for v in i.md.modelVariables if v.causality == "parameter")
    setter = getattr(f, f"set{param.type}")
    value = "" if param.type == "String" else 1
    i.refused(setter, [param.valueReference], [value], text="is a fixed parameter")
    i.refused(f.setDebugLogging, True, ["logEverything"], text='unknown log category "logEverything"')
    f.setDebugLogging(True, ["logEvents"])
    assert f.getBoolean([]) == []                     # a type without variables: no references is fine
    i.refused(f.getBoolean, [0], text="fmi3GetBoolean: the model has no variable of this type")
    i.refused(f.getFMUState, text=f"fmi3GetFMUState is not supported by {name}")
    f.doStep(0.0, 0.001)
    i.refused(f.doStep, 0.5, 0.001, text="currentCommunicationPoint 0.500000000 s != the FMU's time 0.001000000 s")
    i.refused(f.doStep, 0.001, -1.0, text="communicationStepSize -1 must be > 0")
    f.terminate()
    i.refused(f.doStep, 0.001, 0.001, text="fmi3DoStep is not allowed in state 8")
    f.reset()                                         # back to Instantiated: start values
    f.enterInitializationMode(startTime=2.0)
    f.exitInitializationMode()
    f.doStep(2.0, 0.001)
    assert f.getFloat64([i.vars["time"].valueReference])[0] == pytest.approx(2.001)
    f.terminate()
    f.freeInstance()


@pytest.mark.parametrize("name", FMUS)
def test_a_wrong_token_is_refused_naming_the_model(name, tmp_path):
    i = Instance(name, tmp_path, token="{00000000-0000-0000-0000-000000000000}")
    with pytest.raises(Exception):
        i.instantiate()
    assert any(m.startswith(f"{name}: instantiationToken does not match") for m in i.log), i.log


def test_fmi2_build_of_the_plant_has_the_same_state_table(tmp_path):
    i = Instance("navkit_plant_fmi2", tmp_path)
    i.instantiate()
    f = i.fmu
    with pytest.raises(FMICallException):
        f.doStep(0.0, 0.001)                          # Instantiated: not yet
    f.setupExperiment(startTime=1.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    with pytest.raises(FMICallException):
        f.setReal([i.vr("x_mm", "output", "Real")], [1.0])
    f.doStep(1.0, 0.01)
    assert f.getReal([i.vars["time"].valueReference])[0] == pytest.approx(1.01)
    f.terminate()
    f.freeInstance()


@pytest.mark.parametrize("name", FMUS + ["navkit_plant_fmi2"])
def test_only_the_fmi_api_is_exported(name):
    """Every dynamic symbol the binary defines is an fmi2*/fmi3* function: the layer, the
    model and the libraries linked in (the firmware core, the board simulator) stay hidden."""
    fmu_path(name)
    sos = list((build_dir() / "fmus" / name / "binaries").glob("*/*.so"))
    assert len(sos) == 1, sos
    r = subprocess.run(["nm", "-D", "--defined-only", str(sos[0])], capture_output=True, text=True, check=True)
    names = [line.split()[-1] for line in r.stdout.splitlines() if line.split()[-2] in "TtDdBbRr"]
    api = "fmi2" if name.endswith("fmi2") else "fmi3"
    assert names and all(n.startswith(api) for n in names), [n for n in names if not n.startswith(api)]
