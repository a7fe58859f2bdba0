"""ctypes binding of the native coupler `navkit_cosim` (fmu/cosim): steps the firmware
FMU and the plant FMU together at 1 kHz without a Python call per step.

The FMUs are fmpy `FMU3Slave` objects the caller has instantiated and initialised; this
module passes their instance handles and fmi3 function addresses to the library and
connects every firmware input to the plant output of the same name and every firmware
output to the plant input of the same name (Float64 and Int32, docs/internals.md).
"""

from __future__ import annotations

import ctypes
from ctypes import POINTER, c_double, c_int, c_size_t, c_uint8, c_uint32, c_uint64, c_void_p
from pathlib import Path

__all__ = ["CouplerError", "Coupler", "NativeFrames", "library_path", "TRUTH_PLANT",
           "TRUTH_FIRMWARE", "FIRMWARE", "PLANT"]

FIRMWARE, PLANT = 0, 1
_FLOAT64, _INT32 = 0, 1
_TYPES = {"Float64": _FLOAT64, "Int32": _INT32}

# truth columns read from the plant (in this order), then from the firmware
TRUTH_PLANT = ("x_mm", "y_mm", "yaw_deg", "heading_deg", "distance_mm", "v_mm_s",
               "w_deg_s") + tuple(f"servo_deg_{i}" for i in range(8))
TRUTH_FIRMWARE = ("dio_out",)


class CouplerError(RuntimeError):
    """The coupler library or an FMU call failed; the text says which and when."""


class _Fmu(ctypes.Structure):
    _fields_ = [(n, c_void_p) for n in ("instance", "get_float64", "set_float64", "get_int32",
                                        "set_int32", "get_binary", "set_binary", "do_step")]


def library_path(build: Path | None = None) -> Path:
    """The built coupler, `<build>/fmu/cosim/libnavkit_cosim.so` (default build folder:
    navkit.paths.build_dir())."""
    from navkit.paths import build_dir

    return Path(build or build_dir()) / "fmu" / "cosim" / "libnavkit_cosim.so"


_LIB = None


def _lib(build: Path | None = None):
    global _LIB
    if _LIB is None:
        path = library_path(build)
        if not path.exists():
            raise CouplerError(f"{path} not found: build it (cmake --build <build> "
                               f"--target navkit_cosim)")
        lib = ctypes.CDLL(str(path))
        lib.cosim_new.restype = c_void_p
        lib.cosim_new.argtypes = [POINTER(_Fmu), POINTER(_Fmu), c_double, c_double]
        lib.cosim_free.argtypes = [c_void_p]
        lib.cosim_connect.argtypes = [c_void_p, c_int, c_int, c_uint32, c_uint32]
        lib.cosim_serial.argtypes = [c_void_p, c_uint32, c_uint32]
        lib.cosim_record.argtypes = [c_void_p, c_int, c_int, c_uint32]
        lib.cosim_record_every.argtypes = [c_void_p, c_uint32]
        lib.cosim_row_width.restype = c_size_t
        lib.cosim_row_width.argtypes = [c_void_p]
        lib.cosim_sample.argtypes = [c_void_p, POINTER(c_double)]
        lib.cosim_exchange.argtypes = [c_void_p]
        lib.cosim_run.argtypes = [c_void_p, c_uint32, c_void_p, c_size_t,
                                  POINTER(c_uint8), c_size_t, POINTER(c_size_t),
                                  POINTER(c_double), c_size_t, POINTER(c_size_t)]
        lib.cosim_time.restype = c_double
        lib.cosim_time.argtypes = [c_void_p]
        lib.cosim_steps.restype = c_uint64
        lib.cosim_steps.argtypes = [c_void_p]
        lib.cosim_firmware_restart.argtypes = [c_void_p, c_double]
        lib.cosim_fmu_ns.restype = c_uint64
        lib.cosim_fmu_ns.argtypes = [c_void_p, c_int]
        lib.cosim_timing.argtypes = [c_void_p, c_int]
        lib.cosim_error.restype = ctypes.c_char_p
        lib.cosim_error.argtypes = [c_void_p]
        lib.lockstep_new.restype = c_void_p
        lib.lockstep_new.argtypes = [c_void_p, c_int, c_uint32, c_uint32, c_int, c_uint32, c_uint32,
                                     c_uint64, c_uint32, c_uint32, c_void_p, c_size_t, c_void_p,
                                     c_size_t, c_size_t, c_void_p, c_size_t, c_void_p]
        lib.lockstep_rcomm.argtypes = [c_void_p, c_void_p, c_void_p, c_void_p, c_void_p]
        lib.lockstep_port.argtypes = [c_void_p, c_int]
        lib.lockstep_free.argtypes = [c_void_p]
        _LIB = lib
    return _LIB


