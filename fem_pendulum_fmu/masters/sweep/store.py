"""A sweep's output folder: what is done, one file per finished sample while it runs, two tables at the end.

    OUT/sweep.json        the settings every sample shares (stop time, step, outputs, the FMU's sha256;
                          a loop sweep's: also the controller FMU's sha256, the wiring, the drive limit)
    OUT/parts/ID.json     a finished sample's row, written when its result arrives (last, as the marker)
    OUT/parts/ID.parquet  its time series
    OUT/results.parquet   one row a sample (and results.csv on request)
    OUT/series.parquet    every sample's time series, a column sample_id saying whose

Resuming is reading the folder: a sample whose id is in results.parquet or has
a part is done. Each part is written to a temporary name and renamed, so a
sweep killed at any moment leaves whole parts; consolidation merges them into
the two tables (replacing, not repeating, a sample already there: retried
errors, or a consolidation itself interrupted) and only then deletes them.
A folder holds samples of one set of settings: a restart with others is refused.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

SETTINGS, RESULTS, SERIES, PARTS = "sweep.json", "results.parquet", "series.parquet", "parts"


def _atomic(path: Path, write: Any) -> None:
    """Call write(temporary path), then rename it to `path`: readers see the old file or the whole new one."""
    tmp = path.with_name(path.name + ".tmp")
    write(tmp)
    os.replace(tmp, path)


def check_settings(out: Path, settings: dict[str, Any]) -> None:
    """Record the sweep's settings in a new folder, or check that a restart uses the folder's own (every
    key of either: an open-loop sweep does not resume a loop sweep's folder, nor the other way round)."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / SETTINGS
    if path.is_file():
        held = json.loads(path.read_text())
        differ = [
            f"{key}: {held.get(key)!r} there, {settings.get(key)!r} now"
            for key in {**held, **settings}
            if held.get(key) != settings.get(key)
        ]
        if differ:
            raise ValueError(
                f"{out} holds a sweep with other settings ({'; '.join(differ)}): "
                "use another output folder, or the same settings to resume it"
            )
        return
    _atomic(path, lambda tmp: tmp.write_text(json.dumps(settings, indent=1)))


def read_results(out: Path) -> pd.DataFrame:
    """The consolidated results table (empty if there is none yet)."""
    path = out / RESULTS
    return pd.read_parquet(path) if path.is_file() else pd.DataFrame({"sample_id": [], "status": []})


def done_ids(out: Path, retry_failed: bool = False) -> set[str]:
    """Samples this folder already holds (with retry_failed, those that ended with status ok only)."""
    table = read_results(out)
    parts = [json.loads(p.read_text()) for p in sorted((out / PARTS).glob("*.json"))]
    rows = pd.concat([table[["sample_id", "status"]], pd.DataFrame(parts, columns=["sample_id", "status"])])
    if retry_failed:
        rows = rows[rows["status"] == "ok"]
    return set(rows["sample_id"])


def series_table(sample_id: str, series: np.ndarray) -> pa.Table:
    columns = {"sample_id": pa.array([sample_id] * len(series), pa.string())}
    columns.update({name: pa.array(np.ascontiguousarray(series[name])) for name in series.dtype.names or ()})
    return pa.table(columns)


def write_part(out: Path, row: dict[str, Any], series: np.ndarray | None) -> None:
    """Keep one finished sample: its series first, its row last (a row means the sample is whole)."""
    parts = out / PARTS
    parts.mkdir(parents=True, exist_ok=True)
    sample_id = row["sample_id"]
    if series is not None:
        table = series_table(sample_id, series)
        _atomic(parts / f"{sample_id}.parquet", lambda tmp: pq.write_table(table, tmp))
    _atomic(parts / f"{sample_id}.json", lambda tmp: tmp.write_text(json.dumps(row)))


def _merge_series(out: Path, new: list[Path], replaced: set[str]) -> None:
    """series.parquet := its rows of samples not in `replaced`, then the new parts' rows, row group by row group
    (a large sweep's series never has to fit in memory at once)."""
    old = out / SERIES
    tmp = old.with_name(old.name + ".tmp")
    writer: pq.ParquetWriter | None = None

    def write(table: pa.Table) -> None:
        nonlocal writer
        writer = writer or pq.ParquetWriter(tmp, table.schema)
        writer.write_table(table)

    try:
        if old.is_file():
            held = pq.ParquetFile(old)
            drop = pa.array(sorted(replaced), pa.string())
            for index in range(held.num_row_groups):
                group = held.read_row_group(index)
                write(group.filter(pc.invert(pc.is_in(group["sample_id"], value_set=drop))))
        for path in new:
            write(pq.read_table(path))
    finally:
        if writer is not None:
            writer.close()
    if writer is not None:
        os.replace(tmp, old)


def consolidate(out: Path, csv: bool = False) -> pd.DataFrame:
    """Merge the parts into results.parquet and series.parquet (and results.csv), delete them; the table."""
    parts = out / PARTS
    rows = [json.loads(p.read_text()) for p in sorted(parts.glob("*.json"))]
    new_ids = {row["sample_id"] for row in rows}
    table = read_results(out)
    if rows:
        _merge_series(
            out, [parts / f"{i}.parquet" for i in sorted(new_ids) if (parts / f"{i}.parquet").is_file()], new_ids
        )
        kept = table[~table["sample_id"].isin(new_ids)]
        table = pd.concat([kept, pd.DataFrame(rows)], ignore_index=True) if len(kept) else pd.DataFrame(rows)
        _atomic(out / RESULTS, lambda tmp: table.to_parquet(tmp, index=False))
        for path in sorted(parts.iterdir()):
            path.unlink()
        parts.rmdir()
    if csv:
        _atomic(out / "results.csv", lambda tmp: table.to_csv(tmp, index=False))
    return table


def read_series(out: Path, sample_id: str) -> pd.DataFrame:
    """One sample's time series from series.parquet (columns time and the recorded outputs)."""
    frame = pd.read_parquet(out / SERIES, filters=[("sample_id", "==", sample_id)])
    return frame.drop(columns="sample_id").reset_index(drop=True)
