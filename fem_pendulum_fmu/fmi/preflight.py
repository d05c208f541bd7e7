"""Run by the FMU's binary (fmi/shim) at every fmi2Instantiate, before the FMU imports anything else.

The builder copies this file into each FMU as resources/femp_preflight.py. It
uses the standard library only, so that it can speak when everything else is
missing. `prepare(resources)` does two things and returns the problems as text
("" when there are none):

- forgets the modules of an earlier copy of this FMU whose extraction folder is
  gone (fmpy deletes it after each run): left in sys.modules they would point a
  later run in the same process at deleted files;
- refuses to run where the process has already imported a module this FMU
  ships (fem_pendulum_fmu, pythonfmu, its entry script) from another folder
  with other contents: Python keeps one module per name, so the FMU would
  silently run that copy's code instead of its own (another version of this
  FMU, or the package installed in the host's environment);
- checks resources/requirements.txt against the running interpreter, so that a
  missing or too old package is named with the command that installs it,
  instead of failing later inside the physics.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import os
import re
import sys
from pathlib import Path

REQUIREMENT = re.compile(r"^\s*([A-Za-z0-9_.\-]+)\s*(?:>=\s*([0-9][0-9.]*))?")


def prepare(resources: str) -> str:
    """Problems that stop this FMU from running in this interpreter, as one message ("" if none)."""
    forget_deleted_copies(Path(resources))
    foreign = foreign_copy_problems(Path(resources))
    if foreign:
        return "; ".join(foreign)
    problems = requirement_problems(Path(resources) / "requirements.txt")
    if not problems:
        return ""
    return (
        f"this Python ({sys.executable}) cannot run the FMU: "
        + "; ".join(problems)
        + ". Install what the FMU needs into it with: "
        + install_command(Path(resources) / "requirements.txt")
    )


def shipped_modules(resources: Path) -> set[str]:
    """Top-level module names this FMU's resources folder provides."""
    names = {p.stem for p in resources.glob("*.py")}
    names |= {p.parent.name for p in resources.glob("*/__init__.py")}
    return names


def forget_deleted_copies(resources: Path) -> list[str]:
    """Drop from sys.modules the shipped modules whose files no longer exist; returns their names."""
    shipped = shipped_modules(resources)
    stale_tops = {
        name.partition(".")[0]
        for name, module in list(sys.modules.items())
        if name.partition(".")[0] in shipped and _file_is_gone(module)
    }
    dropped = [name for name in list(sys.modules) if name.partition(".")[0] in stale_tops]
    for name in dropped:
        del sys.modules[name]
    sys.path[:] = [p for p in sys.path if not (Path(p).name == "resources" and not os.path.isdir(p))]
    if dropped:
        importlib.invalidate_caches()
    return dropped


def foreign_copy_problems(resources: Path) -> list[str]:
    """One sentence per shipped module that this process has already imported from another folder whose
    files differ from the shipped ones (the first differing file named); an identical copy is no problem."""
    problems = []
    for name in sorted(shipped_modules(resources) - {"femp_preflight"}):
        loaded = _loaded_from(sys.modules.get(name))
        shipped = resources / name if (resources / name).is_dir() else resources / f"{name}.py"
        if loaded is None or _same_path(loaded, shipped):
            continue
        differing = _first_difference(shipped, loaded, sys.modules[name])
        if differing is not None:
            problems.append(
                f"this process has already imported {name} from {loaded}, which differs from the copy in this "
                f"FMU ({differing}), and Python runs one copy of a module per process: the FMU would run that "
                f"code, not its own. Run the FMU in a process that has not imported {name}, or with the "
                f"{name} it was built from"
            )
    return problems


def _loaded_from(module: object) -> Path | None:
    """The folder of an imported package, the file of an imported module; None if it has no file."""
    file = getattr(module, "__file__", None)
    if not isinstance(file, str) or not file:
        return None
    path = Path(file)
    return path.parent if path.name == "__init__.py" else path


def _same_path(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve()
    except OSError:
        return False


def _first_difference(shipped: Path, loaded: Path, module: object) -> str | None:
    """The first shipped file (relative path) whose copy in `loaded` is missing or differs, or None. The
    verdict is kept on the loaded module, so that a host instantiating many times compares once."""
    verdicts = module.__dict__.setdefault("_femp_compared_with", {})
    key = str(shipped)
    if key not in verdicts:
        verdicts[key] = _compare(shipped, loaded)
    return verdicts[key]


def _compare(shipped: Path, loaded: Path) -> str | None:
    if shipped.is_file():
        return None if _same_bytes(shipped, loaded) else shipped.name
    for file in sorted(shipped.rglob("*")):
        if file.is_dir() or "__pycache__" in file.parts or file.suffix == ".pyc":
            continue
        relative = file.relative_to(shipped)
        if not _same_bytes(file, loaded / relative):
            return str(relative)
    return None


def _same_bytes(a: Path, b: Path) -> bool:
    try:
        return a.read_bytes() == b.read_bytes()
    except OSError:
        return False


def _file_is_gone(module: object) -> bool:
    file = getattr(module, "__file__", None)
    return isinstance(file, str) and file != "" and not os.path.exists(file)


def requirements(path: Path) -> list[tuple[str, tuple[int, ...] | None, str]]:
    """(distribution name, minimum version or None, the line) for each requirement in `path`."""
    found = []
    if path.is_file():
        for line in path.read_text().splitlines():
            match = REQUIREMENT.match(line)
            if match and not line.lstrip().startswith("#"):
                found.append((match.group(1), _version_tuple(match.group(2)) if match.group(2) else None, line.strip()))
    return found


def requirement_problems(path: Path) -> list[str]:
    """One sentence per requirement that is missing, too old or does not import."""
    problems = []
    for name, minimum, line in requirements(path):
        try:
            installed = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            problems.append(f"{name} is not installed (needs {line})")
            continue
        if minimum is not None and _version_tuple(installed) < minimum:
            problems.append(f"{name} {installed} is too old (needs {line})")
            continue
        module = name.replace("-", "_").lower()
        try:
            importlib.import_module(module)
        except Exception as exc:  # a package that is installed but broken (missing shared library, ...)
            problems.append(f"{name} {installed} is installed but does not import ({type(exc).__name__}: {exc})")
    return problems


def install_command(path: Path) -> str:
    specs = " ".join(f'"{line}"' for _, _, line in requirements(path))
    return f"{sys.executable} -m pip install {specs}"


def _version_tuple(text: str) -> tuple[int, ...]:
    return tuple(int(part) for part in re.findall(r"\d+", text)[:3])
