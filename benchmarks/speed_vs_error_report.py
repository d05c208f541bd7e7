"""Tables and work-precision plots of docs/notes/speed_vs_error.md from the benchmark's results.

    python benchmarks/speed_vs_error.py report

Scores every row of benchmarks/results/speed_vs_error.jsonl against the stored
references (from the run's saved samples when they are on this machine, else
the metrics stored with the row), writes the scores back into the results
file, replaces the generated part of docs/notes/speed_vs_error.md (between its
markers) and draws docs/notes/speed_vs_error_theta.png and _energy.png.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import speed_vs_error as bench

START, END = "<!-- speed-vs-error:start -->", "<!-- speed-vs-error:end -->"
SEED_BASELINE_S = 478.0  # DESIGN.md section 3: the seed tutorial at dt 1 ms, wall s per simulated s
SEED_ORIGINAL = {bench.SEED_FIXED: "dt 0.001", bench.SEED_GAP: "base dt 0.001"}
MARKERS = {"fem": "o", "rigid": "s", "reduced": "D", bench.SEED_FIXED: "x", bench.SEED_GAP: "+"}


def load_rows() -> list[dict]:
    rows = [json.loads(line) for line in bench.RESULTS.read_text().splitlines() if line.strip()]
    refs = {c.name: bench.load_reference(c.name) for c in bench.SCENES}
    for r in rows:
        run = bench.load_signals(r.get("signals", ""))
        ref = refs.get(r["scene"])
        if run is not None and ref is not None:
            r["metrics"] = bench.metrics(run, ref, bench.case_swing_energy(bench.SCENE[r["scene"]]))
    bench.RESULTS.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return rows


def med(values) -> float:
    return float(np.median(values)) if len(values) else math.nan


def is_default(r: dict) -> bool:
    return r["label"] == "default" or SEED_ORIGINAL.get(r["curve"]) == r["label"]


def fmt(x: float, spec: str) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def scene_table(rows: list[dict], scene: str, ref: dict | None) -> list[str]:
    out = [
        "| curve | setting | wall s / sim s, median (min-max) | CPU s / sim s | internal steps "
        "| max theta err before 2nd impact (rad) | max theta err (rad) | RMS theta err (rad) | max gap err (mm) "
        "| rebound peak err (deg) | energy err / swing | penetration (um) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    order = {c: i for i, c in enumerate(bench.curves())}
    for r in sorted(
        (r for r in rows if r["scene"] == scene), key=lambda r: (order.get(r["curve"], 99), med(r["wall_per_sim"]))
    ):
        m = r["metrics"] or {}
        w = r["wall_per_sim"]
        name = f"**{r['label']}**" if is_default(r) else r["label"]
        failed = f" (failed: {r['failed']})" if r["failed"] else ""
        out.append(
            f"| {r['curve']} | {name}{failed} | {med(w):.3g} ({min(w):.3g}-{max(w):.3g}) | {med(r['cpu_per_sim']):.3g} "
            f"| {r['substeps']} | {fmt(m.get('theta_max_early'), '.2e')} | {fmt(m.get('theta_max'), '.2e')} "
            f"| {fmt(m.get('theta_rms'), '.2e')} "
            f"| {fmt(m.get('gap_max', math.nan) * 1e3, '.3f')} "
            f"| {fmt(math.degrees(m.get('rebound_peak_error', math.nan)), '+.3f')} "
            f"| {fmt(m.get('energy'), '.1e')} | {fmt(m.get('penetration', math.nan) * 1e6, '.1f')} |"
        )
    if ref is not None:
        out.append("")
        out.append(
            f"Reference ({ref['meta']['level']}: {ref['meta']['values']}): first rebound peak "
            f"{math.degrees(ref['rebound_peak']):.3f} deg, penetration {bench.penetration(ref) * 1e6:.1f} um, "
            f"energy error {bench.energy_error(ref, ref['meta']['swing_energy']):.1e}."
        )
    return out


def convergence_table() -> list[str]:
    out = [
        "| scene | coarse -> fine | max theta diff before 2nd impact (rad) | max theta diff (rad) "
        "| RMS theta diff (rad) | max gap diff (mm) | rebound peak diff (deg) | penetration coarse / fine (um) "
        "| energy error of coarse | reference wall time (s) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in bench.SCENES:
        ref = bench.load_reference(c.name)
        if ref is None:
            out.append(f"| {c.name} | (no reference yet) | | | | | | | | |")
            continue
        for ch in ref["meta"]["convergence"]:
            early = ch.get(
                "theta_max_early", ch["theta_max"] if len(bench.rebounds(ref["omega"], ref["gap"])) < 2 else math.nan
            )
            out.append(
                f"| {c.name} | {ch['coarse']} -> {ch['fine']} | {fmt(early, '.2e')} | {ch['theta_max']:.2e} "
                f"| {ch['theta_rms']:.2e} "
                f"| {ch['gap_max'] * 1e3:.4f} | {math.degrees(ch['rebound_peak_error']):+.4f} "
                f"| {ch['penetration'] * 1e6:.1f} / {ch['fine_penetration'] * 1e6:.1f} | {ch['energy']:.1e} "
                f"| {ref['meta']['wall_s']:.0f} |"
            )
    return out


def _beaten(pts: list[dict], s: dict, keys: tuple[str, ...], cost: str = "wall_per_sim") -> bool:
    """Whether a point of `pts` is at most as costly as the seed point `s` and at most as wrong in every key."""
    return any(med(p[cost]) <= med(s[cost]) and all(p["metrics"][k] <= s["metrics"][k] for k in keys) for p in pts)


def _yes(ok: bool) -> str:
    return "yes" if ok else "**no**"


def dominance(rows: list[dict]) -> list[str]:
    """For each scene and fidelity: how many seed-scheme points it beats on both wall time and theta error."""
    out = [
        "| scene | fidelity | seed points beaten in wall time (a point of the fidelity at most as slow and at most as "
        "wrong): theta before the 2nd impact | theta, whole run | theta before the 2nd impact and energy "
        "| the same in CPU time: theta before the 2nd impact | theta before the 2nd impact and energy |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in bench.SCENES:
        seeds = [r for r in rows if r["scene"] == c.name and r["curve"].startswith("seed") and r["metrics"]]
        for fid in bench.available_fidelities():
            pts = [r for r in rows if r["scene"] == c.name and r["curve"] == fid and r["metrics"] and not r["failed"]]
            if not pts or not seeds:
                continue

            n = len(seeds)
            counts = [
                sum(_beaten(pts, s, keys, cost) for s in seeds)
                for keys, cost in (
                    (("theta_max_early",), "wall_per_sim"),
                    (("theta_max",), "wall_per_sim"),
                    (("theta_max_early", "energy"), "wall_per_sim"),
                    (("theta_max_early",), "cpu_per_sim"),
                    (("theta_max_early", "energy"), "cpu_per_sim"),
                )
            ]
            out.append(f"| {c.name} | {fid} | " + " | ".join(f"{k} of {n}" for k in counts) + " |")
    return out


def default_table(rows: list[dict]) -> list[str]:
    out = [
        "| scene | fidelity | meant for it (auto rule) | max theta err before 2nd impact (rad) | within 1e-3 rad "
        "| max theta err, whole run (rad) | within 1e-3 rad | energy err / swing | within 1e-3 | wall s / sim s "
        "| CPU s / sim s |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in bench.SCENES:
        for fid in bench.available_fidelities():
            r = next((r for r in rows if r["scene"] == c.name and r["curve"] == fid and r["label"] == "default"), None)
            if r is None or not r["metrics"]:
                continue
            m = r["metrics"]
            out.append(
                f"| {c.name} | {fid} | {'yes' if bench.meant_for(fid, c) else 'no'} | {m['theta_max_early']:.2e} "
                f"| {_yes(m['theta_max_early'] <= bench.THETA_TARGET)} | {m['theta_max']:.2e} "
                f"| {_yes(m['theta_max'] <= bench.THETA_TARGET)} | {m['energy']:.1e} "
                f"| {_yes(m['energy'] <= bench.ENERGY_TARGET)} | {med(r['wall_per_sim']):.3g} "
                f"| {med(r['cpu_per_sim']):.3g} |"
            )
    return out


def plot(rows: list[dict], key: str, ylabel: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    for ax, c in zip(axes.flat, bench.SCENES, strict=False):
        for i, curve in enumerate(bench.curves()):
            # a failed (diverged) run counts with its error up to the failure: a lower bound
            pts = sorted(
                (
                    (med(r["wall_per_sim"]), r["metrics"][key], is_default(r), bool(r["failed"]))
                    for r in rows
                    if r["scene"] == c.name and r["curve"] == curve and r["metrics"]
                ),
                key=lambda p: p[0],
            )
            pts = [p for p in pts if p[1] > 0 and math.isfinite(p[1])]
            if not pts:
                continue
            color = f"C{i}"
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], MARKERS.get(curve, "o"), color=color, alpha=0.6)
            front, best = [], math.inf  # the lower-left envelope: the best error for the time spent
            for p in pts:
                if p[1] < best:
                    front.append(p)
                    best = p[1]
            ax.loglog([p[0] for p in front], [p[1] for p in front], "-", color=color, label=curve)
            for p in pts:
                if p[2]:
                    ax.loglog(p[0], p[1], "*", color=color, ms=14, mec="k")
                if p[3]:
                    ax.loglog(p[0], p[1], "o", mfc="none", mec="r", ms=16)
        ax.set_title(f"{c.name} ({c.t_end:g} s)")
        ax.set_xlabel("wall time per simulated second (s)")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(
        "Work-precision through the FMU (1 ms communication steps); star = default / the seed's own setting;\n"
        "red ring = diverged or failed (error up to then)"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def write_report() -> None:
    rows = load_rows()
    lines = [
        START,
        "",
        "### References and their convergence check",
        "",
        "Each reference is the finest of the levels below, run by `python benchmarks/speed_vs_error.py references` "
        f"(levels {', '.join(f'{lab}: {v}' for lab, v in bench.REFERENCE_LEVELS)}; `default` is the scene's default "
        "FE settings). A row compares a level with the next finer one.",
        "",
    ]
    lines += convergence_table()
    lines += ["", "### Each fidelity's default settings against the targets", ""] + default_table(rows)
    steel = next((r for r in rows if r["scene"] == "steel" and r["curve"] == "fem" and r["label"] == "default"), None)
    if steel is not None:
        w = med(steel["wall_per_sim"])
        lines += [
            "",
            f"fem on steel at default settings: {w:.2f} s wall per simulated second (median of "
            f"{len(steel['wall_per_sim'])}), {SEED_BASELINE_S / w:.0f}x less than the seed baseline's "
            f"{SEED_BASELINE_S:g} s (target: at least 50x, i.e. at most {SEED_BASELINE_S / 50:.2f} s); how the "
            'sweep was run (machine, load, runs per row) is under "How it was measured".',
        ]
    lines += ["", "### Below and left of the seed's schemes?", ""] + dominance(rows)
    for c in bench.SCENES:
        lines += ["", f"### {c.name}: {c.description}, {c.t_end:g} s", ""] + scene_table(
            rows, c.name, bench.load_reference(c.name)
        )
    lines += ["", END]
    text = bench.DOC.read_text() if bench.DOC.exists() else f"{START}\n{END}\n"
    head, _, rest = text.partition(START)
    _, _, tail = rest.partition(END)
    bench.DOC.write_text(head + "\n".join(lines) + tail)
    plot(
        rows,
        "theta_max_early",
        "max |theta - theta_ref| before the 2nd impact (rad)",
        bench.DOC.with_name("speed_vs_error_theta_early.png"),
    )
    plot(
        rows, "theta_max", "max |theta - theta_ref| over the run (rad)", bench.DOC.with_name("speed_vs_error_theta.png")
    )
    plot(rows, "energy", "max |E - E0 - W| / swing energy", bench.DOC.with_name("speed_vs_error_energy.png"))
    print(f"wrote {bench.DOC} and its plots from {len(rows)} rows")
