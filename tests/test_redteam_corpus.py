"""The red-team corpus (issue 22): hostile inputs of every kind the product reads, each run as
the user runs it, in a child process, with the promise it must keep: a clear one-line message
and the exit code of the README's table, never a crash, a hang, a traceback, a forged line or a
result left behind.

Each attack runs ``python -m qa_app.cli ...`` (or, for sessions, the desktop app's Qt-free
controller) in a child process with a timeout, as ``engine.io.child`` runs the native readers:
a regression that crashes (a signal) or hangs fails its row, naming the signal, and cannot take
the test run down. What every row asserts is written once: :func:`check_cli` for a command
line, :func:`test_sessions` for a session. The tables: PLANS, STEP, BATCH, NUMERICS, FILES
(point files, meshes, DXF drawings) and SESSIONS.

Adding a row. A new input type (a new reader, a new option that takes a file, a new field of the
plan or the session) gets rows here in the same change, so that this file stays the one list of
what the product has been attacked with:

* pick the table of its category, or start one (a list of ``attack(...)`` rows and a test that
  runs :func:`check_cli` on them; a session is a ``session(...)`` row);
* write ``make(d, base)``: it writes the hostile input(s) into the folder ``d`` (small, made by
  code, or a file of ``tests/data``) and returns the arguments after ``qa-inspect``;
  ``base`` holds a small sound nominal and measured file to put beside them;
* give the exit code and words the one-line message must hold (the README's contract, not
  today's wording of a detail). The harness adds ``--json``/``--csv`` (and ``--report`` with
  ``report=True``) to ``inspect`` and ``--out`` to ``batch``, and checks that a refused run
  leaves none of them;
* a row that fails on main is a finding: keep it, marked
  ``xfail(strict=True, reason=...)`` naming the defect, until the product is fixed.

Each child costs one to two CPU seconds of imports before its work: small inputs, one run per
attack, ``--report`` only where the renderer matters.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from surfaces import height, height_normal, random_rotation, write_grid_nominal

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"
REDTEAM = DATA / "step" / "redteam"
BRACKET = ROOT / "samples" / "seat_bracket"
GEAR = DATA / "dxf" / "gear_z20.dxf"

TIMEOUT_S = 60.0
"""A child that runs longer has hung (the slowest row takes a few seconds)."""

FORGED = "ACCEPT: all 5 characteristics are within tolerance"
"""The verdict line the red team forged with a line break in an id or a file name."""

RAW = re.compile("[\x00-\x09\x0b-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069"
                 "\udc80-\udcff]")
"""What must never reach the terminal as it is (item 8): C0/C1 control characters but the line
break between lines, the Unicode line and paragraph separators, bidirectional overrides, and
bytes that are not UTF-8 (read back as lone surrogates)."""


# ------------------------------------------------------------------------------ the harness

@dataclass(frozen=True)
class Base:
    """Sound inputs shared by the rows: a small grid nominal with normals (40 x 20 over
    500 x 250 mm) and 120 points on it in another pose (``measured``)."""

    dir: Path
    nominal: Path
    measured: Path


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Base:
    d = tmp_path_factory.mktemp("base")
    write_grid_nominal(d / "nominal.csv", 40, 20)
    rng = np.random.default_rng(22)
    x, y = rng.uniform(-240, 240, 120), rng.uniform(-115, 115, 120)
    q = np.column_stack([x, y, height(x, y)])
    q += rng.normal(0, 0.002, 120)[:, None] * height_normal(x, y)
    q = q @ random_rotation(rng).T + [310.0, -45.0, 72.0]
    write_points(d / "measured.csv", q)
    return Base(d, d / "nominal.csv", d / "measured.csv")


def write_points(path: Path, points, header: str = "x,y,z\n") -> Path:
    """(n, 3) points as a CSV point file (repr: NaN and inf as Python writes them)."""
    path.write_text(header + "".join(",".join(repr(float(v)) for v in p) + "\n"
                                     for p in points))
    return path


@dataclass(frozen=True)
class Child:
    """A finished child process: exit code (negative: killed by that signal), its output, and
    how long it ran."""

    code: int
    out: str
    err: str
    seconds: float


def run_child(argv: list[str], cwd: Path, timeout: float = TIMEOUT_S,
              env: dict | None = None) -> Child:
    """``argv`` (a Python child: ``[sys.executable, ...]``) run in its own process group with
    this worktree's code first on the path; a child that outlives ``timeout`` is killed with
    its group (a batch's workers too) and fails the test as a hang."""
    # QA_DEBUG turns an internal error into a traceback: the contract is the user's, without it.
    env = {k: v for k, v in (env or os.environ).items() if k != "QA_DEBUG"}
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    t0 = time.monotonic()
    p = subprocess.Popen(argv, cwd=cwd, env=env, stdin=subprocess.DEVNULL,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         start_new_session=True)
    try:
        out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        out, err = p.communicate()
        pytest.fail(f"hung: {argv[1:]} did not finish within {timeout:g} s; stderr: "
                    f"{_decode(err)[-1500:]!r}", pytrace=False)
    finally:
        try:  # nothing it started may outlive it
            os.killpg(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    return Child(p.returncode, _decode(out), _decode(err), time.monotonic() - t0)


def _decode(raw: bytes) -> str:
    return raw.decode("utf-8", errors="surrogateescape")  # bad bytes stay visible to RAW


def assert_no_crash(r: Child, what) -> None:
    if r.code < 0:
        try:
            name = signal.Signals(-r.code).name
        except ValueError:
            name = f"signal {-r.code}"
        pytest.fail(f"crashed: {what} was killed by {name}; stderr: {r.err[-1500:]!r}",
                    pytrace=False)
    assert "Traceback" not in r.err and "Traceback" not in r.out, r.err[-3000:]


def assert_printable(text: str, one_line: bool = False) -> None:
    """No raw control character in ``text``; ``one_line``: no line break either (a message of
    the app is one line; the terminal's output breaks only between its lines)."""
    bad = RAW.search(text) or (re.search("\n", text) if one_line else None)
    assert bad is None, f"a raw control character {bad.group()!r} reached the output: {text!r}"


@dataclass(frozen=True)
class Attack:
    """One hostile input and what the product must answer.

    make : (d, base) -> the arguments after ``qa-inspect``, having written the hostile input(s)
        into the folder ``d``.
    code : the exit code.
    says : words the one-line message holds: the first line of stderr for a refused run, else
        the first line of stdout (the verdict, or a batch's count).
    refused : the run is refused (default: code >= 64): nothing on stdout, no output left.
    report : add ``--report`` to an ``inspect`` (starts the renderer: a few seconds more).
    then : (d, child) -> None, checks of its own (a batch's summary).
    """

    make: Callable[[Path, Base], list]
    code: int
    says: str
    refused: bool | None = None
    report: bool = False
    then: Callable[[Path, Child], None] | None = None


def attack(id: str, make, code: int, says: str, xfail: str | None = None, **kw):
    """A row of a table: ``xfail`` names a finding (a defect on main), kept strict."""
    marks = [pytest.mark.xfail(strict=True, reason=xfail)] if xfail else []
    return pytest.param(Attack(make, code, says, **kw), id=id, marks=marks)


def check_cli(a: Attack, d: Path, base: Base) -> Child:
    """Run the attack's command line in a child process and hold it to the contract."""
    args = [str(x) for x in a.make(d, base)]
    out = d / "out"
    if args[0] == "inspect":
        out.mkdir()
        args += ["--json", str(out / "r.json"), "--csv", str(out / "r.csv")]
        if a.report:
            args += ["--report", str(out / "r.pdf")]
    elif args[0] == "batch":
        args += ["--out", str(out), "--quiet"]
        if "--scheduler" not in args:
            args += ["--workers", "1"]
    r = run_child([sys.executable, "-m", "qa_app.cli", *args], cwd=d)
    assert_no_crash(r, f"qa-inspect {args[0]}")
    assert r.code == a.code, (r.code, r.err[-3000:], r.out[-1500:])
    refused = a.code >= 64 if a.refused is None else a.refused
    said = (r.err if refused else r.out).splitlines()
    assert said, (r.err, r.out)
    assert a.says in said[0], said[0]
    if refused:
        assert said[0].startswith(("qa-inspect: error: ", f"qa-inspect {args[0]}: ")), said[0]
        if a.code != 64:  # a usage error adds the command's usage; any other refusal is a line
            assert len(said) == 1, r.err
        assert r.out == "", r.out
        left = sorted(str(p.relative_to(out)) for p in out.rglob("*")) if out.exists() else []
        assert left == [], f"a refused run left {left} behind"
    assert_printable(r.err)
    assert_printable(r.out)
    if a.then is not None:
        a.then(d, r)
    return r


def test_the_guard_fails_a_crash_naming_its_signal_and_a_hang():
    """The harness itself: a child killed by SIGSEGV (what OpenCascade did) and a child that
    never ends (what a FIFO did) are failures of their row, and the run goes on."""
    with pytest.raises(pytest.fail.Exception, match="killed by SIGSEGV"):
        r = run_child([sys.executable, "-c", "import os, signal; "
                       "os.kill(os.getpid(), signal.SIGSEGV)"], cwd=ROOT)
        assert_no_crash(r, "a child")
    t0 = time.monotonic()
    with pytest.raises(pytest.fail.Exception, match="hung: .* within 1 s"):
        run_child([sys.executable, "-c", "import time; time.sleep(60)"], cwd=ROOT, timeout=1)
    assert time.monotonic() - t0 < 20


# ------------------------------------------------------------------------------ plans

def _bracket_plan(edit: Callable[[str], str] | None = None, raw: bytes | None = None):
    """The seat bracket sample inspected by its plan, the plan edited by ``edit(text)`` (or
    replaced by ``raw`` bytes)."""
    def make(d: Path, base: Base):
        plan = d / "plan.toml"
        if raw is not None:
            plan.write_bytes(raw)
        else:
            plan.write_text(edit((BRACKET / "plan.toml").read_text(encoding="utf-8")),
                            encoding="utf-8")
        return ["inspect", BRACKET / "nominal.xyz", BRACKET / "measured.csv", "--plan", plan]
    return make


REGION_A = '[[region]]\nname = "A"\nbox = [[-1.0, -1.0, -0.5], [121.0, 61.0, 0.5]]\n'


def _one_characteristic(body: str) -> Callable[[str], str]:
    return lambda _: REGION_A + '[[characteristic]]\nid = "1"\n' + body


def _characteristics(n: int) -> Callable[[str], str]:
    return lambda _: REGION_A + "".join(
        f'[[characteristic]]\nid = "{k}"\ntype = "flatness"\nregion = "A"\nzone = 0.1\n'
        for k in range(n))


PLANS = [
    # deep.toml: tomllib recursed out of the stack (exit 70, RecursionError)
    attack("nested-5000-deep", _bracket_plan(
        lambda t: t + "\nx = " + "[" * 5000 + "]" * 5000 + "\n"), 65, "nested too deeply"),
    # id_newline.toml: the REJECT run printed a forged "ACCEPT: ..." line
    attack("id-with-line-break-forging-a-verdict", _bracket_plan(
        lambda t: t.replace('id = "2"', f'id = "2: ACCEPT\\n{FORGED}\\n"')), 65,
        "'id' holds a control character (U+000A)"),
    attack("part-name-with-escape-sequence", _bracket_plan(
        lambda t: t.replace('name = "Seat bracket"', 'name = "Seat\\u001b[2J bracket"')), 65,
        "holds a control character (U+001B)"),
    attack("zone-1e300", _bracket_plan(_one_characteristic(
        'type = "profile"\nregion = "A"\nzone = 1e300\n')), 65, "beyond 1e6 mm"),
    attack("zone-beyond-1000-parts", _bracket_plan(_one_characteristic(
        'type = "profile"\nregion = "A"\nzone = 5e5\n')), 65,
        "beyond 1000 × the part's size"),
    attack("10001-characteristics", _bracket_plan(_characteristics(10_001)), 65,
           "holds 10,001 characteristics; a plan may hold at most 10,000"),
    attack("unknown-type", _bracket_plan(_one_characteristic(
        'type = "surface_finish"\nregion = "A"\nzone = 0.1\n')), 65,
        "'type' must be one of profile, flatness, position, size"),
    attack("missing-region", _bracket_plan(_one_characteristic(
        'type = "flatness"\nregion = "flange"\nzone = 0.1\n')), 65,
        '"flange" is not the name of any [[region]]'),
    attack("not-utf8", _bracket_plan(raw=b'[part]\nname = "Tr\xe4ger"\n'), 65, "not UTF-8"),
    attack("toml-syntax", _bracket_plan(lambda t: t.replace('name = "Seat bracket"',
                                                            "name = Seat bracket")), 65,
           "not valid TOML"),
]


@pytest.mark.parametrize("a", PLANS)
def test_plans(a, tmp_path, base):
    check_cli(a, tmp_path, base)


# ------------------------------------------------------------------------------ STEP

def _step(text: Callable[[], str] | None = None, path: Path | None = None,
          name: str = "nominal.stp"):
    """``inspect`` of a STEP nominal (a red-team file, or ``text()`` written as ``name``)
    against 20 points: the file is refused before any point matters."""
    def make(d: Path, base: Base):
        nominal = path
        if nominal is None:
            nominal = d / name
            nominal.write_bytes(text().encode("latin-1"))
        measured = d / "m.csv"
        measured.write_text("".join(f"{i},{i % 3},{i % 5}\n" for i in range(20)))
        return ["inspect", nominal, measured, "--tol", "0.1"]
    return make


def _redteam_text(name: str) -> str:
    return (REDTEAM / name).read_text(encoding="latin-1")


STEP = [
    # edgeloop_cycle.stp, oe_cycle2.stp: OpenCascade's parser died (exit 139, nothing said)
    attack("oriented-edge-of-itself", _step(path=REDTEAM / "edgeloop_cycle.stp"), 65,
           "entity #20, an ORIENTED_EDGE, refers to itself", report=True),
    attack("two-oriented-edges-in-a-cycle", _step(path=REDTEAM / "oe_cycle2.stp"), 65,
           "#20 ORIENTED_EDGE -> #55 ORIENTED_EDGE -> #20"),
    attack("oriented-edge-of-an-oriented-edge", _step(lambda: _redteam_text(
        "edgeloop_cycle.stp").replace("#20 = ORIENTED_EDGE('',*,*,#20,.F.);",
                                      "#20 = ORIENTED_EDGE('',*,*,#55,.F.);")), 65,
        "refers to #55, another ORIENTED_EDGE"),
    # zero_dir.stp: was "model lies beyond ±1e9 mm"
    attack("zero-length-direction", _step(path=REDTEAM / "zero_dir.stp"), 65,
           "entity #13, a DIRECTION, has length 0"),
    attack("truncated", _step(lambda: (t := _redteam_text("zero_dir.stp"))[:len(t) // 2]), 65,
           "truncated"),
    attack("not-step-named-stp", _step(lambda: "x y z\n1 2 3\n"), 65, "not a STEP file"),
    attack("empty", _step(lambda: ""), 65, "empty"),
]


@pytest.mark.parametrize("a", STEP)
def test_step(a, tmp_path, base):
    check_cli(a, tmp_path, base)


# ------------------------------------------------------------------------------ batch

def _unreadable_matches(d: Path, base: Base):
    lot = d / "lot"
    lot.mkdir()
    (lot / "s01.csv").symlink_to(d / "gone.csv")
    os.mkfifo(lot / "s02.csv")
    (lot / "s03.csv").mkdir()
    return ["batch", base.nominal, lot / "*.csv", "--tol", "0.1"]


def _every_match_is_an_error_row(d: Path, r: Child) -> None:
    """Each match is a row of the summary, ERROR with what it is; none was opened."""
    rows = json.loads((d / "out" / "summary.json").read_text())["parts"]
    lot = d / "lot"
    assert [(x["serial"], x["verdict"]) for x in rows] == [
        ("s01", "ERROR"), ("s02", "ERROR"), ("s03", "ERROR")]
    assert rows[0]["message"] == f"{lot / 's01.csv'}: a symbolic link to {d / 'gone.csv'}, " \
                                 "which does not exist"
    assert rows[1]["message"].startswith(f"{lot / 's02.csv'}: a named pipe (FIFO), not a file")
    assert rows[2]["message"].startswith(f"{lot / 's03.csv'}: a folder, not a file")
    for serial in ("s01", "s02", "s03"):
        assert f"  ERROR {serial} ({lot / serial}.csv): " in r.out, r.out


def _closed_port(d: Path, base: Base):
    with socket.socket() as s:  # a free port, closed again: nothing listens there
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return ["batch", base.nominal, base.measured, "--tol", "0.1", "--scheduler",
            f"tcp://127.0.0.1:{port}"]


def _within_15_s(d: Path, r: Child) -> None:
    assert r.seconds < 15, f"exit 69 took {r.seconds:.1f} s (it took 61 s)"


def _two_stems(d: Path, base: Base):
    (d / "a").mkdir()
    (d / "b").mkdir()
    shutil.copyfile(base.measured, d / "a" / "s01.csv")
    shutil.copyfile(base.measured, d / "b" / "s01.csv")
    return ["batch", base.nominal, d / "a" / "s01.csv", d / "b" / "s01.csv", "--tol", "0.1"]


BATCH = [
    # issue 22 item 3: dropped by an isfile filter, "1 parts: 1 ACCEPT"
    attack("dangling-symlink-fifo-folder-among-the-matches", _unreadable_matches, 65,
           "3 parts: 0 ACCEPT, 0 REJECT, 0 INCONCLUSIVE, 3 ERROR", refused=False,
           then=_every_match_is_an_error_row),
    # issue 22 item 4: 69 only after 61 s
    attack("scheduler-at-a-closed-port", _closed_port, 69,
           "the connection was refused", then=_within_15_s),
    attack("step-nominal-with-a-reference-cycle",
           lambda d, b: ["batch", REDTEAM / "edgeloop_cycle.stp", b.measured, "--tol", "0.1"],
           65, "entity #20, an ORIENTED_EDGE, refers to itself"),
    attack("glob-matching-nothing",
           lambda d, b: ["batch", b.nominal, d / "*.xyz", "--tol", "0.1"], 64,
           "matches no file"),
    attack("two-files-one-serial", _two_stems, 64, "two parts have the serial 's01'"),
]


@pytest.mark.parametrize("a", BATCH)
def test_batch(a, tmp_path, base):
    check_cli(a, tmp_path, base)


# ------------------------------------------------------------------------------ numerics

def _measured(edit: Callable[[np.ndarray], np.ndarray], *options: str):
    """``inspect`` of the base nominal against its measured points edited by ``edit``."""
    def make(d: Path, base: Base):
        p = np.loadtxt(base.measured, delimiter=",", skiprows=1)
        path = write_points(d / "m.csv", edit(p))
        return ["inspect", base.nominal, path, *(options or ("--tol", "0.1"))]
    return make


def _set(row: int, col: int, value: float):
    def edit(p):
        p = p.copy()
        p[row, col] = value
        return p
    return edit


def _names_the_option(r: Child) -> None:
    assert "read it with --units mm" in r.out.splitlines()[0], r.out


def _gear_points(d: Path, base: Base):
    """A gear drawing whose header says metres over numbers in mm, and points in mm."""
    from engine.contour import points_on
    from engine.io.templates import read_dxf_template

    rng = np.random.default_rng(4)
    q = points_on(read_dxf_template(str(GEAR), units="mm").template, 300, rng) + [40.0, -25.0]
    np.savetxt(d / "gear.csv", q, delimiter=",", header="x,y", comments="", fmt="%.6f")
    return ["inspect", GEAR, d / "gear.csv", "--tol", "0.05"]


NUMERICS = [
    # issue 22 item 9: accepted with numpy's overflow warning, 300 digits printed
    attack("tol-1e308", _measured(lambda p: p, "--tol", "1e308"), 64,
           "a limit 1e+308 mm from the nominal is beyond 1e6 mm"),
    attack("tol-nan", _measured(lambda p: p, "--tol", "nan"), 64, "'nan' is not a finite number"),
    attack("nan-coordinate", _measured(_set(5, 1, np.nan)), 65,
           "m.csv:7: NaN or infinity is not a coordinate"),
    attack("inf-coordinate", _measured(_set(5, 2, -np.inf)), 65,
           "m.csv:7: NaN or infinity is not a coordinate"),
    attack("coordinate-beyond-1e9", _measured(_set(5, 0, 2e9)), 65, "lies beyond ±1e9 mm"),
    # issue 22 item 10: "lie on one straight line"
    attack("1000-identical-points", _measured(lambda p: np.tile([1.5, 2.5, 3.5], (1000, 1))), 65,
           "all 1,000 points are the same point (1.5, 2.5, 3.5)"),
    # issue 22 item 11: only "registration did not converge ... rms 18.9 mm"
    attack("nominal-1000x-the-points", _gear_points, 2,
           "INCONCLUSIVE: the nominal is 1000 x the size of the measured points",
           then=lambda d, r: _names_the_option(r)),
]


@pytest.mark.parametrize("a", NUMERICS)
def test_numerics(a, tmp_path, base):
    check_cli(a, tmp_path, base)


# ------------------------------------------------------------------------------ other files

def _nominal_copy(d: Path, base: Base):
    shutil.copyfile(base.nominal, d / "copy.csv")
    return ["inspect", base.nominal, d / "copy.csv", "--tol", "0.1"]


def _fifo_measured(d: Path, base: Base):
    os.mkfifo(d / "m.csv")
    return ["inspect", base.nominal, d / "m.csv", "--tol", "0.1"]


def _fifo_nominal(suffix: str):
    """A named pipe as the nominal (or the plan): every reader waited for a writer for ever
    before (sha256_of and the readers opened it; only the measured file was checked)."""
    def make(d: Path, base: Base):
        os.mkfifo(d / f"n{suffix}")
        if suffix in (".toml", ".qif"):
            return ["inspect", base.nominal, base.measured, "--plan", d / f"n{suffix}"]
        return ["inspect", d / f"n{suffix}", base.measured, "--tol", "0.1"]
    return make


def _forging_file_name(d: Path, base: Base):
    bad = d / f"m\n{FORGED}\x1b[2J.csv"
    bad.write_text("x,y,z\n1,2,3\n4,five,6\n")
    return ["inspect", base.nominal, bad, "--tol", "0.1"]


def _as_nominal(name: str, content: str | bytes):
    def make(d: Path, base: Base):
        path = d / name
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
        return ["inspect", path, base.measured, "--tol", "0.1"]
    return make


CUBE = "".join(f"v {x} {y} {z}\n" for x in (0, 1) for y in (0, 1) for z in (0, 1))


def _ply_fewer_declared() -> str:
    v = np.random.default_rng(0).normal(size=(40, 3)) * 10
    head = ["ply", "format ascii 1.0", "element vertex 25", "property float x",
            "property float y", "property float z", "element face 12",
            "property list uchar int vertex_indices", "end_header"]
    return "\n".join(head + [f"{a:.6f} {b:.6f} {c:.6f}" for a, b, c in v]
                     + [f"3 {i} {i + 1} {i + 2}" for i in range(0, 36, 3)]) + "\n"


def _npy_huge_header() -> bytes:
    import io

    buf = io.BytesIO()
    np.save(buf, np.random.default_rng(0).normal(size=(50, 3)))
    raw = buf.getvalue()
    hlen = 10 + int.from_bytes(raw[8:10], "little")
    header = raw[:hlen].decode("latin-1").replace("(50, 3)", "(100000000000, 3)").rstrip()
    return (header + " " * (hlen - len(header) - 1) + "\n").encode("latin-1") + raw[hlen:]


def _vtk_4_2_holding_5_1(d: Path, base: Base):
    """VTK's own reader crashes on it: it is read in a child process (engine.io.child)."""
    import pyvista as pv

    pv.Sphere(theta_resolution=10, phi_resolution=8).save(d / "s.vtk", binary=True)
    path = d / "v42.vtk"
    path.write_bytes((d / "s.vtk").read_bytes().replace(b"Version 5.1", b"Version 4.2", 1))
    return ["inspect", path, base.measured, "--tol", "0.1"]


def _dxf(add: Callable, name: str):
    def make(d: Path, base: Base):
        import ezdxf

        doc = ezdxf.new("R2010")
        doc.header["$INSUNITS"] = 4
        add(doc.modelspace())
        doc.saveas(d / name)
        return ["inspect", d / name, base.measured, "--tol", "0.1"]
    return make


FILES = [
    # issue 22 item 2: a signed ACCEPT that verified VALID
    attack("nominal-copy-as-measured", _nominal_copy, 65, "the measured file is the nominal"),
    attack("fifo-as-measured", _fifo_measured, 66, "is not a file"),
    *(attack(f"fifo-as-{suffix[1:]}", _fifo_nominal(suffix), 66,
             f"n{suffix}: is not a file (a named pipe, socket or device)")
      for suffix in (".stp", ".dxf", ".ply", ".csv", ".toml", ".qif")),
    attack("file-name-forging-a-verdict-line", _forging_file_name, 65,
           f"m\\n{FORGED}\\x1b[2J.csv:3:"),
    attack("binary-bytes-in-a-text-file", _as_nominal("junk.xyz", b"1 2 3\n\x00\x07\x00\x01b\n"),
           65, "binary file"),
    attack("obj-face-of-a-missing-vertex", _as_nominal("bad.obj", CUBE + "f 1 2 3\nf 1 2 9\n"),
           65, "face refers to vertex 9; the file holds 8 vertices"),
    attack("ply-declares-fewer-vertices", _as_nominal("fewer.ply", _ply_fewer_declared()), 65,
           "the header declares 25 vertices, the file holds 40"),
    attack("npy-header-claims-1e11-rows", _as_nominal("claims.npy", _npy_huge_header()), 65,
           "the header declares 100000000000 rows, the file holds 50"),
    attack("vtk-that-crashes-vtks-reader", _vtk_4_2_holding_5_1, 65,
           "damaged: VTK's reader crashed reading it (signal"),
    attack("dxf-circle-of-radius-1e300", _dxf(lambda m: m.add_circle((0, 0), 1e300), "huge.dxf"),
           65, "has a coordinate or radius of 1e+300"),
    attack("dxf-of-zero-length-lines", _dxf(lambda m: (m.add_line((1, 1), (1, 1)),
                                                       m.add_line((5, 2), (5, 2))), "zero.dxf"),
           65, "the drawing holds no contour geometry"),
]


@pytest.mark.parametrize("a", FILES)
def test_files(a, tmp_path, base):
    check_cli(a, tmp_path, base)


# ------------------------------------------------------------------------------ sessions

SESSION_CHILD = """
import json, sys
from qa_app.desktop.controller import Controller
from qa_app.desktop.model import Session

hostile, nominal, measured = sys.argv[1:]
s = Session()
said = []
s.message.connect(lambda level, text: said.append([level, text]))
c = Controller(s, synchronous=True)
c.open_session(hostile)
if s.can_inspect and s.run is None and "error" not in [level for level, _ in said]:
    c.inspect()  # what the session opened, inspected as the window's button would
opened, said[:] = list(said), []
# Still usable: the next job opens, inspects and gives its verdict.
c.open_nominal(nominal)
c.open_measured(measured)
c.set_tolerance(-0.1, 0.1)
c.inspect()
print(json.dumps({"opened": opened, "then": said, "busy": c.busy,
                  "verdict": s.run and s.run.result.verdict}))
"""


@dataclass(frozen=True)
class SessionAttack:
    """make : (d, base) -> the hostile session's path, written into ``d``.
    said : the messages its opening (and inspecting what it opened) must give, in order:
        (level, words), one error at most."""

    make: Callable[[Path, Base], Path]
    said: list[tuple[str, str]]


def session(id: str, make, said, xfail: str | None = None):
    marks = [pytest.mark.xfail(strict=True, reason=xfail)] if xfail else []
    return pytest.param(SessionAttack(make, said), id=id, marks=marks)


def _text_session(content: str | bytes):
    def make(d: Path, base: Base):
        path = d / "x.qasession"
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
        return path
    return make


def _sha(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _session_doc(nominal, measured, version=1, tol=0.1) -> dict:
    return {"format": "qa-inspect session", "version": version, "saved": None,
            "inputs": [{"role": role, "path": str(p), "sha256": _sha(p) if os.path.isfile(p)
                        else "0" * 64} for role, p in (("nominal", nominal),
                                                        ("measured", measured))],
            "settings": {"tol_lower": -tol, "tol_upper": tol}, "results": None}


def _json_session(doc: Callable[[Path, Base], dict]):
    def make(d: Path, base: Base):
        path = d / "x.qasession"
        path.write_text(json.dumps(doc(d, base)))
        return path
    return make


def _fifo(d: Path, base: Base):
    os.mkfifo(d / "x.qasession")
    return d / "x.qasession"


def _fifo_input(d: Path, base: Base):
    os.mkfifo(d / "m.csv")
    return _json_session(lambda d, b: _session_doc(b.nominal, d / "m.csv"))(d, base)


SESSIONS = [
    # deep.qasession: a RecursionError traceback out of the window
    session("nested-100000-deep", _text_session("[" * 100_000 + "]" * 100_000),
            [("error", "nested too deeply")]),
    # a FIFO as the session hung the window for ever
    session("fifo", _fifo, [("error", "not a regular file")]),
    session("folder", lambda d, b: d, [("error", "not a regular file")]),
    session("not-json", _text_session("{not json"), [("error", "not a readable session file")]),
    session("not-utf8", _text_session(b"\xff\xfe\x00garbage\x80"),
            [("error", "not a readable session file")]),
    session("another-format", _json_session(lambda d, b: {
        **_session_doc(b.nominal, b.measured), "format": "qa-inspect sessions"}),
        [("error", "not a qa-inspect session file")]),
    session("a-version-it-does-not-know", _json_session(
        lambda d, b: _session_doc(b.nominal, b.measured, version=99)),
        [("error", "version 99")]),
    # issue 22 item 9: a zone of 1e308 was accepted
    session("tolerance-1e308", _json_session(
        lambda d, b: _session_doc(b.nominal, b.measured, tol=1e308)),
        [("error", "a limit 1e+308 mm from the nominal is beyond 1e6 mm")]),
    session("fifo-as-its-measured-file", _fifo_input,
            [("warning", "m.csv"), ("error", "is not a file")]),
    session("step-nominal-with-a-reference-cycle", _json_session(
        lambda d, b: _session_doc(REDTEAM / "edgeloop_cycle.stp", b.measured)),
        [("info", "Session reopened"),
         ("error", "entity #20, an ORIENTED_EDGE, refers to itself")]),
    session("input-path-forging-a-line", _json_session(
        lambda d, b: _session_doc(b.nominal, d / f"m\n{FORGED}\x1b[2J.csv")),
        [("warning", f"m\\n{FORGED}\\x1b[2J.csv no longer exists"),
         ("error", f"m\\n{FORGED}\\x1b[2J.csv: no such file")]),
]


@pytest.mark.parametrize("a", SESSIONS)
def test_sessions(a, tmp_path, base):
    """The desktop app's model and controller (no Qt) open the hostile session in a child
    process: the messages it must give and no other, then the next job inspects."""
    hostile = a.make(tmp_path, base)
    r = run_child([sys.executable, "-c", SESSION_CHILD, str(hostile), str(base.nominal),
                   str(base.measured)], cwd=tmp_path,
                  env={**os.environ, "QT_QPA_PLATFORM": "offscreen"})
    assert_no_crash(r, "the app's controller")
    assert r.code == 0 and r.err == "", (r.code, r.err[-3000:])
    got = json.loads(r.out.splitlines()[-1])
    for _, text in got["opened"] + got["then"]:
        assert_printable(text, one_line=True)
    assert [level for level, _ in got["opened"]] == [level for level, _ in a.said], got["opened"]
    for (level, text), (_, words) in zip(got["opened"], a.said):
        assert words in text, (level, text)
    assert got["verdict"] == "ACCEPT" and not got["busy"], got
    assert got["then"][-1][0] == "info" and got["then"][-1][1].startswith("ACCEPT"), got["then"]
