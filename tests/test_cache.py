"""The disk cache of meshes and precomputed data (cache.py)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fem_pendulum_fmu.physics import cache
from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.scene import stiff

WRITER = str(Path(__file__).resolve().parent / "cache_writer.py")


def test_entry_is_built_once_and_reused(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV, str(tmp_path))
    calls = []
    first = cache.load_or_build_json("demo", {"a": 1}, lambda: calls.append(1) or [1.5, 2.5])
    again = cache.load_or_build_json("demo", {"a": 1}, lambda: calls.append(1) or [9.0])
    other = cache.load_or_build_json("demo", {"a": 2}, lambda: calls.append(1) or [3.0])
    assert first == again == [1.5, 2.5] and other == [3.0] and len(calls) == 2
    assert len(list(tmp_path.iterdir())) == 2


def test_cache_off_and_unwritable_folder_still_build(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV, "off")
    assert cache.load_or_build_json("demo", {"a": 1}, lambda: [4.0]) == [4.0]
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv(cache.ENV, str(blocker / "sub"))
    assert cache.load_or_build_json("demo", {"a": 1}, lambda: [5.0]) == [5.0]


def test_processes_sharing_the_cache_never_see_a_partial_entry(tmp_path):
    env = {**os.environ, cache.ENV: str(tmp_path)}
    procs = [subprocess.Popen([sys.executable, WRITER], env=env, stdout=subprocess.PIPE, text=True) for _ in range(4)]
    sizes = [int(p.communicate()[0].strip()) for p in procs]
    assert sizes == [1024000] * 4
    assert [f.name for f in tmp_path.iterdir()] == [cache.entry_name("race", {"n": 1}, ".bin")]


@pytest.mark.slow
def test_cached_mesh_gives_bit_identical_results(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV, str(tmp_path))
    cold = [create(stiff()).advance(0.02, 0.1).theta for _ in range(2)]
    monkeypatch.setenv(cache.ENV, "off")
    off = create(stiff()).advance(0.02, 0.1).theta
    assert cold[0] == cold[1] == off
    assert any(f.suffix == ".vol" for f in tmp_path.iterdir())
    assert np.isfinite(off)


def test_bytes_entries_round_trip_an_npz(tmp_path, monkeypatch):
    import io

    monkeypatch.setenv(cache.ENV, str(tmp_path))
    calls = []

    def build() -> bytes:
        calls.append(1)
        buf = io.BytesIO()
        np.savez(buf, x=np.linspace(0.0, 1.0, 7))
        return buf.getvalue()

    key = {"mesh_size": 0.03, "order": 2}
    first = cache.load_or_build("modes", key, build)
    again = cache.load_or_build("modes", dict(reversed(key.items())), build)  # key order does not matter
    assert first == again and len(calls) == 1
    assert np.array_equal(np.load(io.BytesIO(again))["x"], np.linspace(0.0, 1.0, 7))
    cache.load_or_build("modes", {**key, "order": 3}, build)
    assert len(calls) == 2
    monkeypatch.setenv(cache.ENV, "off")
    assert cache.load_or_build("modes", key, build) == first and len(calls) == 3


def test_an_entry_of_another_netgen_is_another_entry(monkeypatch):
    """A mesh file netgen 6.2.2608 wrote does not load in netgen 6.2.2604 ('unknown format version'):
    the entry's name carries the versions of the libraries that write and read it."""
    here = cache.entry_name("mesh", {"h": 0.03}, ".vol")
    assert here == cache.entry_name("mesh", {"h": 0.03}, ".vol")
    versions = dict(cache.writer_versions())
    assert versions["netgen-mesher"] != "absent" and versions["ngsolve"] != "absent"
    other = {**versions, "netgen-mesher": versions["netgen-mesher"] + ".other"}
    monkeypatch.setattr(cache, "writer_versions", lambda: other)
    assert cache.entry_name("mesh", {"h": 0.03}, ".vol") != here
