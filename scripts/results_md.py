"""docs/RESULTS.md: the sections the measurement scripts write (`--write-results`).

Each script owns one or more sections of the file, delimited by `<!-- BEGIN key -->` and
`<!-- END key -->`; writing one replaces the text between its markers and leaves the rest of
the file as it is. A missing file is created with the intro and every section's markers; a
missing section is inserted where the order of SECTIONS puts it. The file is written to a
temporary file beside it and renamed over it, so a reader never sees half a file.

A section holds: a `##` heading; when, at which commit and on which machine it was measured;
the exact command that made it; the table; fixed sentences on how to read it.
"""

import datetime
import os
import platform
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
RESULTS = REPO / "docs" / "RESULTS.md"

# (key, heading, the command that writes it), in the file's order.
SECTIONS = (
    ("accuracy", "Accuracy on the benchmark logs", "scripts/accuracy --write-results"),
    ("sparse", "Accuracy on the sparse logs", "scripts/accuracy --sparse --write-results"),
    ("throughput", "Throughput and memory", "scripts/throughput --write-results"),
    ("lifelong", "Merge, resume and localize", "scripts/lifelong --write-results"),
    ("sweep", "Step-size sweep", "scripts/sweep --write-results"),
    ("simworlds", "Simulated worlds", "scripts/simworlds --write-results"),
    ("live", "Live: the ROS 2 node", "scripts/live --write-results"),
)

INTRO = """# Results

The current figures of polymap on the logs in `../shared/datasets` and on the simulator's
worlds, one section per measurement script. Every section is written by its script
(`--write-results`), never by hand; each states when, at which commit and on which machine it
was measured, and the command that made it. Run the command again to replace the section.

- **Accuracy on the benchmark logs** (`scripts/accuracy`): relation error on Intel, ACES and
  FR079, without and with odometry, beside the published figures of other methods.
- **Accuracy on the sparse logs** (`scripts/accuracy --sparse`): relation error on five
  corrected Radish logs that keep about one scan per metre and carry no odometry.
- **Throughput and memory** (`scripts/throughput`): wall-clock time, scans/s, peak memory and
  per-scan latency of whole `polymap map` processes.
- **Merge, resume and localize** (`scripts/lifelong`): maps of half logs merged, resumed and
  localized in, against the full run.
- **Step-size sweep** (`scripts/sweep`): every K-th scan of each benchmark log, per phase and
  under nuisance variants of the configuration.
- **Simulated worlds** (`scripts/simworlds`): the simulator's worlds over noise seeds, lasers
  and step sizes, against their true trajectories: the maps wrong in silence.
- **Live: the ROS 2 node** (`scripts/live`): recordings played into `polymap ros2` over DDS:
  scan-to-pose latency at 40 Hz, scans kept at 5x real time, accuracy beside the offline run.
"""


def add_arguments(parser):
    """Adds `--write-results` and `--commit` to an argparse parser."""
    parser.add_argument("--write-results", action="store_true",
                        help="besides printing, replace this script's section of "
                        "docs/RESULTS.md (written atomically; the other sections are kept)")
    parser.add_argument("--commit", default=None, metavar="HASH",
                        help="the commit the measured binary was built from, when it is not "
                        "the repository's HEAD (stated in docs/RESULTS.md)")


def _git(*args):
    r = subprocess.run(["git", "-C", str(REPO)] + list(args), capture_output=True, text=True)
    return r.stdout.strip() if r.returncode == 0 else None


def check_commit(commit):
    """The abbreviated hash of `commit` (a commit of the repository); raises ValueError."""
    if commit is None:
        return None
    short = _git("rev-parse", "--short", "--verify", "--quiet", commit + "^{commit}")
    if not short:
        raise ValueError("--commit %s: not a commit of %s" % (commit, REPO))
    return short


