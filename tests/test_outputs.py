"""reports.outputs: every output of a run or none, whatever fails and when."""

import os

import pytest

from reports.outputs import Output, OutputConflictError, check_outputs, same_file, write_all


def listing(folder):
    """{relative path: bytes} of every file below ``folder``, hidden and temporary ones too."""
    out = {}
    for root, _, names in os.walk(folder):
        for n in names:
            p = os.path.join(root, n)
            with open(p, "rb") as f:
                out[os.path.relpath(p, folder)] = f.read()
    return out


def test_all_written(tmp_path):
    (tmp_path / "b.txt").write_text("old b")
    write_all([Output(str(tmp_path / "a.txt"), "A"), Output(str(tmp_path / "b.txt"), b"B"),
               Output(str(tmp_path / "new" / "c.txt"), "C", private=True)])
    assert listing(tmp_path) == {"a.txt": b"A", "b.txt": b"B", os.path.join("new", "c.txt"): b"C"}
    assert os.stat(tmp_path / "new" / "c.txt").st_mode & 0o777 == 0o600


def test_a_failed_write_leaves_nothing(tmp_path):
    (tmp_path / "a.txt").write_text("old a")
    (tmp_path / "blocker").write_text("")
    before = listing(tmp_path)
    with pytest.raises(OSError) as e:
        write_all([Output(str(tmp_path / "a.txt"), "new a"),
                   Output(str(tmp_path / "made" / "deeper" / "b.txt"), "b"),
                   Output(str(tmp_path / "blocker" / "c.txt"), "c")])
    assert e.value.filename == str(tmp_path / "blocker" / "c.txt")
    assert listing(tmp_path) == before
    assert not (tmp_path / "made").exists()  # folders made for the outputs are gone too


@pytest.mark.parametrize("fail_at", [0, 1, 2])
def test_a_rename_failing_midway_is_undone(tmp_path, monkeypatch, fail_at):
    """The third kind of failure: every temporary file was written, then a rename fails (a
    full or vanished file system, say). The renames done are undone: each target that was
    there has its previous content back, each new one is gone."""
    targets = [tmp_path / "a.txt", tmp_path / "b.txt", tmp_path / "c.txt"]
    targets[0].write_text("old a")
    targets[2].write_text("old c")
    before = listing(tmp_path)
    real_replace = os.replace
    calls = []

    def replace(src, dst, *a, **k):
        if os.path.basename(str(src)).startswith(".tmp-"):
            calls.append(dst)
            if len(calls) == fail_at + 1:
                raise OSError(28, "No space left on device", str(dst))
        return real_replace(src, dst, *a, **k)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OSError) as e:
        write_all([Output(str(t), f"new {t.name}") for t in targets])
    monkeypatch.setattr(os, "replace", real_replace)
    assert e.value.filename == str(targets[fail_at])
    assert "could not undo" not in str(e.value)
    assert listing(tmp_path) == before


def test_check_outputs(tmp_path):
    src = tmp_path / "m.csv"
    src.write_text("1,2,3\n")
    os.link(src, tmp_path / "hard.csv")
    os.symlink(src, tmp_path / "soft.csv")
    for alias in (src, tmp_path / "hard.csv", tmp_path / "soft.csv",
                  tmp_path / "x" / ".." / "m.csv"):
        assert same_file(str(alias), str(src))
        with pytest.raises(OutputConflictError, match="--csv .* is the MEASURED file"):
            check_outputs({"--csv": str(alias)}, {"MEASURED": str(src)})
    with pytest.raises(OutputConflictError, match="--csv and --json name the same file"):
        check_outputs({"--csv": str(tmp_path / "r"), "--json": str(tmp_path / "." / "r")}, {})
    with pytest.raises(OutputConflictError, match="--json needs a file name"):
        check_outputs({"--json": ""}, {})
    # Distinct files, and options not given, pass.
    check_outputs({"--csv": str(tmp_path / "r.csv"), "--json": str(tmp_path / "r.json"),
                   "--report": None}, {"MEASURED": str(src), "--sign identity": None})
