"""The two FMUs of a run, the firmware and the plant, as fmpy instances: extracted,
instantiated and initialised (FmuPair), the plant's start values set from the mission's
[plant] table and the run's seed, a refusal named in the mission's terms."""

from __future__ import annotations

import re
from pathlib import Path

from navkit.sim.mission import Mission, MissionError
from navkit.sim.options import SimError

__all__ = ["FmuPair", "set_start", "check_seed"]


def set_start(slave, md, name: str, value, where: str, fmu: Path) -> None:
    """Set variable `name` of FMU file `fmu` (model description `md`) before initialisation,
    converting `value` to its type."""
    var = {v.name: v for v in md.modelVariables}.get(name)
    if var is None:
        raise MissionError(f"{where}: key {name!r}: the plant FMU ({fmu}) has no such variable")
    if var.causality not in ("parameter", "structuralParameter"):
        raise MissionError(f"{where}: key {name!r}: not a parameter of the plant FMU ({fmu}) "
                           f"(causality {var.causality})")
    vr = [var.valueReference]
    t = var.type
    try:
        if t in ("Float64", "Float32"):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError
            getattr(slave, f"set{t}")(vr, [float(value)])
        elif t.startswith(("Int", "UInt")):
            if isinstance(value, bool) or not isinstance(value, int):
                raise TypeError
            getattr(slave, f"set{t}")(vr, [value])
        elif t == "Boolean":
            if not isinstance(value, bool):
                raise TypeError
            slave.setBoolean(vr, [value])
        elif t == "String":
            if not isinstance(value, str):
                raise TypeError
            slave.setString(vr, [value])
        else:
            raise MissionError(f"{where}: key {name!r}: cannot set a {t} variable")
    except TypeError:
        raise MissionError(f"{where}: key {name!r}: {value!r} does not fit its type {t}") from None


_PARAM_MSG = re.compile(r"\bparameter (\w+)\b")

# FMI integer types -> (least, greatest) value
_INT_RANGES = {f"{u}Int{n}": (0, (1 << n) - 1) if u else (-(1 << n - 1), (1 << n - 1) - 1)
               for u in ("", "U") for n in (8, 16, 32, 64)}


def check_seed(seed: int, plant_md, plant_fmu: Path) -> None:
    """SimError unless `seed` fits the plant FMU's `seed` parameter (model description
    `plant_md`): its integer type's range (Int32 for the built plant), narrowed by its
    min / max when the FMU declares them. fmpy would wrap a seed outside it silently, so
    two seeds would give the same run while the outputs record different ones. A plant
    without a seed takes any (the line noise's generator is seeded with it as well)."""
    var = next((v for v in plant_md.modelVariables if v.name == "seed"), None)
    if var is None:
        return
    lo, hi = _INT_RANGES[var.type]
    lo = max(lo, int(var.min)) if var.min is not None else lo
    hi = min(hi, int(var.max)) if var.max is not None else hi
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise SimError(f"--seed {seed!r}: not an integer")
    if not lo <= seed <= hi:
        raise SimError(f"--seed {seed!r}: outside {lo}..{hi}, the values of the plant FMU's "
                       f"seed parameter ({var.type}, {plant_fmu})")