def _fmu_struct(slave) -> _Fmu:
    dll = slave.dll

    def addr(name):
        fn = getattr(dll, name, None)
        return ctypes.cast(fn, c_void_p).value if fn is not None else None

    return _Fmu(slave.component, addr("fmi3GetFloat64"), addr("fmi3SetFloat64"),
                addr("fmi3GetInt32"), addr("fmi3SetInt32"), addr("fmi3GetBinary"),
                addr("fmi3SetBinary"), addr("fmi3DoStep"))


def _variables(md) -> dict:
    return {v.name: v for v in md.modelVariables}


class Coupler:
    """The native coupler of one firmware FMU and one plant FMU.

    `firmware`, `plant`: initialised fmpy FMU3Slave objects; `fw_md`, `plant_md`: their
    model descriptions. `step_s`: the step (s, 0.001 = 1 kHz); `record_every`: steps
    between truth rows (20 = 50 Hz). Truth columns are TRUTH_PLANT then TRUTH_FIRMWARE
    (those the FMUs have); `columns` lists them. `build`: the build folder holding the
    library (default navkit.paths.build_dir()).
    """

    def __init__(self, firmware, fw_md, plant, plant_md, *, step_s=0.001, start_s=0.0,
                 record_every=20, tx_capacity=1 << 16, row_capacity=4096, build=None):
        self._c = None
        lib = _lib(build)
        self._lib = lib
        self._fw_struct, self._plant_struct = _fmu_struct(firmware), _fmu_struct(plant)
        self._c = lib.cosim_new(ctypes.byref(self._fw_struct), ctypes.byref(self._plant_struct),
                                step_s, start_s)
        if not self._c:
            raise CouplerError("cosim_new failed (bad FMU handles or step)")
        self.step_s = step_s
        fw_vars, plant_vars = _variables(fw_md), _variables(plant_md)
        self.links = []          # (source, name) pairs connected
        for name, v in fw_vars.items():
            if v.type not in _TYPES:
                continue
            p = plant_vars.get(name)
            if p is None or p.type != v.type:
                continue
            if v.causality == "input" and p.causality == "output":
                self._check(lib.cosim_connect(self._c, PLANT, _TYPES[v.type],
                                              p.valueReference, v.valueReference))
                self.links.append(("plant", name))
            elif v.causality == "output" and p.causality == "input":
                self._check(lib.cosim_connect(self._c, FIRMWARE, _TYPES[v.type],
                                              v.valueReference, p.valueReference))
                self.links.append(("firmware", name))
        # the link's Binary variables: serial bytes, or CAN frame records (the CAN build)
        rx = fw_vars.get("serial_rx") or fw_vars.get("can_rx")
        tx = fw_vars.get("serial_tx") or fw_vars.get("can_tx")
        if rx is None or tx is None:
            raise CouplerError("the firmware FMU has no serial_rx/serial_tx (or can_rx/can_tx) Binary variables")
        self._check(lib.cosim_serial(self._c, rx.valueReference, tx.valueReference))
        self.columns = []
        for which, names, vars_ in ((PLANT, TRUTH_PLANT, plant_vars),
                                    (FIRMWARE, TRUTH_FIRMWARE, fw_vars)):
            for name in names:
                v = vars_.get(name)
                if v is None or v.type not in _TYPES:
                    continue
                rc = lib.cosim_record(self._c, which, _TYPES[v.type], v.valueReference)
                self._check(rc if rc < 0 else 0)
                self.columns.append(name)
        self._check(lib.cosim_record_every(self._c, record_every))
        self.width = lib.cosim_row_width(self._c)
        self._tx = (c_uint8 * tx_capacity)()
        self._tx_cap = tx_capacity
        self._grow_rows(row_capacity)
        self._tx_len, self._n_rows = c_size_t(), c_size_t()
        # made once: run_raw() is called twice per host frame
        self._tx_len_ref, self._n_rows_ref = ctypes.byref(self._tx_len), ctypes.byref(self._n_rows)
        self._tx_view = memoryview(self._tx).cast("B")
        # run_raw's cosim_run without argtypes, whose per-call conversions cost more than
        # the call: every argument is passed as a ctypes object of the prototype's type
        # (lib.cosim_run above, a separate function object, keeps its argtypes)
        self._run = lib["cosim_run"]
        self._run.argtypes, self._run.restype = None, c_int
        self._handle = c_void_p(self._c)
        self._tx_cap_arg = c_size_t(tx_capacity)
        self._steps_arg: dict = {}       # n_steps -> its c_uint32
        self._no_rx = c_size_t(0)
        self._check(lib.cosim_exchange(self._c))

    def _check(self, rc: int) -> None:
        if rc != 0:
            raise self._error(rc)

    def _error(self, rc: int) -> CouplerError:
        """The error of cosim code `rc`, in cosim_error's words when it has them."""
        return CouplerError(self._lib.cosim_error(self._c).decode() or f"error {rc}")

    def close(self) -> None:
        """Frees the native coupler (the FMUs stay the caller's)."""
        if getattr(self, "_c", None):
            self._lib.cosim_free(self._c)
            self._c = None

    def __del__(self):
        self.close()

    @property
    def time_s(self) -> float:
        """Simulated time (s)."""
        return self._lib.cosim_time(self._c)

    @property
    def steps(self) -> int:
        """Steps done so far."""
        return self._lib.cosim_steps(self._c)

    def sample(self) -> list:
        """The current truth row [t_s, columns...] without stepping."""
        row = (c_double * self.width)()
        self._check(self._lib.cosim_sample(self._c, row))
        return list(row)

    def run(self, n_steps: int, rx: bytes = b"") -> tuple[bytes, list]:
        """Do `n_steps` steps, `rx` arriving at the firmware's serial port with the first.
        Returns (bytes the firmware sent, truth rows as lists [t_s, columns...])."""
        tx, _ = self.run_raw(n_steps, rx)
        n, w = self._n_rows.value, self.width
        flat = self._rows[:n * w]
        return tx, [flat[i * w:(i + 1) * w] for i in range(n)]

    def _grow_rows(self, n_rows: int) -> None:
        """Make the truth row buffer hold `n_rows` rows (its view and capacity argument with it)."""
        self._rows = (c_double * (n_rows * self.width))()
        self._rows_view = memoryview(self._rows).cast("B")
        self._row_cap = n_rows
        self._row_cap_arg = c_size_t(n_rows)

    def run_raw(self, n_steps: int, rx: bytes = b"") -> tuple[bytes, bytes]:
        """As run(), but the truth rows come back as the raw bytes of their doubles
        (native byte order, `width` doubles per row)."""
        if n_steps > self._row_cap:     # enough even with record_every = 1
            self._grow_rows(n_steps)
        steps = self._steps_arg.get(n_steps)
        if steps is None:
            if not 0 <= n_steps <= 0xFFFFFFFF:
                raise CouplerError(f"run_raw: {n_steps} steps is not a uint32")
            steps = self._steps_arg[n_steps] = c_uint32(n_steps)
        if self._c is None:
            raise CouplerError("run_raw: the coupler is closed")
        rc = self._run(self._handle, steps, rx or None, c_size_t(len(rx)) if rx else self._no_rx,
                       self._tx, self._tx_cap_arg, self._tx_len_ref, self._rows, self._row_cap_arg,
                       self._n_rows_ref)
        if rc:
            self._check(rc)
        return (bytes(self._tx_view[:self._tx_len.value]),
                bytes(self._rows_view[:self._n_rows.value * self.width * 8]))

    def exchange(self) -> None:
        """Copy connected outputs to inputs both ways without stepping (after a reset)."""
        self._check(self._lib.cosim_exchange(self._c))

    def firmware_restart(self, start_s: float) -> None:
        """The firmware was reset and re-initialised at its time `start_s` (s)."""
        self._lib.cosim_firmware_restart(self._c, start_s)

    def timing(self, on: bool = True) -> None:
        """Measure the time spent in each FMU (for the benchmark)."""
        self._lib.cosim_timing(self._c, 1 if on else 0)

    def fmu_seconds(self) -> tuple[float, float]:
        """(firmware, plant) wall seconds spent in their calls while timing was on: an
        estimate from one step in 17 (cosim.h COSIM_TIMING_EVERY)."""
        return (self._lib.cosim_fmu_ns(self._c, FIRMWARE) / 1e9,
                self._lib.cosim_fmu_ns(self._c, PLANT) / 1e9)


