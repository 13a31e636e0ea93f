"""Batch conversion on Dask distributed: ``python -m implicitize.batch INPUTS... -o OUT_DIR``.

The same conversion, files and ``manifest.jsonl`` as ``implicitize batch`` (one line per mesh,
in input order), with each mesh a Dask task. Without ``--scheduler`` a ``LocalCluster`` of
``--workers`` processes runs on this machine; with ``--scheduler tcp://HOST:PORT`` the tasks go
to an existing cluster (``dask scheduler`` and ``dask worker`` processes; every worker needs
this package installed and the inputs and OUT_DIR at the same paths).

A worker that dies mid-batch loses no mesh: the scheduler runs its tasks again on another
worker. A task that keeps killing its workers (Dask's ``allowed-failures``) is listed as
failed. Every input appears in the manifest exactly once, and a rerun reuses only the meshes
whose outputs are complete and were made from the same input file (size, modification time,
content) and options. Exit status 1 when any mesh failed.

The options and their defaults are the library's, as ``implicitize batch`` takes them. The
memory limit (``--memory-limit``, default the machine's available memory) is shared between
the workers of a LocalCluster; on a running cluster it is each task's.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any, Dict, List, Optional, Sequence

from . import _implicitize


def convert(input: str, name: str, out_dir: str, options: Dict[str, Any]) -> str:
    """Converts one mesh (on a worker); its manifest line, JSON. Never raises for a bad mesh."""
    return _implicitize.batch_convert(input, name, out_dir, **options)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m implicitize.batch",
        description="Fit many meshes on Dask distributed into one folder, with a manifest.",
    )
    parser.add_argument("inputs", nargs="+", help="mesh files, folders, @LIST files")
    parser.add_argument("-o", "--output", required=True, help="the output folder")
    parser.add_argument("--scheduler", help="a Dask scheduler's address (default: a LocalCluster)")
    parser.add_argument("--workers", type=int, help="LocalCluster worker processes (default: CPUs)")
    parser.add_argument("--sdf", action="store_true", help="also write signed distance volumes")
    parser.add_argument(
        "--samples",
        type=int,
        metavar="N",
        help="also write N samples of each mesh's exact signed distance (NAME.samples.npz)",
    )
    parser.add_argument("--quiet", "-q", action="store_true", help="print no progress")
    # The fit's settings, each a flag made from the library's table (FIT_SETTINGS).
    for setting in _implicitize.fit_settings():
        _add_setting(parser, setting)
    parser.add_argument(
        "--memory-limit",
        help="bytes, or a size such as 2G (default: the machine's available memory)",
    )
    return parser


#: How argparse reads a value of each kind of setting (FIT_SETTINGS' ``kind``).
_KIND_ARGUMENTS: Dict[str, Dict[str, Any]] = {
    "count": {"type": int},
    "number": {"type": float},
    "counts3": {"type": int, "nargs": 3},
    "switch": {"action": "store_true"},
    "choice": {},
    "text": {},
}


def _add_setting(parser: argparse.ArgumentParser, setting: Dict[str, Any]) -> None:
    """The flag of a fit setting: its name, value, help and default from the table."""
    default = "" if setting["default"] is None else f" (default {setting['default']})"
    arguments = dict(_KIND_ARGUMENTS[setting["kind"]], help=setting["help"] + default)
    if setting["choices"]:
        arguments["choices"] = setting["choices"]
    if setting["kind"] == "counts3":
        arguments["metavar"] = tuple(setting["value_name"].split())
    elif setting["kind"] != "switch":
        arguments["metavar"] = setting["value_name"]
    parser.add_argument("--" + setting["name"].replace("_", "-"), **arguments)


def _options(args: argparse.Namespace) -> Dict[str, Any]:
    """The keywords of ``batch_convert``: every fit setting given, and the batch's own."""
    names = [setting["name"] for setting in _implicitize.fit_settings()]
    settings = {name: getattr(args, name) for name in names}
    given = {name: value for name, value in settings.items() if value not in (None, False)}
    return dict(given, sdf=args.sdf, samples=args.samples, memory_limit=args.memory_limit)


def _client(scheduler: Optional[str], workers: Optional[int]) -> Any:
    from dask.distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler)
    n = workers or os.cpu_count() or 1
    # Each worker's fits run on a rayon pool of its share of the cores: pools of all the cores
    # in every worker would oversubscribe them (see docs/results.md, batch conversion).
    share = str(max(1, (os.cpu_count() or 1) // n))
    cluster = LocalCluster(
        n_workers=n,
        threads_per_worker=1,
        dashboard_address=None,
        env={"RAYON_NUM_THREADS": share},
    )
    return Client(cluster)


def _shared(options: Dict[str, Any], workers: int) -> Dict[str, Any]:
    """The options of one of ``workers`` workers on this machine: its share of the memory."""
    limit = options.get("memory_limit")
    if limit is None:
        limit = _implicitize.available_memory()
        if limit is None:
            return options
    else:
        limit = _implicitize.parse_size(str(limit))
    return {**options, "memory_limit": max(1, limit // max(1, workers))}


def run(
    inputs: Sequence[str],
    out_dir: str,
    options: Dict[str, Any],
    client: Any,
    quiet: bool = False,
) -> List[str]:
    """Converts every mesh on ``client``'s cluster and writes the manifest; its lines."""
    from dask.distributed import as_completed

    jobs = _implicitize.batch_plan(list(inputs))
    if not jobs:
        raise ValueError(f"no mesh files in {' '.join(inputs)}")
    os.makedirs(out_dir, exist_ok=True)
    # The largest files first, so that no long fit starts last while the other workers idle.
    futures = {
        client.submit(
            convert, input, name, out_dir, options, key=f"implicitize-{i}-{name}", priority=_size(input)
        ): i
        for i, (input, name) in enumerate(jobs)
    }
    lines: List[Optional[str]] = [None] * len(jobs)
    for future in as_completed(futures):
        i = futures[future]
        try:
            lines[i] = future.result()
        except Exception as error:  # the task's workers kept dying: the mesh failed
            lines[i] = _implicitize.batch_failed(*jobs[i], f"{jobs[i][0]}: {error}")
        if not quiet:
            print(lines[i], file=sys.stderr)
    done = [line for line in lines if line is not None]
    summary = _implicitize.batch_manifest(out_dir, done)
    if not quiet:
        for line in summary:
            print(line, file=sys.stderr)
    return done


def _size(path: str) -> int:
    """The file's size in bytes, 0 when it cannot be read (its task then reports why)."""
    try:
        return os.path.getsize(path)
    except OSError:
        return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    """The command line; the exit status."""
    args = _parser().parse_args(argv)
    options = _options(args)
    try:
        _implicitize.batch_plan([])  # the extension loads before a cluster starts
        if not args.scheduler:
            options = _shared(options, args.workers or os.cpu_count() or 1)
        with _client(args.scheduler, args.workers) as client:
            lines = run(args.inputs, args.output, options, client, args.quiet)
    except (OSError, ValueError, MemoryError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    entries = [json.loads(line) for line in lines]
    failed = sum(entry["status"] == "failed" for entry in entries)
    reused = sum(entry.get("reused", False) for entry in entries)
    manifest = os.path.join(args.output, "manifest.jsonl")
    if not args.quiet:
        print(
            f"{len(lines) - failed} of {len(lines)} meshes converted ({reused} reused from an "
            f"earlier run of the same input and options); wrote {manifest}",
            file=sys.stderr,
        )
    if failed:
        print(f"error: {failed} of {len(lines)} meshes failed; see {manifest}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
