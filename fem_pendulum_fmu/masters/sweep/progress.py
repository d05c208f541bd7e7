"""The sweep's progress bar: samples done, failed and remaining, on one line (tqdm)."""

from __future__ import annotations

from typing import Any


class Progress:
    """Counts finished samples; `enabled=False` counts without drawing (tests, logs)."""

    def __init__(self, total: int, enabled: bool = True) -> None:
        self.total, self.done, self.failed = total, 0, 0
        self._bar: Any = None
        if enabled and total:
            from tqdm import tqdm

            self._bar = tqdm(total=total, unit="sample", desc="sweep")
            self._show()

    @property
    def remaining(self) -> int:
        return self.total - self.done - self.failed

    def _show(self, refresh: bool = True) -> None:
        self._bar.set_postfix_str(f"done {self.done}, failed {self.failed}, remaining {self.remaining}", refresh)

    def finished(self, ok: bool) -> None:
        """One sample finished, with status ok or not."""
        if ok:
            self.done += 1
        else:
            self.failed += 1
        if self._bar is not None:
            self._show(refresh=False)  # drawn once, by update, with the new counts
            self._bar.update(1)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
