"""One of the processes of tests/test_cache.py that write the same cache entry at once.

    python tests/cache_writer.py

writes the entry ("race", {"n": 1}) of the cache folder FEM_PENDULUM_CACHE names, slowly (4 kB at a time),
and prints the size of the file the cache then gives: a process must never see a partial entry.
"""

from __future__ import annotations

import time
from pathlib import Path

from fem_pendulum_fmu.physics import cache


def write(path: Path) -> None:
    data = bytes(range(256)) * 4000
    with open(path, "wb") as f:
        for i in range(0, len(data), 4096):
            f.write(data[i : i + 4096])
            f.flush()
            time.sleep(0.001)


def main() -> None:
    p = cache.cached_file("race", {"n": 1}, ".bin", write)
    assert p is not None, "the cache is off or its folder cannot be written"
    print(len(Path(p).read_bytes()))


if __name__ == "__main__":
    main()
