"""Run one command and write its wall time and peak memory to a file, as GNU time's ``-f "%e %M"`` does
(seconds, then kilobytes), so the make targets need no /usr/bin/time (not installed everywhere).

    python scripts/timed.py OUT.txt -- COMMAND [ARGS...]

Exits with the command's status. The peak is the child's ru_maxrss; this small parent's own few MB can show
in it when the child is started by vfork, which does not matter at the sizes these targets measure.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path


def main(argv: list[str]) -> int:
    if len(argv) < 3 or argv[1] != "--":
        print("usage: timed.py OUT.txt -- COMMAND [ARGS...]", file=sys.stderr)
        return 2
    out, command = Path(argv[0]), argv[2:]
    start = time.perf_counter()
    proc = subprocess.Popen(command)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    out.write_text(f"{wall:.2f} {usage.ru_maxrss}\n")
    return os.waitstatus_to_exitcode(status)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