# lockstep.h's results and output indexes
_LS_OK, _LS_GONE, _LS_BIG = 0, 1, 2
_LS_TIMEOUT, _LS_MAGIC, _LS_FRAME, _LS_SHORT, _LS_OS, _LS_RCOMM, _LS_COSIM = range(-1, -8, -1)
(_TX_BYTES, _FLAGS, _LISP, _TX1, _ROWS1, _WROTE1, _TX2, _ROWS2, _WROTE2, _NS_HOST, _NS_PTY,
 _NS_FMUS, _DETAIL, _ERRNO, _WAITS, _SLEEPS, _OUT_N) = range(17)


class NativeFrames:
    """Lockstep host frames in native code (fmu/cosim/lockstep.h) for `coupler`: the tick
    and done on `lock` (navkit.sim.links.Lockstep, whose timeouts it sets to `timeout_s`
    s, by default links.DONE_WAIT_S), the host's and the firmware's bytes on the pty
    master `pty`, the planner's heartbeat and lisp_data through `rcomm`
    (navkit.rcomm.Client.native(), or None: neither), and each frame's `steps` (>= 1) FMU
    steps in chunks of `split` and the rest, as
    navkit.sim.lockstep's loop does them. host() and micro() return what the Python path's
    calls return; times_s() the wall time (s) in the host (tick -> done), the pty and the
    FMUs so far."""

    # the host's bytes a frame: more than a pty holds (its buffers: 64 KiB and 4 KiB)
    HOST_CAP = 1 << 17

    def __init__(self, coupler: Coupler, lock, pty: int, steps: int, split: int, rcomm=None,
                 timeout_s: float | None = None):
        from navkit.sim.links import DONE_MAGIC, DONE_WAIT_S, READ_WAIT_S, TICK_MAGIC, WRITE_WAIT_S

        self._l = None
        lib = coupler._lib
        self._lib, self._coupler, self._lock = lib, coupler, lock
        lock.set_timeout(DONE_WAIT_S if timeout_s is None else timeout_s)
        self._read_wait_s = READ_WAIT_S
        self._host = (c_uint8 * self.HOST_CAP)()
        self._tx = (c_uint8 * (2 * coupler._tx_cap))()      # a chunk's room is run_raw's
        self._rows = (c_double * (steps * coupler.width))()   # a row a step at most
        self._out = (c_uint64 * _OUT_N)()
        self._host_view = memoryview(self._host).cast("B")
        self._tx_view = memoryview(self._tx).cast("B")
        self._rows_view = memoryview(self._rows).cast("B")
        self._out_view = memoryview(self._out).cast("B").cast("Q")
        self._row_bytes = coupler.width * 8
        self.pty = pty
        self._l = lib.lockstep_new(coupler._c, lock.sock.fileno(), TICK_MAGIC, DONE_MAGIC, pty,
                                   round(READ_WAIT_S * 1000), round(WRITE_WAIT_S * 1000),
                                   steps * 1000, steps, split, self._host, self.HOST_CAP, self._tx,
                                   len(self._tx), coupler._tx_cap, self._rows, steps, self._out)
        if not self._l:
            raise CouplerError("lockstep_new failed (bad arguments or no memory)")
        if rcomm is not None:
            handle, beat, read_data, lisp_bytes, self._rcomm_failed = rcomm
            self._lisp = (ctypes.c_int32 * ((lisp_bytes + 3) // 4))()
            self._lisp_view = memoryview(self._lisp).cast("B")[:lisp_bytes]
            lib.lockstep_rcomm(self._l, handle, beat, read_data, self._lisp)
        # the per-frame calls without argtypes (ints and ctypes objects only)
        self._host_call, self._micro_call = lib["lockstep_host"], lib["lockstep_micro"]
        for fn in (self._host_call, self._micro_call):
            fn.argtypes, fn.restype = None, c_int
        self._handle = c_void_p(self._l)

    def port(self, pty: int) -> None:
        """The port's master is now `pty` (a new pty behind the same path)."""
        self._lib.lockstep_port(self._l, pty)
        self.pty = pty

    def host(self, frame: int, rx_bytes: int):
        """Frame `frame`'s host part: heartbeat, tick (`rx_bytes`: bytes written to the host
        since the last tick), done, the host's bytes from the pty, lisp_data. Returns
        (tx_bytes, flags, host's bytes, lisp_data raw bytes or None), None when the host went
        away (navkit.sim.links.Lockstep.frame's None), or (tx_bytes, flags, None, None) when
        they are more than HOST_CAP: nothing read, the caller reads them. Raises what
        Lockstep.frame, Port.read_exact and the rcomm client raise."""
        rc = self._host_call(self._handle, frame, rx_bytes)
        out = self._out_view
        if rc == _LS_OK:
            n = out[_TX_BYTES]
            return (n, out[_FLAGS], bytes(self._host_view[:n]),
                    bytes(self._lisp_view) if out[_LISP] else None)
        if rc == _LS_GONE:
            return None
        if rc == _LS_BIG:
            return out[_TX_BYTES], out[_FLAGS], None, None
        self._raise(rc, frame)

    def micro(self) -> tuple:
        """The FMU part of the frame after host(): (truth rows, firmware bytes, bytes of them
        written to the pty) of the first chunk, then of the second (b"", b"", 0 without
        one). Raises CouplerError (an FMU failed: the outputs of a first chunk that completed
        are in the error's `done`) or OSError (a pty write failed)."""
        rc = self._micro_call(self._handle)
        out = self._out_view
        tx1, rows1 = out[_TX1], out[_ROWS1]
        first = (bytes(self._rows_view[:rows1 * self._row_bytes]), bytes(self._tx_view[:tx1]),
                 out[_WROTE1])
        if rc == _LS_OK:
            rows2 = out[_ROWS2]
            return first + (bytes(self._rows_view[rows1 * self._row_bytes:(rows1 + rows2) * self._row_bytes]),
                            bytes(self._tx_view[tx1:tx1 + out[_TX2]]), out[_WROTE2])
        if rc == _LS_COSIM:
            err = self._coupler._error(ctypes.c_int64(out[_ERRNO]).value)
            err.done = first if out[_DETAIL] == 2 else None
            raise err
        self._raise(rc, None)

    def _raise(self, rc: int, frame):
        """Raise the error of result `rc` as the Python path would."""
        import os

        from navkit.sim.links import Port

        out = self._out_view
        if rc == _LS_TIMEOUT:
            raise self._lock.no_done(frame)
        if rc == _LS_MAGIC:
            self._lock.check_done(frame, out[_DETAIL], frame)
        if rc == _LS_FRAME:
            from navkit.sim.links import DONE_MAGIC

            self._lock.check_done(frame, DONE_MAGIC, out[_DETAIL])
        if rc == _LS_SHORT:
            raise Port.short_read(out[_DETAIL], out[_TX_BYTES], self._read_wait_s)
        if rc == _LS_RCOMM:
            raise self._rcomm_failed()
        e = out[_ERRNO]
        raise OSError(e, os.strerror(e))

    def times_s(self) -> tuple[float, float, float]:
        """Wall s so far in the host (tick -> done), the pty and the FMUs."""
        out = self._out_view
        return out[_NS_HOST] / 1e9, out[_NS_PTY] / 1e9, out[_NS_FMUS] / 1e9

    def waits(self) -> tuple[int, int]:
        """Reads of the host's bytes so far that found them not there yet, and of those the
        reads that slept (lockstep.h LOCKSTEP_SPIN_NS)."""
        return self._out_view[_WAITS], self._out_view[_SLEEPS]

    def close(self) -> None:
        """Frees the native driver (the coupler, socket and pty stay their owners')."""
        if getattr(self, "_l", None):
            self._lib.lockstep_free(self._l)
            self._l = None

    def __del__(self):
        self.close()
