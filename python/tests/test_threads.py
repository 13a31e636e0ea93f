"""Fits release the GIL: two threads fitting at once give the models of two fits one after
the other."""

import threading

import implicitize


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