def machine():
    """`cpu model, N cores, X GiB RAM, OS` of this machine."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    ram = "RAM unknown"
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                ram = "%.1f GiB RAM" % (int(line.split()[1]) / 1024.0 ** 2)
                break
    except OSError:
        pass
    system = "%s %s" % (platform.system(), platform.release())
    try:
        info = platform.freedesktop_os_release()
        system = "%s, %s kernel %s" % (info.get("PRETTY_NAME", info.get("NAME", "")),
                                       platform.system(), platform.release())
    except (OSError, AttributeError):
        pass
    return "%s, %d cores, %s, %s" % (cpu, os.cpu_count() or 0, ram, system)


def command_line(argv=None):
    """The command as run, with the script named by its path in the repository."""
    argv = list(sys.argv if argv is None else argv)
    script = Path(argv[0]).resolve()
    try:
        argv[0] = str(script.relative_to(REPO))
    except ValueError:
        pass
    return shlex.join(argv)


class Stamp:
    """When, at which commit and on which machine: taken when the measurements start."""

    def __init__(self, commit=None):
        self.when = datetime.datetime.now(datetime.timezone.utc)
        self.head = _git("rev-parse", "--short", "HEAD") or "unknown"
        self.commit = check_commit(commit)
        status = _git("status", "--porcelain", "--untracked-files=no", "--", "crates")
        self.dirty = status.splitlines() if status else []
        self.machine = machine()
        self.command = command_line()

    def line(self):
        when = self.when.strftime("%Y-%m-%d %H:%M")
        if self.commit and self.commit != self.head:
            commit = "commit %s (the binary's, as given with `--commit`; HEAD was %s)" % (
                self.commit, self.head)
        else:
            commit = "commit %s" % self.head
        text = "Measured on %s (UTC) at %s on %s." % (when, commit, self.machine)
        if self.commit:
            pass  # the binary's commit is given: the working tree's state says nothing of it
        elif self.dirty:
            text += (" When measured, the working tree had uncommitted changes under crates/ "
                     "(%d file%s)." % (len(self.dirty), "" if len(self.dirty) == 1 else "s"))
        else:
            text += " When measured, the working tree had no uncommitted changes under crates/."
        return text


def heading(key):
    for k, title, _ in SECTIONS:
        if k == key:
            return title
    raise KeyError(key)


def section(key, stamp, body, explanation=(), failed=()):
    """The text of a section: heading, stamp, command, body (markdown), explanation."""
    parts = ["## " + heading(key), stamp.line(), "Made by: `%s`" % stamp.command]
    if failed:
        parts.append("**Failed:** %s (the rows of these runs are missing; see the script's "
                     "standard error)." % ", ".join(failed))
    if body:
        parts.append(body.strip("\n"))
    parts.extend(p.strip("\n") for p in explanation if p)
    return "\n\n".join(parts)


def write_incomplete(key, stamp, table, failure, explanation=()):
    """Writes section `key` for a measurement stopped by a failed run: the lines of `table`
    done so far (none when only its header was), the failure's first line, and
    `explanation`."""
    body = "\n".join(table) if len(table) > 2 else ""
    first = failure.strip().splitlines()[0] if failure.strip() else "unknown"
    body += ("\n\n**Incomplete:** the measurement stopped when a run failed (`%s`); the rows "
             "after the last one above are missing." % first.replace("`", "'"))
    write_section(key, section(key, stamp, body.strip("\n"), explanation))


def _markers(key):
    return "<!-- BEGIN %s -->" % key, "<!-- END %s -->" % key


def _placeholder(key):
    for k, title, command in SECTIONS:
        if k == key:
            return "## %s\n\nNot measured yet: `%s` writes this section." % (title, command)
    raise KeyError(key)


def _block(key, text):
    begin, end = _markers(key)
    return "%s\n%s\n%s" % (begin, text.strip("\n"), end)


def new_file():
    return INTRO + "\n" + "\n\n".join(_block(k, _placeholder(k)) for k, _, _ in SECTIONS) + "\n"


def replace_section(document, key, text):
    """`document` with the section `key` replaced by `text` (inserted when missing)."""
    begin, end = _markers(key)
    i = document.find(begin)
    j = document.find(end, i + len(begin)) if i >= 0 else -1
    if i >= 0 and j >= 0:
        return document[:i] + _block(key, text) + document[j + len(end):]
    if i >= 0 or document.find(end) >= 0:
        raise ValueError("%s: the markers of section %s are unpaired" % (RESULTS, key))
    keys = [k for k, _, _ in SECTIONS]
    for later in keys[keys.index(key) + 1:]:
        at = document.find(_markers(later)[0])
        if at >= 0:
            return document[:at] + _block(key, text) + "\n\n" + document[at:]
    return document.rstrip("\n") + "\n\n" + _block(key, text) + "\n"


def write_section(key, text, path=RESULTS):
    """Replaces section `key` of `path` with `text`, atomically (temporary file + rename)."""
    path = Path(path)
    document = path.read_text(encoding="utf-8") if path.is_file() else new_file()
    document = replace_section(document, key, text)
    _write_atomically(path, document)
    print("wrote section %s of %s" % (key, path), file=sys.stderr, flush=True)


README = REPO / "README.md"
README_BEGIN = "<!-- BEGIN results: written by scripts/accuracy --write-results -->"
README_END = "<!-- END results -->"


def write_readme_table(text, path=README):
    """Replaces the results table of README.md (between README_BEGIN and README_END)."""
    path = Path(path)
    document = path.read_text(encoding="utf-8")
    i = document.find(README_BEGIN)
    j = document.find(README_END, i + len(README_BEGIN)) if i >= 0 else -1
    if i < 0 or j < 0:
        raise ValueError("%s: no results markers (%s … %s)" % (path, README_BEGIN, README_END))
    document = (document[:i] + README_BEGIN + "\n" + text.strip("\n") + "\n" +
                document[j:])
    _write_atomically(path, document)
    print("wrote the results table of %s" % path, file=sys.stderr, flush=True)


def _write_atomically(path, document):
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + path.name + ".", dir=str(path.parent))
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(document)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
