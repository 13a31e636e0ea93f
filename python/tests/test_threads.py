"""Fits release the GIL: Python runs in other threads while one thread fits, and two threads
fitting at once give the models of two fits one after the other."""

import sys
import threading
import time

import implicitize


def count_until(counter, stop):
    """Counts in counter[0], in pure Python bytecode, until `stop` is set."""
    while not stop.is_set():
        counter[0] += 1


def test_python_runs_in_another_thread_during_a_fit(triceratops):
    """While a fit runs in a second thread, this thread keeps counting in Python. A fit that
    held the GIL would stop the count for the whole call, leaving it only the switch intervals
    (set to a millisecond here) around the call; so the count during the call is converted to
    the seconds this thread would need alone, and compared with the call's duration (some
    hundreds of milliseconds, against a few of switching)."""
    interval = sys.getswitchinterval()
    sys.setswitchinterval(0.001)
    try:
        counter, stop = [0], threading.Event()
        timer = threading.Timer(0.2, stop.set)
        start = time.perf_counter()
        timer.start()
        count_until(counter, stop)
        rate = counter[0] / (time.perf_counter() - start)

        counter, stop, call = [0], threading.Event(), {}

        def fit():
            try:
                before, start = counter[0], time.perf_counter()
                implicitize.fit(triceratops, resolution=80, seed=1)
                call["counted"] = counter[0] - before
                call["seconds"] = time.perf_counter() - start
            finally:
                stop.set()

        thread = threading.Thread(target=fit)
        thread.start()
        count_until(counter, stop)
        thread.join()
    finally:
        sys.setswitchinterval(interval)
    assert "seconds" in call, "the fit failed"
    counting = call["counted"] / rate
    assert counting > 0.1 * call["seconds"], (
        f"this thread counted {counting * 1000:.1f} ms worth during a fit of "
        f"{call['seconds'] * 1000:.0f} ms: the fit holds the GIL"
    )


def test_two_threads_fit_at_once(triceratops):
    seeds = [1, 2]
    results = {}

    def work(seed):
        results[seed] = implicitize.fit(triceratops, resolution=48, seed=seed)

    threads = [threading.Thread(target=work, args=(seed,)) for seed in seeds]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for seed in seeds:
        alone = implicitize.fit(triceratops, resolution=48, seed=seed)
        assert results[seed]._state()[0] == alone._state()[0]
    assert results[1]._state()[0] != results[2]._state()[0]
