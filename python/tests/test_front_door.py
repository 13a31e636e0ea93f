"""One front door: the package's defaults, its memory budget and its batch are the library's,
the same as the command line's."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

import implicitize

# The address-space limit of the memory tests: `ulimit -v 3000000` (KiB).
ULIMIT_KIB = 3_000_000


def help_defaults(text: str) -> dict:
    """The `[default: ...]` of each `--flag` in clap's help, its whitespace normalized."""
    found = {}
    blocks = re.split(r"\n(?=\s+(?:-\w, )?--[a-z])", text)
    for block in blocks:
        flag = re.match(r"\s+(?:-\w, )?--([a-z-]+)", block)
        default = re.search(r"\[default: ([^\]]+)\]", block)
        if flag and default:
            found[flag.group(1).replace("-", "_")] = " ".join(default.group(1).split())
    return found


def test_the_cli_help_shows_the_library_defaults(run):
    shown = help_defaults(run("fit", "--help").stdout)
    defaults = implicitize.DEFAULTS
    assert int(shown["resolution"]) == defaults["resolution"]
    assert float(shown["target_error"]) == defaults["target_error"]
    assert int(shown["seed"]) == defaults["seed"]
    assert int(shown["max_iterations"]) == defaults["max_iterations"]
    assert shown["method"] == defaults["method"]
    assert int(shown["max_constraints"]) == defaults["max_constraints"]
    help_text = " ".join(run("fit", "--help").stdout.split())
    assert f"the naive method: {defaults['naive_max_constraints']}," in help_text


