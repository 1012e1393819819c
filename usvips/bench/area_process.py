"""The child process that runs one bench area: ``python -m usvips.bench.area_process AREA MODULE SCALE OUT``.

Each row the area's ``benchmarks(scale)`` yields is appended to the file OUT as one JSON line (with its
``area``) as soon as it is made; a failure of the area appends a row naming the area and its error
(:func:`usvips.bench.error_row`); the last line gives the process's CPU seconds and peak resident memory.
Run by :func:`usvips.bench.run_area`; the module is named by its caller, so that the bench's own package
never imports the GUI's.
"""

from __future__ import annotations

import importlib
import json
import os
import resource
import sys
import traceback


def _line(out, record: dict) -> None:
    out.write(json.dumps(record, default=str) + "\n")
    out.flush()


def main(argv: list[str]) -> int:
    area, module_name, scale, path = argv[0], argv[1], float(argv[2]), argv[3]
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from usvips.bench import error_row

    code = 0
    with open(path, "a", encoding="utf-8") as out:
        try:
            module = importlib.import_module(module_name)
            for row in module.benchmarks(scale):
                _line(out, {**row, "area": area})
        except Exception as error:  # any failure of the area is reported as its row, not raised
            where = traceback.extract_tb(error.__traceback__)[-1]
            message = " ".join(f"{type(error).__name__}: {error}".split())[:1500]
            _line(out, error_row(area, f"{message} (at {os.path.basename(where.filename)}:{where.lineno})"))
            traceback.print_exc()
            code = 1
        usage = resource.getrusage(resource.RUSAGE_SELF)
        children = resource.getrusage(resource.RUSAGE_CHILDREN)
        _line(out, {"area_done": area, "cpu_s": usage.ru_utime + usage.ru_stime + children.ru_utime
                    + children.ru_stime, "peak_rss_mb": usage.ru_maxrss / 1024})
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
