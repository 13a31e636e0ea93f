"""`python -m implicitize.batch` on Dask: the manifest and files of `implicitize batch` on a
LocalCluster, and on a loopback cluster that loses a worker mid-batch."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import implicitize

DASK = Path(sys.executable).with_name("dask")


def folder(tmp_path: Path, triceratops: Path, copies: int, bad: bool) -> Path:
    lib = tmp_path / "library"
    lib.mkdir()
    for i in range(copies):
        shutil.copy(triceratops, lib / f"mesh-{i:02}.obj")
    if bad:
        (lib / "broken.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
        (lib / "unreadable.ply").symlink_to(tmp_path / "nowhere.ply")
    return lib


def manifest(out: Path):
    return [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()]


def without_seconds(entries):
    return [{k: v for k, v in e.items() if k != "seconds"} for e in entries]


def python_batch(*args):
    return subprocess.run(
        [sys.executable, "-m", "implicitize.batch", "--quiet", *map(str, args)],
        capture_output=True,
        text=True,
    )


def test_local_cluster_writes_the_rust_batch_manifest_and_files(tmp_path, run, triceratops):
    lib = folder(tmp_path, triceratops, copies=2, bad=True)
    rust, dask = tmp_path / "rust", tmp_path / "dask"
    assert run("batch", lib, "-o", rust, "--resolution", 40, "--sdf", check=False).returncode == 1
    done = python_batch(lib, "-o", dask, "--resolution", 40, "--sdf", "--workers", 2)
    assert done.returncode == 1, done.stderr
    assert "2 of 4 meshes failed" in done.stderr
    assert without_seconds(manifest(dask)) == without_seconds(manifest(rust))
    failed = [e for e in manifest(dask) if e["status"] == "failed"]
    assert [e["name"] for e in failed] == ["broken", "unreadable"]
    assert all(e["error"].startswith(e["input"]) for e in failed)
    for name in ["mesh-00.imp", "mesh-01.imp", "mesh-00.sdf.npy", "mesh-01.report.json"]:
        if name.endswith("report.json"):
            ours, theirs = (json.loads((d / name).read_text()) for d in (dask, rust))
            assert ours.keys() == theirs.keys()
        else:
            assert (dask / name).read_bytes() == (rust / name).read_bytes(), name


def wait_for(condition, what, timeout=120.0):
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.05)


def test_cluster_loses_a_worker_and_no_mesh(tmp_path, triceratops):
    lib = folder(tmp_path, triceratops, copies=12, bad=False)
    out = tmp_path / "out"
    address_file = tmp_path / "scheduler.json"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    processes = []
    try:
        processes.append(
            subprocess.Popen(
                [DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                 "--scheduler-file", address_file],
                **quiet,
            )
        )
        wait_for(address_file.exists, "the scheduler")
        address = json.loads(address_file.read_text())["address"]
        workers = [
            subprocess.Popen(
                [DASK, "worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                 "--name", f"worker-{i}"],
                **quiet,
            )
            for i in range(2)
        ]
        processes += workers
        from dask.distributed import Client

        with Client(address) as client:
            client.wait_for_workers(2, timeout=120)
            victim = next(
                a for a, w in client.scheduler_info()["workers"].items()
                if w["name"] == "worker-0"
            )
            driver = subprocess.Popen(
                [sys.executable, "-m", "implicitize.batch", "--quiet", lib, "-o", out,
                 "--resolution", "72", "--scheduler", address],
                stderr=subprocess.PIPE,
                text=True,
            )
            processes.append(driver)
            wait_for(lambda: out.is_dir() and any(out.glob("*.entry.json")), "a first mesh")
            # Killed while it holds a conversion (one thread: it is running it), which the
            # scheduler must then hand to the other worker.
            wait_for(lambda: client.processing([victim])[victim], "a task on the victim")
            finished = len(list(out.glob("*.entry.json")))
            assert finished < 12, "the worker is killed mid-batch"
            workers[0].send_signal(signal.SIGKILL)
        _, stderr = driver.communicate(timeout=600)
        assert driver.returncode == 0, stderr
    finally:
        for process in processes:
            if process.poll() is None:
                process.kill()
                process.wait()
    entries = manifest(out)
    assert sorted(e["input"] for e in entries) == sorted(str(p) for p in lib.glob("*.obj"))
    assert all(e["status"] == "ok" for e in entries)
    for e in entries:
        implicitize.load(out / f"{e['name']}.imp")
        reported = json.loads((out / f"{e['name']}.report.json").read_text())["max_error_voxels"]
        assert np.float32(reported) == np.float32(e["max_error_voxels"])  # E is an f32
