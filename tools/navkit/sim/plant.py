"""Checking a plant FMU before a run (`navkit sim --plant FILE`): the native coupler needs
an FMI 3.0 co-simulation FMU with a binary for this platform and the variable contract of
docs/internals.md ("Firmware FMU <-> plant FMU").

The contract is read from the firmware FMU itself: every Float64 / Int32 input of the
firmware must be a plant output of the same name and type, every firmware output a plant
input. Optional, but checked when present: the truth outputs (Float64 outputs, the
`/truth` columns), the parameters `seed` (Int32) and `world_file` (String) and the
output `walls` (Binary: the world's walls, drawn in run.mcap's /foxglove/scene).
"""

from __future__ import annotations

import functools
from pathlib import Path

__all__ = ["PlantFmuError", "check", "contract", "model_description", "FMI2_UNSUPPORTED"]

FMI2_UNSUPPORTED = "FMI 2.0 plant FMUs are not supported by the native coupler"

_LINKED_TYPES = ("Float64", "Int32")
_OPPOSITE = {"input": "output", "output": "input"}
# optional variables: name -> (type, causality)
_OPTIONAL = {"seed": ("Int32", "parameter"), "world_file": ("String", "parameter"),
             "walls": ("Binary", "output")}


class PlantFmuError(ValueError):
    """A plant FMU the harness cannot couple; the text names the file and every problem."""


def contract(fw_md) -> dict:
    """{name: (type, causality)} every plant FMU must have, from the firmware FMU's model
    description `fw_md`: the firmware's Float64 / Int32 inputs and outputs with the
    plant-side (opposite) causality."""
    return {v.name: (v.type, _OPPOSITE[v.causality]) for v in fw_md.modelVariables
            if v.type in _LINKED_TYPES and v.causality in _OPPOSITE}


def model_description(path: Path, validate: bool = True):
    """fmpy's model description of FMU file `path`, read once per version of the file (its
    size and modification time) and `validate` (its XML checked against the FMI schemas,
    which fmpy loads at the first check in a process): the check and the instantiation of
    a run, and the runs of one process, share it. Read-only to its users."""
    st = Path(path).stat()
    return _model_description(str(path), st.st_size, st.st_mtime_ns, validate)


@functools.lru_cache(maxsize=8)
def _model_description(path: str, _size: int, _mtime_ns: int, validate: bool):
    from fmpy import read_model_description

    return read_model_description(path, validate=validate)


def _read(path: Path, what: str, validate: bool = True):
    if not path.is_file():
        raise PlantFmuError(f"{path}: no such file ({what})")
    try:
        return model_description(path, validate)
    except Exception as e:  # noqa: BLE001 - fmpy raises plain Exception for bad FMUs
        raise PlantFmuError(f"{path}: not a readable FMU: {e}") from None


def check(plant_fmu: str | Path, fw_fmu: str | Path, validate: bool = True):
    """Check the plant FMU file `plant_fmu` against the firmware FMU file `fw_fmu`; return
    the plant's fmpy model description. Raises PlantFmuError naming `plant_fmu` and, for a
    variable mismatch, each missing or mistyped variable. `validate`: check the plant's
    XML against the FMI schemas (a plant of the user's). The build's own FMUs are
    validated by their tests (test_plant_fmu, test_firmware_fmu, test_pil_fmu), so the
    firmware FMU, always the build's, is read without, as is the build's plant
    (`validate` False)."""
    import zipfile

    from fmpy import platform_tuple, sharedLibraryExtension

    from navkit.sim.coupler import TRUTH_PLANT

    plant_fmu, fw_fmu = Path(plant_fmu), Path(fw_fmu)
    md = _read(plant_fmu, "the plant FMU", validate)
    if md.fmiVersion.startswith("2."):
        raise PlantFmuError(f"{plant_fmu}: {FMI2_UNSUPPORTED} (it calls the fmi3 functions): "
                            f"export the plant as an FMI 3.0 co-simulation FMU")
    if not md.fmiVersion.startswith("3."):
        raise PlantFmuError(f"{plant_fmu}: FMI {md.fmiVersion} is not supported: the native "
                            f"coupler needs an FMI 3.0 co-simulation FMU")
    if md.coSimulation is None:
        raise PlantFmuError(f"{plant_fmu}: not a co-simulation FMU (no <CoSimulation>): the "
                            f"native coupler needs an FMI 3.0 co-simulation FMU")
    binary = f"binaries/{platform_tuple}/{md.coSimulation.modelIdentifier}" \
             f"{sharedLibraryExtension}"
    with zipfile.ZipFile(plant_fmu) as z:
        if binary not in z.namelist():
            raise PlantFmuError(f"{plant_fmu}: no binary for this platform ({binary})")
    have = {v.name: v for v in md.modelVariables}
    wanted = contract(_read(fw_fmu, "the firmware FMU", validate=False))
    optional = dict(_OPTIONAL, **{n: ("Float64", "output") for n in TRUTH_PLANT})
    problems = []
    for name, (typ, caus) in list(wanted.items()) + list(optional.items()):
        v = have.get(name)
        if v is None:
            if name in wanted:
                problems.append(f"missing {name} ({typ} {caus})")
        elif (v.type, v.causality) != (typ, caus):
            problems.append(f"{name} is {v.type} {v.causality}, expected {typ} {caus}")
    if problems:
        lines = "\n".join(f"  {p}" for p in problems)
        raise PlantFmuError(f"{plant_fmu}: does not fit the firmware FMU's variables "
                            f"(docs/internals.md, \"Firmware FMU <-> plant FMU\"):\n{lines}")
    return md
