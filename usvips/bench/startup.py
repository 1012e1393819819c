"""Start-up: the CPU time (user + system, seconds, of the child process) that ``usvips --help`` and a
subcommand's ``--help`` take, against a bare ``python -c pass`` started the same way in the same run.

CPU time, not wall time, so that a loaded machine does not blur it; the promise is absolute (``target_s``
0.3 s of CPU, issue 27) and the ratio to a bare interpreter is given beside it.
"""

from __future__ import annotations

import resource
import subprocess
import sys
from collections.abc import Iterator

#: the CPU seconds a command-line start may take (``usvips --help``, ``usvips project --help``)
TARGET_CPU_S = 0.3


def child_cpu_s(arguments: list[str], repeats: int = 3) -> float:
    """The least CPU time (s) a child process running ``arguments`` took over ``repeats`` runs."""
    best = float("inf")
    for _ in range(max(1, repeats)):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run(arguments, capture_output=True, check=False)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        best = min(best, after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return best


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    repeats = max(1, round(3 * scale))
    bare = child_cpu_s([sys.executable, "-c", "pass"], repeats)
    for words in (["--help"], ["project", "--help"]):
        cpu = child_cpu_s([sys.executable, "-m", "usvips", *words], repeats)
        yield {"name": f"start-up CPU: usvips {' '.join(words)}", "n": 1, "ours_s": round(cpu, 3),
               "cpu_s": round(cpu, 3),
               "baseline": "python -c pass", "baseline_s": round(bare, 3),
               "ratio": round(cpu / bare, 2) if bare > 0 else None, "target": None, "target_s": TARGET_CPU_S,
               "met": bool(cpu <= TARGET_CPU_S)}
