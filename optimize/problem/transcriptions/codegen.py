"""CasADi functions as compiled C code, cached by the hash of their source.

The C code CasADi generates for a function is compiled once by the system's C compiler
(``$CC``, else ``gcc``, else ``cc``) into a shared library under the user's cache folder
(``$XDG_CACHE_HOME/drivebench/casadi``, default ``~/.cache/drivebench/casadi``), named by
the hash of the source and the compiler command, and loaded with ``casadi.external``.
Each library is kept with the SHA-256 of its bytes (``<library>.sha256``, written after
it): a library whose bytes differ from it (damaged, truncated, replaced by another
function's) or that has none is not loaded; a warning names it and it is compiled again.
Where no compiler is found, the compilation fails, or the cache cannot be used (a folder
that cannot be written, a library that does not load), the function stays as it is (run
by CasADi's virtual machine) and a warning says so, naming the cache.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as ca

from kernel.files import file_sha256, write_text_atomic

log = logging.getLogger(__name__)

#: flags of the compilation (optimized, position-independent, one shared library)
FLAGS = ("-O2", "-fPIC", "-shared")


def compiler() -> str | None:
    """Path of the C compiler: ``$CC``, else ``gcc``, else ``cc``; None when none is found."""
    for name in (os.environ.get("CC"), "gcc", "cc"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def cache_dir() -> Path:
    """Where the compiled libraries are kept."""
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "drivebench" / "casadi"


def compiled(fn: ca.Function) -> ca.Function:
    """``fn`` as a compiled function of the same signature (built once, then loaded from
    the cache; no derivatives); ``fn`` itself, with a warning, when no C compiler is
    found or the compilation fails."""
    cc = compiler()
    if cc is None:
        log.warning("no C compiler found ($CC, gcc, cc): %s runs uncompiled in CasADi's "
                    "virtual machine (slower); install gcc to compile it", fn.name())
        return fn
    gen = ca.CodeGenerator(f"{fn.name()}.c", {"with_header": False})
    gen.add(fn)
    source = gen.dump()
    key = hashlib.sha256((source + cc + " ".join(FLAGS)).encode()).hexdigest()[:20]
    lib = cache_dir() / f"{fn.name()}_{key}.so"
    try:
        why = _unbelieved(lib)
        if why is not None:
            log.warning("the compiled-code cache %s %s: compiled again", lib, why)
        if (why is not None or not lib.exists()) and not _build(cc, fn.name(), source, lib):
            return fn
        return ca.external(fn.name(), str(lib))
    except (OSError, RuntimeError) as exc:  # a cache folder not writable, a damaged library
        log.warning("the compiled-code cache %s cannot be used (%s): %s runs uncompiled "
                    "(slower); remove the file, or set XDG_CACHE_HOME to a writable folder",
                    lib, str(exc).strip().splitlines()[0][:300] if str(exc).strip() else
                    type(exc).__name__, fn.name())
        return fn


def _hash_file(lib: Path) -> Path:
    """Where the SHA-256 of ``lib``'s bytes is kept."""
    return lib.with_name(lib.name + ".sha256")


def _unbelieved(lib: Path) -> str | None:
    """Why the cached library ``lib`` is not to be loaded (its bytes differ from the hash
    recorded at its build, or it has none); None when it is absent or intact."""
    if not lib.exists():
        return None
    recorded = _hash_file(lib)
    if not recorded.is_file():
        return "records no SHA-256 of its build (built by an earlier drivebench, or not by it)"
    if recorded.read_text(encoding="utf-8").strip() != file_sha256(lib):
        return "differs from the SHA-256 recorded at its build (damaged or replaced)"
    return None


def _build(cc: str, name: str, source: str, lib: Path) -> bool:
    """Compile ``source`` into ``lib``; False (with a warning) when the compiler fails."""
    lib.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=lib.parent) as tmp:
        src, out = Path(tmp) / f"{name}.c", Path(tmp) / lib.name
        src.write_text(source, encoding="utf-8")
        run = subprocess.run([cc, *FLAGS, str(src), "-o", str(out), "-lm"],
                             capture_output=True, text=True, check=False)
        if run.returncode != 0:
            log.warning("compiling %s failed (%s); it runs uncompiled: %s", name, cc,
                        run.stderr.strip()[:500])
            return False
        digest = file_sha256(out)
        os.replace(out, lib)  # atomic: a concurrent worker sees all or nothing
    write_text_atomic(_hash_file(lib), digest + "\n")
    log.info("compiled %s into %s", name, lib)
    return True
