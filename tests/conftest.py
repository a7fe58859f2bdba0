"""Shared pytest options and fixtures: the build the tests need (a missing one stops the run
with one message), seeded property tests' seed and count from the command line (`pytest
--prop-seed 7 --prop-count 100000`) or the environment (NAVKIT_PROP_SEED, NAVKIT_PROP_COUNT),
the host and FMU helpers. Helpers shared as plain code live in tests/*_helpers.py (no
tests in them); no test imports another test module."""

import os

import pytest


# ---------------------------------------------------------------- the build
# Most tests run the built host, FMUs and coupler (navkit.paths.build_dir()). Without them a
# bare `pytest` stops before collecting with one message naming the build folder and the
# fix, never a run of skips that reads as green. NAVKIT_TEST_WITHOUT_BUILD=1 opts out: the
# tests that need no build run, the others skip (their own require_build / skipif).


def pytest_configure(config):
    """Stop the run (pytest.UsageError: exit status 4) when the build folder lacks a product
    of sim_helpers.build_missing(), unless opted out or only asked for --help/--version."""
    if config.option.help or config.option.version or os.environ.get("NAVKIT_TEST_WITHOUT_BUILD") == "1":
        return
    from sim_helpers import build_missing

    missing = build_missing()
    if missing:
        from navkit.paths import build_dir

        raise pytest.UsageError(
            f"{build_dir()}: not built (no {', '.join(p.name for p in missing)}): run `make build`, or set "
            "NAVKIT_BUILD_DIR to a built folder (NAVKIT_TEST_WITHOUT_BUILD=1 runs only the tests that need "
            "no build)")


def pytest_addoption(parser):
    parser.addoption("--prop-seed", type=int, default=int(os.environ.get("NAVKIT_PROP_SEED", "1")),
                     help="seed of the seeded property tests")
    parser.addoption("--prop-count", type=int, default=int(os.environ.get("NAVKIT_PROP_COUNT", "300")),
                     help="cases per property test")


@pytest.fixture
def prop_seed(request) -> int:
    """Seed for property tests (printed on failure by the tests that use it)."""
    return request.config.getoption("--prop-seed")


@pytest.fixture
def prop_count(request) -> int:
    """Number of random cases per property test."""
    return request.config.getoption("--prop-count")


@pytest.fixture
def host_converts():
    """Skip unless navkit-host is built: loading a mission with [[command]] entries asks it
    (`navkit-host --convert-lisp`) what it makes of them (navkit.sim.mission)."""
    from host_helpers import require_host

    require_host()


# ---------------------------------------------------------------- the host binary


@pytest.fixture
def host_factory(tmp_path):
    """host_factory(cls=Host, **kw) -> a host_helpers.Host (or subclass `cls`) of the real
    navkit-host in a folder of its own under tmp_path, kw to its constructor; all are
    closed after the test."""
    from host_helpers import Host

    made = []

    def make(cls: type = Host, **kw) -> Host:
        d = tmp_path / f"h{len(made)}"
        d.mkdir()
        h = cls(d, **kw)
        made.append(h)
        return h

    yield make
    for h in made:
        h.close()


# ---------------------------------------------------------------- FMUs in fmpy
# A test module of one FMU names its file in a module-level `FMU` (pathlib.Path); the
# fixtures below open that file.


@pytest.fixture
def shm_name():
    """A POSIX shared-memory name of this test process; the region and a "-link" beside it
    are removed after the test."""
    name = f"/nk-rcomm-{os.getpid()}"
    yield name
    for path in ("/dev/shm" + name, "/dev/shm" + name + "-link"):
        try:
            os.unlink(path)
        except OSError:
            pass


@pytest.fixture(scope="session")
def status_bit():
    """status_bit(name) -> the mask of micro_status flag `name`, from the spec (bit values
    are never hard-coded in tests; spec_helpers.bit)."""
    from spec_helpers import bit

    return lambda name: bit("micro_status", name)


@pytest.fixture(scope="module")
def unzipped(request, tmp_path_factory) -> str:
    """The folder the module's FMU is extracted into (one per module)."""
    import fmpy
    fmu = request.module.FMU
    return fmpy.extract(str(fmu), unzipdir=str(tmp_path_factory.mktemp(fmu.stem)))


