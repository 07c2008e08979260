"""The start kit built once into a cache folder outside any checkout, for this interpreter.

The kit's ``lifelong`` embeds the Python it is built against, and that Python must be the
one this package is installed for. :func:`build_kit` builds it out of source (the kit's
folder is only read: ``cmake -S KIT -B CACHE/build -DCMAKE_BUILD_TYPE=Release
-DBUILD_TESTS=OFF -DPYTHON_EXECUTABLE=<the base interpreter of this environment>``, then
``make lifelong MAPF``) into :func:`cache_folder`: ``$XDG_CACHE_HOME`` (else
``~/.cache``) ``/warehouse_phys/startkit-<kit version>-<python tag>-<key>``, the key a hash
of the kit's path, its sources' contents and the interpreter, so that another kit or
interpreter gets a build of its own and an unchanged one is built once (copied again,
its files' times new, it is still the same). A lock file keeps two
processes from building one folder at once; a build that fails leaves its log
(``build.log``) and no binary.

What is missing is said in one line (:class:`KitBuildError`): ``cmake``, ``make`` or a
C++ compiler not on ``PATH``, or, from CMake's own complaint, Boost, pybind11 or the
Python headers (on Debian: ``apt-get install cmake g++ libboost-program-options-dev
libboost-system-dev libboost-filesystem-dev libboost-log-dev pybind11-dev python3-dev``,
the kit's ``apt.txt``).
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

#: The kit's build targets: the simulator and the ``MAPF`` Python module.
TARGETS = ("lifelong", "MAPF")
#: The kit's Debian packages (its ``apt.txt``, with a compiler and make).
DEBIAN_PACKAGES = (
    "cmake", "make", "g++", "libboost-program-options-dev", "libboost-system-dev",
    "libboost-filesystem-dev", "libboost-log-dev", "pybind11-dev", "python3-dev",
)  # fmt: skip
#: CMake's complaints and what they mean is missing.
_MISSING = (
    ("Boost", "Boost (libboost-program-options-dev, -system-dev, -filesystem-dev, -log-dev)"),
    ("pybind11", "pybind11 (pybind11-dev, or pip install pybind11)"),
    ("Python", "the Python headers (python3-dev)"),
)


class KitBuildError(RuntimeError):
    """The kit could not be built, in one line: what is missing, or where the log is."""


class NotAKitError(KitBuildError, ValueError):
    """A folder that is not a start kit's source, in one line."""


@dataclass(frozen=True)
class KitBuild:
    """A built kit: its source folder and its build folder's ``lifelong``."""

    kit: Path
    folder: Path

    @property
    def lifelong(self) -> Path:
        return self.folder / "build" / "lifelong"

    @property
    def mapf_module(self) -> Path | None:
        """The kit's ``MAPF`` extension module (for tests), if built."""
        found = sorted((self.folder / "build").glob("MAPF*.so"))
        return found[0] if found else None


def kit_version(kit: Path) -> str:
    """The kit's version (its ``version.txt``, else ``unknown``)."""
    try:
        return (kit / "version.txt").read_text().split()[0]
    except (OSError, IndexError):
        return "unknown"


def base_interpreter() -> Path:
    """The interpreter this environment's Python is built on (a virtual environment's
    base), whose ``libpython`` the kit embeds."""
    return Path(getattr(sys, "_base_executable", sys.executable)).resolve()


def cache_folder(kit: str | os.PathLike[str]) -> Path:
    """The build folder of ``kit`` for this interpreter (see the module)."""
    kit = Path(kit).resolve()
    digest = hashlib.sha256()
    digest.update(str(kit).encode())
    digest.update(str(base_interpreter()).encode())
    digest.update(sys.version.encode())
    for path in _sources(kit):  # contents, not times: a kit copied again is the same kit
        digest.update(f"{path.relative_to(kit)}:".encode())
        digest.update(hashlib.sha256(path.read_bytes()).digest())
    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    tag = f"py{sys.version_info[0]}{sys.version_info[1]}"
    return root / "warehouse_phys" / f"startkit-{kit_version(kit)}-{tag}-{digest.hexdigest()[:12]}"


def missing_tools() -> list[str]:
    """The build tools not on ``PATH``: ``cmake``, ``make``, a C++ compiler."""
    missing = [tool for tool in ("cmake", "make") if shutil.which(tool) is None]
    if not any(shutil.which(compiler) for compiler in ("c++", "g++", "clang++")):
        missing.append("a C++ compiler (g++)")
    return missing


def build_kit(kit: str | os.PathLike[str], *, jobs: int = 2, quiet: bool = True) -> KitBuild:
    """The kit at ``kit`` built for this interpreter, building it if its cache folder has
    no ``lifelong`` yet (see the module); ``quiet=False`` prints a line before building.

    Raises:
        NotAKitError: one line, for a folder that is not a start kit.
        KitBuildError: one line, for a missing tool or library, or a failed build (naming
            its log).
    """
    kit = Path(kit)
    if not (kit / "CMakeLists.txt").is_file() or not (kit / "src" / "driver.cpp").is_file():
        raise NotAKitError(f"{kit}: not a start kit (no CMakeLists.txt and src/driver.cpp)")
    build = KitBuild(kit.resolve(), cache_folder(kit))
    if build.lifelong.is_file():
        return build
    missing = missing_tools()
    if missing:
        raise KitBuildError(f"cannot build the start kit: {', '.join(missing)} not found "
                            f"(Debian: apt-get install {' '.join(DEBIAN_PACKAGES)})")  # fmt: skip
    build.folder.mkdir(parents=True, exist_ok=True)
    with open(build.folder / "build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # another process may be building it: wait
        if not build.lifelong.is_file():
            if not quiet:
                print(f"building the start kit {kit_version(kit)} into {build.folder} "
                      "(a few minutes, once)", file=sys.stderr, flush=True)  # fmt: skip
            _build(build, jobs)
    return build


def _build(build: KitBuild, jobs: int) -> None:
    """Configure and make the kit into ``build.folder``, its output in ``build.log``."""
    log = build.folder / "build.log"
    configure = ["cmake", "-S", str(build.kit), "-B", str(build.folder / "build"),
                 "-DCMAKE_BUILD_TYPE=Release", "-DBUILD_TESTS=OFF",
                 f"-DPYTHON_EXECUTABLE={base_interpreter()}"]  # fmt: skip
    make = ["make", "-C", str(build.folder / "build"), f"-j{max(1, int(jobs))}", *TARGETS]
    with open(log, "w") as out:
        for command in (configure, make):
            out.write(f"$ {' '.join(command)}\n")
            out.flush()
            done = subprocess.run(command, stdout=out, stderr=subprocess.STDOUT, check=False)
            if done.returncode:
                raise KitBuildError(_why(log, command[0]))


def _why(log: Path, step: str) -> str:
    """One line on a failed build: what CMake said is missing, else where the log is."""
    text = log.read_text(errors="replace")
    if step == "cmake":
        for word, what in _MISSING:
            if (
                f"find_package({word}" in text
                or f"Could NOT find {word}" in text
                or (f"{word}Config.cmake" in text)
            ):
                return f"cannot build the start kit: {what} not found (log: {log})"
    return f"cannot build the start kit: {step} failed (log: {log})"


def _sources(kit: Path) -> list[Path]:
    """The kit's files a build depends on, in a fixed order."""
    found = [kit / "CMakeLists.txt"]
    for folder in ("src", "inc", "default_planner", "python/common"):
        found += sorted(p for p in (kit / folder).rglob("*") if p.is_file())
    return [p for p in found if p.is_file()]