class FmuPair:
    """The firmware FMU and the plant FMU (files checked to exist by the caller) extracted
    into `tmp`, instantiated (`fw`, `plant`; model descriptions `fw_md`, `plant_md`) and
    initialised at t = 0 s. Their log messages are kept (`log`, newest last, at most 50)
    and name the cause when a call fails. `validate_plant`: the plant's model description
    is checked against the FMI schemas (navkit.sim.plant.check: a plant of the user's;
    the firmware FMU is the build's)."""

    def __init__(self, fw_path: Path, plant_path: Path, tmp: Path, plant_params: dict,
                 mission: Mission, validate_plant: bool = True):
        from fmpy import extract
        from fmpy.fmi3 import FMU3Slave

        from navkit.sim.plant import model_description

        self.slaves = []
        self.log = []
        self.fw_md = model_description(fw_path, False)
        self.plant_md = model_description(plant_path, validate_plant)
        fw_dir = extract(str(fw_path), unzipdir=str(tmp / "fw"))
        plant_dir = extract(str(plant_path), unzipdir=str(tmp / "plant"))
        self.fw = FMU3Slave(guid=self.fw_md.guid, unzipDirectory=fw_dir,
                            modelIdentifier=self.fw_md.coSimulation.modelIdentifier,
                            instanceName="firmware")
        self.plant = FMU3Slave(guid=self.plant_md.guid, unzipDirectory=plant_dir,
                               modelIdentifier=self.plant_md.coSimulation.modelIdentifier,
                               instanceName="plant")
        try:
            self.fw.instantiate(logMessage=self._logger("firmware"))
            self.slaves.append(self.fw)
            self.plant.instantiate(logMessage=self._logger("plant"))
            self.slaves.append(self.plant)
            for name, value in plant_params.items():
                set_start(self.plant, self.plant_md, name, value, f"{mission.path}: [plant]",
                          plant_path)
            self._init(self.fw, "firmware", fw_path, 0.0)
            self._init_plant(plant_path, mission, plant_params)
        except BaseException:
            self.close()
            raise

    def _logger(self, who: str):
        """An fmi3LogMessageCallback that keeps the FMU `who`'s messages."""
        def log(_env, _status, _category, message) -> None:
            self.log.append((who, message.decode(errors="replace") if message else ""))
            del self.log[:-50]
        return log

    def _messages(self, who: str) -> str:
        """The kept messages of FMU `who`, joined by "; "."""
        return "; ".join(m for w, m in self.log if w == who) or "(the FMU logged nothing)"

    def _init(self, slave, who: str, path: Path, t: float) -> None:
        """Enter and exit initialisation mode at `t` (s); SimError with the FMU's log."""
        from fmpy.fmi1 import FMICallException

        try:
            slave.enterInitializationMode(startTime=t)
            slave.exitInitializationMode()
        except FMICallException as e:
            raise SimError(f"the {who} FMU ({path}) failed to initialise: {e} "
                           f"{self._messages(who)}") from None

    def _init_plant(self, path: Path, mission, params: dict) -> None:
        """Initialise the plant; a refusal is the mission's: MissionError naming the mission
        file and the [plant] key (from the FMU's message) or the world file and line."""
        from fmpy.fmi1 import FMICallException

        try:
            self.plant.enterInitializationMode(startTime=0.0)
            self.plant.exitInitializationMode()
        except FMICallException as e:
            text = self._messages("plant")
            keys = [k for k in _PARAM_MSG.findall(text) if k in mission.plant]
            world = params.get("world_file")
            if keys:
                where = f"{mission.path}: [plant]: key {keys[0]!r}"
            elif world and world in text:
                where = f"{mission.path}: key 'world'"
            elif mission.plant:
                where = f"{mission.path}: [plant] ({', '.join(mission.plant)})"
            else:
                where = f"{mission.path}"
            raise MissionError(f"{where}: the plant FMU ({path}) refused it: {text} "
                               f"({e.function} failed)") from None

    def walls(self, plant_path: Path) -> bytes | None:
        """The plant's `walls` output (docs/plant.md: the world it loaded, as whole walls
        of navkit.sim.foxglove.WALL_BYTES bytes), None if the plant `plant_path` has none;
        SimError if it is not whole walls."""
        from navkit.sim.foxglove import WALL_BYTES

        var = next((v for v in self.plant_md.modelVariables if v.name == "walls"), None)
        if var is None:
            return None
        data = bytes(self.plant.getBinary([var.valueReference])[0] or b"")
        if len(data) % WALL_BYTES:
            raise SimError(f"{plant_path}: its walls output is {len(data)} bytes, not whole "
                           f"walls of {WALL_BYTES} bytes (docs/plant.md)")
        return data

    def reset_firmware(self, t: float) -> None:
        """fmi3Reset of the firmware, then initialise it again starting at `t` (s)."""
        self.fw.reset()
        self._init(self.fw, "firmware", Path(self.fw_md.modelName), t)

    def close(self) -> None:
        """Terminate and free both instances (best effort: a failed FMU may refuse)."""
        for s in self.slaves:
            try:
                s.terminate()
            except Exception:  # noqa: BLE001 - best effort at shutdown
                pass
            try:
                s.freeInstance()
            except Exception:  # noqa: BLE001
                pass
        self.slaves = []