@pytest.fixture(scope="module")
def md(request):
    """The module's FMU's model description, validated by fmpy on reading."""
    import fmpy
    return fmpy.read_model_description(str(request.module.FMU), validate=True)


class Fmu3:
    """One FMI 3 co-simulation instance of an FMU, its variables addressed by name through
    the setter and getter of each one's type. `vr` maps names to value references, `log`
    keeps the FMU's messages (str), `t` is the instance's time (s) and `h` the step of
    run() (s)."""

    def __init__(self, unzipdir, md, name, h=0.001):
        from fmpy.fmi3 import FMU3Slave
        self.vars = {v.name: v for v in md.modelVariables}
        self.vr = {n: v.valueReference for n, v in self.vars.items()}
        self.log = []
        self.fmu = FMU3Slave(guid=md.guid, unzipDirectory=unzipdir,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(logMessage=lambda env, st, cat, msg: self.log.append(msg.decode()))
        self.t, self.h = 0.0, h

    def start(self, **params):
        """Initialization mode from t = 0 with `params` set in it, then step mode."""
        self.fmu.enterInitializationMode(startTime=0.0)
        self.set(**params)
        self.fmu.exitInitializationMode()
        self.t = 0.0

    def set(self, **values):
        for name, value in values.items():
            v = self.vars[name]
            cast = {"Float64": float, "String": str, "Binary": bytes, "Boolean": bool}.get(v.type, int)
            getattr(self.fmu, f"set{v.type}")([v.valueReference], [cast(value)])

    def get(self, name):
        v = self.vars[name]
        return getattr(self.fmu, f"get{v.type}")([v.valueReference])[0]

    def step(self, h=None, rx=b""):
        """One doStep of h seconds (default self.h); an FMU with a serial link gets rx in
        serial_rx and returns the bytes of serial_tx, others return b""."""
        h = self.h if h is None else h
        if "serial_rx" in self.vr:
            self.fmu.setBinary([self.vr["serial_rx"]], [rx])
        self.fmu.doStep(self.t, h)
        self.t += h
        return bytes(self.fmu.getBinary([self.vr["serial_tx"]])[0]) if "serial_tx" in self.vr else b""

    def run(self, seconds, watch=()):
        """Steps of self.h for `seconds`; {name: [value after each step]} for `watch`."""
        rows = {n: [] for n in watch}
        for _ in range(round(seconds / self.h)):
            self.step()
            for n in watch:
                rows[n].append(self.get(n))
        return rows

    def frames(self, seconds, rx=b"", h=0.001, frame_period=0.1, before=None, after=None):
        """Steps of h for `seconds`, the host sending rx every frame_period (s, as it repeats
        its last command); before(self) and after(self, h) run around each step (a plant
        model's inputs and update). Returns the fields of the micro_data frames sent back."""
        from navkit import protocol
        parser = protocol.Parser(protocol.DIR_TO_HOST)
        out = []
        every = round(frame_period / h)
        for k in range(round(seconds / h)):
            if before:
                before(self)
            tx = self.step(h, rx if k % every == 0 else b"")
            if after:
                after(self, h)
            for ev in parser.feed(tx):
                assert isinstance(ev, protocol.Frame), ev
                out.append(ev.fields)
        return out

    def free(self):
        self.fmu.freeInstance()


@pytest.fixture
def fmu3(unzipped, md):
    """fmu3(name="fmu", start=True, **params) -> a Fmu3 of the module's FMU, started with
    `params` set in initialization mode unless start=False; freed when the test ends."""
    made = []

    def make(name="fmu", start=True, **params):
        inst = Fmu3(unzipped, md, name)
        made.append(inst)
        if start:
            inst.start(**params)
        return inst

    yield make
    for inst in made:
        inst.free()


@pytest.fixture
def micro(fmu3):
    """micro(name="micro", start=True, **params) -> an instance of the module's firmware FMU
    (a Fmu3 of fmu3, named "micro")."""
    return lambda name="micro", **kw: fmu3(name, **kw)
