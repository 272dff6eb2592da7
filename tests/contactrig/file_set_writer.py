"""Writer process of ``test_files.py``: replaces a set of files as one, again and again, on a slow disk, until the
test kills it. Usage: ``python file_set_writer.py FOLDER N`` — the set ``head.txt``, ``part-1.txt`` … ``part-N.txt``,
every file of generation ``k`` holding ``k``; or ``python file_set_writer.py FOLDER hold`` — enter a staging folder
and sleep (a live writer)."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from contactrig.core import files


def _slowed(real):  # type: ignore[no-untyped-def]
    def call(*args, **kwargs):  # type: ignore[no-untyped-def]
        time.sleep(0.02)
        return real(*args, **kwargs)

    return call


def main() -> None:
    folder = Path(sys.argv[1])
    if sys.argv[2] == "hold":
        with files.replace_together(folder, [folder / "held.txt"], force=True) as stage:
            (stage / "held.txt").write_text("held")
            print("holding", flush=True)
            time.sleep(600)
        return
    n = int(sys.argv[2])
    for name in ("replace", "link", "unlink"):
        setattr(os, name, _slowed(getattr(os, name)))
    outputs = [folder / "head.txt", *(folder / f"part-{i}.txt" for i in range(1, n + 1))]
    generation = int(os.environ.get("GENERATION", "1"))
    while True:
        with files.replace_together(folder, outputs, force=True) as stage:
            for p in outputs:
                (stage / p.name).write_text(str(generation))
                time.sleep(0.005)
        print(generation, flush=True)
        generation += 1


if __name__ == "__main__":
    main()
