"""Running `polymap` from the measurement scripts that judge many runs at once (`scripts/sweep`,
`scripts/simworlds`): a command's output, when a run misses its mark, and whether its warnings
say where.
"""

import re
import subprocess
import sys

# A run whose mean error (relation error on a log, ATE on a simulated world) is above this
# misses its mark, metres: the dense benchmark runs' relation error is 0.026-0.045 m, the
# sweep's rows within their spread stay below it, and so does every run of the simulated worlds
# whose scans observe the robot's motion throughout (hallway45, hex60, clutter, office, moved:
# ATE at most 0.089 m over their seeds, lasers and step sizes).
MISS_M = 0.1

# A warning of `polymap map` that names where the map may be wrong: scans by number (lost
# scans, weak stretches, the travel observed by few points, steps off the log's odometry,
# stalls short of it, gaps in the log, walls drawn twice, walls seen through at the end).
PLACED = re.compile(r"polymap: warning: .*\b(scans? \d+|the scans after them: \d+)")


def log(msg):
    """Progress, to standard error."""
    print(msg, file=sys.stderr, flush=True)


def run(cmd, allow=None, stderr=False):
    """A command's standard output (with `stderr`, and its standard error); None when it failed
    with `allow` in its standard error; exits on any other failure."""
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        if allow and allow in r.stderr:
            return None
        raise SystemExit(f"failed: {' '.join(map(str, cmd))}\n{r.stderr.strip()}")
    return (r.stdout, r.stderr) if stderr else r.stdout


def placed(stderr):
    """Whether a run's standard error holds a warning that names scans."""
    return any(PLACED.search(line) for line in stderr.splitlines())


def inconsistent(summary):
    """Whether a run's summary.json (parsed) calls the map likely inconsistent or finds its
    walls drawn twice (`map_consistency`)."""
    consistency = summary.get("map_consistency") or {}
    return bool(consistency.get("likely_inconsistent", False)
                or consistency.get("walls_drawn_twice", False))


def emit(table, line):
    """Prints a line of a table and keeps it (in `table`) for docs/RESULTS.md."""
    table.append(line)
    print(line, flush=True)