def test_the_dask_batch_help_and_the_docstrings_show_the_library_defaults():
    done = subprocess.run(
        [sys.executable, "-m", "implicitize.batch", "--help"], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    text = " ".join(done.stdout.split())
    doc = " ".join(implicitize.fit.__doc__.split())
    # The defaults are the table's, which tests/test_settings.py holds against DEFAULTS.
    for setting in implicitize.FIT_SETTINGS:
        if setting["default"] is not None:
            assert f"(default {setting['default']})" in text, setting["name"]
            assert f"{setting['unit']}; default {setting['default']})" in doc, setting["name"]
    assert "{" not in doc, "every default was filled in"


def test_fit_without_keywords_is_the_cli_fit_without_flags(tmp_path, run, triceratops):
    """Keywords left at None take the library's defaults, as flags left out do."""
    model = implicitize.fit(triceratops, max_iterations=3)
    model.save(tmp_path / "python.json")
    run("fit", triceratops, "--max-iterations", "3", "-o", tmp_path / "cli.json")
    assert (tmp_path / "python.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    grid = json.loads((tmp_path / "cli.json").read_text())["grid"]
    assert max(grid["dims"]) == implicitize.DEFAULTS["resolution"]


def test_only_the_api_is_exported():
    assert sorted(dir(implicitize)) == sorted(implicitize.__all__)
    assert not {"np", "os", "Any", "Optional", "dataclass"} & set(dir(implicitize))


def under_ulimit(code: str) -> subprocess.CompletedProcess:
    """Runs `code` in a Python whose address space is limited as `ulimit -v` limits it."""
    limit = ULIMIT_KIB * 1024
    preamble = f"import resource; resource.setrlimit(resource.RLIMIT_AS, ({limit}, {limit}))\n"
    return subprocess.run(
        [sys.executable, "-c", preamble + code], capture_output=True, text=True, timeout=120
    )


@pytest.mark.parametrize("call", ["fit", "signed_distance", "voxelize"])
def test_a_grid_too_large_is_a_memoryerror_and_the_interpreter_lives_on(triceratops, call):
    done = under_ulimit(
        "import implicitize\n"
        "try:\n"
        f"    implicitize.{call}({str(triceratops)!r}, resolution=4096)\n"
        "except MemoryError as e:\n"
        "    print('refused:', e)\n"
        "print('alive')\n"
    )
    assert done.returncode == 0, done.stderr
    refusal, alive = done.stdout.strip().splitlines()
    assert alive == "alive"
    assert refusal.startswith("refused: ")
    assert "triceratops.obj: a grid of 4096 x " in refusal
    assert "exceeds the memory limit of" in refusal
    assert "(set it with memory_limit)" in refusal
    largest = int(re.search(r"the largest that fits is resolution=(\d+)$", refusal).group(1))
    assert 100 < largest < 4096


def test_a_memory_limit_refuses_polygonizing_and_names_a_resolution_that_fits(triceratops):
    model = implicitize.fit(triceratops, resolution=32, max_iterations=2)
    with pytest.raises(MemoryError) as raised:
        model.to_mesh(resolution=2000, dense=True, memory_limit="1G")
    largest = int(re.search(r"resolution=(\d+)$", str(raised.value)).group(1))
    vertices, faces = model.to_mesh(resolution=largest, memory_limit="1G")
    assert len(faces) > 0
    with pytest.raises(MemoryError):
        implicitize.signed_distance(triceratops, resolution=600, memory_limit=100 << 20)


def test_the_dask_batch_reuses_only_what_is_unchanged(tmp_path, triceratops):
    """A rerun with the same options reuses every mesh; another resolution refits them."""
    lib = tmp_path / "lib"
    lib.mkdir()
    for name in ("a.obj", "b.obj"):
        (lib / name).write_bytes(triceratops.read_bytes())
    out = tmp_path / "out"

    def batch(resolution: str) -> list:
        done = subprocess.run(
            [sys.executable, "-m", "implicitize.batch", str(lib), "-o", str(out),
             "--resolution", resolution, "--workers", "1"],
            capture_output=True, text=True, timeout=300,
        )
        assert done.returncode == 0, done.stderr
        lines = (out / "manifest.jsonl").read_text().splitlines()
        return [json.loads(line) for line in lines]

    assert [e["reused"] for e in batch("32")] == [False, False]
    assert [e["reused"] for e in batch("32")] == [True, True]
    again = batch("36")
    assert [e["reused"] for e in again] == [False, False]
    assert {e["origin"]["options"]["fit"]["resolution"]["longest_axis"] for e in again} == {36}


def test_a_dask_batch_too_large_lists_the_refusal_in_python_words(tmp_path, triceratops):
    out = tmp_path / "out"
    done = subprocess.run(
        [sys.executable, "-m", "implicitize.batch", str(triceratops), "-o", str(out),
         "--resolution", "4096", "--workers", "1", "--memory-limit", "2G"],
        capture_output=True, text=True, timeout=300,
    )
    assert done.returncode == 1
    (entry,) = [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()]
    assert entry["status"] == "failed"
    assert "exceeds the memory limit of 2.0 GB" in entry["error"], entry["error"]
    assert re.search(r"the largest that fits is resolution=\d+$", entry["error"])


def peak_and_estimate(cli, *args) -> tuple:
    """The peak resident memory of `implicitize ARGS` and the memory it estimates beforehand
    (the estimate its refusal under a limit of one byte states), in MB."""
    refused = subprocess.run(
        [str(cli), "--quiet", "--memory-limit", "1", *map(str, args)],
        capture_output=True, text=True,
    )
    match = re.search(r"needs about ([\d.]+) (MB|GB)", refused.stderr)
    assert match, refused.stderr
    estimate = float(match.group(1)) * (1024 if match.group(2) == "GB" else 1)
    # A fresh interpreter, so that the children's peak is this run's alone.
    measure = (
        "import resource, subprocess, sys\n"
        "done = subprocess.run(sys.argv[1:], capture_output=True)\n"
        "assert done.returncode == 0, done.stderr\n"
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", measure, str(cli), "--quiet", *map(str, args)],
        capture_output=True, text=True,
    )
    assert done.returncode == 0, done.stderr
    return int(done.stdout) / 1024, estimate


@pytest.mark.parametrize(
    "command, resolution",
    [("sdf", 96), ("sdf", 256), ("fit", 64), ("fit", 160), ("fit-levels", 512), ("mesh", 256),
     ("mesh", 512), ("mesh-dense", 256), ("mesh-dense", 512)],
)
def test_memory_estimates_are_upper_bounds_of_the_peak(tmp_path, cli, triceratops, command, resolution):
    model = tmp_path / "model.json"
    if command.startswith("mesh"):
        subprocess.run([str(cli), "--quiet", "fit", str(triceratops), "--resolution", "48",
                        "-o", str(model)], check=True)
        dense = ["--dense"] if command == "mesh-dense" else []
        args = ["mesh", model, *dense, "--resolution", resolution, "-o", tmp_path / "m.ply"]
    elif command == "sdf":
        args = ["sdf", triceratops, "--resolution", resolution, "-o", tmp_path / "s.npy"]
    else:
        levels = ["--target-error", "1"] if command == "fit-levels" else []
        args = ["fit", triceratops, "--resolution", resolution, *levels, "-o", model]
    peak, estimate = peak_and_estimate(cli, *args)
    assert peak < estimate, f"{command} at {resolution}: peak {peak:.0f} MB, estimate {estimate:.0f} MB"


def test_thin_walls_are_a_userwarning_naming_a_keyword(triceratops):
    """The triceratops at 48 voxels has a third of its surface on walls about 3 voxels thick:
    fitted, with the warning `fit` prints, its setting worded as Python's keyword."""
    with pytest.warns(UserWarning, match=r"walls about .* voxels thick.*resolution=\d+"):
        implicitize.fit(triceratops, resolution=48, max_iterations=2)
