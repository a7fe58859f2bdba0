"""navkit.sim.stops.DeferredStops: a stop signal that arrives while the harness's work is held
is recorded, not raised, and acted on by deliver() or at the block's end as the handler
before it would; a blocking call it interrupts carries on; the handlers come back after the
block; in a thread other than the main one nothing is installed. The harness's use of it:
test_can_stop's and test_sim_harden's SIGTERM cases."""

import signal
import socket
import threading

import pytest

from navkit.sim.stops import DeferredStops


def _interrupt(signum, _frame):
    raise KeyboardInterrupt(signum)


@pytest.fixture
def harness_handlers():
    """SIGTERM raises KeyboardInterrupt(SIGTERM), as `navkit sim` sets it; put back after."""
    saved = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGHUP)}
    signal.signal(signal.SIGTERM, _interrupt)
    yield
    for s, h in saved.items():
        signal.signal(s, h)


def test_a_stop_signal_waits_for_deliver(harness_handlers):
    with DeferredStops() as stops:
        signal.pthread_kill(threading.main_thread().ident, signal.SIGTERM)
        for _ in range(1000):       # bytecodes: the Python handler has run by now
            pass
        assert stops.pending == [signal.SIGTERM]
        with pytest.raises(KeyboardInterrupt) as e:
            stops.deliver()
        assert e.value.args == (signal.SIGTERM,)
        assert stops.pending == []
    assert signal.getsignal(signal.SIGTERM) is _interrupt


def test_the_block_end_delivers_and_restores(harness_handlers):
    with pytest.raises(KeyboardInterrupt):
        with DeferredStops():
            signal.pthread_kill(threading.main_thread().ident, signal.SIGTERM)
            for _ in range(1000):
                pass
    assert signal.getsignal(signal.SIGTERM) is _interrupt
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_an_ignored_signal_stays_ignored(harness_handlers):
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    with DeferredStops() as stops:
        signal.pthread_kill(threading.main_thread().ident, signal.SIGHUP)
        for _ in range(1000):
            pass
        assert stops.pending == [signal.SIGHUP]
        stops.deliver()
    assert signal.getsignal(signal.SIGHUP) == signal.SIG_IGN


def test_a_blocking_read_carries_on_through_a_stop(harness_handlers):
    a, b = socket.socketpair()
    with a, b:
        def later():
            signal.pthread_kill(threading.main_thread().ident, signal.SIGTERM)
            b.sendall(b"done")
        timer = threading.Timer(0.05, later)
        with DeferredStops() as stops:
            timer.start()
            got = a.recv(4)         # interrupted by the signal, retried, then the data
            timer.join()
            assert got == b"done" and stops.pending == [signal.SIGTERM]
            stops.pending.clear()


def test_nested_blocks_leave_it_to_the_outer(harness_handlers):
    with DeferredStops() as outer:
        with DeferredStops() as inner:
            signal.pthread_kill(threading.main_thread().ident, signal.SIGTERM)
            for _ in range(1000):
                pass
        assert inner.pending == [] and outer.pending == [signal.SIGTERM]
        outer.pending.clear()


def test_another_thread_installs_nothing(harness_handlers):
    seen = []

    def work():
        with DeferredStops() as stops:
            seen.append((signal.getsignal(signal.SIGTERM), stops.pending))
    t = threading.Thread(target=work)
    t.start()
    t.join()
    assert seen == [(_interrupt, [])]


def test_a_stop_recorded_while_an_error_unwinds_still_lands(harness_handlers):
    with pytest.raises(KeyboardInterrupt) as e:
        with DeferredStops():
            signal.pthread_kill(threading.main_thread().ident, signal.SIGTERM)
            for _ in range(1000):
                pass
            raise RuntimeError("the host broke the lockstep contract")
    assert isinstance(e.value.__context__, RuntimeError)
