"""Shared fixtures of the Python module's tests: the mcvo executable, the
shared real samples, and tiny datasets rendered once per session.

Run by ctest (mcvo_python_test) with PYTHONPATH=build/python, MCVO_BINARY
and MCVO_SHARED_DIR set; by hand:
  PYTHONPATH=build/python /usr/bin/python3 -m pytest -q python/tests
"""

import hashlib
import json
import os
import pathlib
import subprocess

import numpy  # noqa: F401  (missing numpy fails the suite, it does not skip it)
import pytest

import mcvo

SOURCE_DIR = pathlib.Path(os.environ.get("MCVO_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
MCVO_BINARY = pathlib.Path(os.environ.get("MCVO_BINARY", SOURCE_DIR / "build" / "mcvo"))
SHARED_DIR = pathlib.Path(os.environ.get("MCVO_SHARED_DIR", SOURCE_DIR.parent / "shared"))
REAL_DIR = SHARED_DIR / "data" / "real"

# The smallest render that a run poses (mcvo synth --preset mono ...).
TINY_RENDER = dict(preset="mono", frames=12, image_scale=0.25, samples=1, seed=3)
TINY_RENDER_FLAGS = ["--preset", "mono", "--frames", "12", "--image-scale", "0.25", "--samples", "1", "--seed", "3"]

mcvo.set_log_level("warning")


def cli(*args, check=True):
    """Runs the mcvo executable; returns the CompletedProcess (text)."""
    proc = subprocess.run([str(MCVO_BINARY), *map(str, args)], capture_output=True, text=True)
    if check and proc.returncode != 0:
        raise AssertionError(f"mcvo {' '.join(map(str, args))}: exit {proc.returncode}\n{proc.stderr}")
    return proc


def file_hashes(folder, skip=()):
    """Relative path -> SHA-256 of every file under folder, except the names in skip."""
    folder = pathlib.Path(folder)
    hashes = {}
    for path in sorted(folder.rglob("*")):
        rel = path.relative_to(folder).as_posix()
        if path.is_file() and rel not in skip:
            hashes[rel] = hashlib.sha256(path.read_bytes()).hexdigest()
    return hashes


# run.json members that are not the same for the same inputs: how the run was
# called, its wall times, and the program that ran it (python3, not mcvo).
RUN_JSON_VARYING = ("command_line", "timing", "build")


def comparable_run_json(folder):
    with open(pathlib.Path(folder) / "run.json") as f:
        manifest = json.load(f)
    for key in RUN_JSON_VARYING:
        manifest.pop(key, None)
    manifest.get("outputs_sha256", {}).pop("timing.csv", None)
    return manifest


def comparable_outputs(folder):
    return file_hashes(folder, skip=("run.json", "timing.csv")), comparable_run_json(folder)


@pytest.fixture(scope="session")
def work(tmp_path_factory):
    return tmp_path_factory.mktemp("mcvo_python")


@pytest.fixture(scope="session")
def tiny_dataset(work):
    """A tiny render by the executable (the reference the module is compared with)."""
    out = work / "tiny_cli"
    cli("synth", *TINY_RENDER_FLAGS, "--out", out)
    return out


@pytest.fixture(scope="session")
def tiny_cli_run(work, tiny_dataset):
    out = work / "tiny_cli_run"
    cli("run", "--dataset", tiny_dataset, "--out", out)
    return out


@pytest.fixture(scope="session")
def tiny_py_run(work, tiny_dataset):
    return mcvo.run(str(tiny_dataset), out=str(work / "tiny_py_run"))


@pytest.fixture(scope="session")
def real_sample():
    path = REAL_DIR / "kitti00_mono"
    if not path.is_dir():
        pytest.fail(f"{path}: the shared real sample is missing (MCVO_SHARED_DIR)")
    return path
