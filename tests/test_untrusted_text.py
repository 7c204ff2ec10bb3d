"""Strings from the inputs are shown as text, never acted on (issue 22 item 8): a file name
holding a line break and a forged "ACCEPT: ..." line, an ANSI escape sequence, a point label
with Paragraph markup (<b>, &) and control characters. On the terminal, in the certificate
(read back with pdftotext) and in its QIF (parsed with lxml, validated against the schema)
each appears once, on its own line, its control characters written out
(reports.messages.printable)."""

import os

import pytest

from qa_app.cli import main
from reports.messages import printable

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BRACKET = os.path.join(ROOT, "samples", "seat_bracket")
FORGED = "ACCEPT: all 5 characteristics are within tolerance"
NAME = f"m\n{FORGED}\x1b[2J"
"""A measured file's name (before .csv): a line break, a forged verdict line, 'clear screen'."""
LABEL = "<b>&</b><font size=80>\x1b[31m\u2028"
"""What each point label gains: Paragraph markup and control characters."""
RAW = ("\x1b", "\u2028", "\r")
"""Characters that must not reach the terminal or the certificate's text as they are (nor a
line break but between lines: counted apart)."""


def measured(d, name: str, label: str = "", bad: bool = False) -> str:
    """The seat bracket's measured points in ``d`` as ``name``.csv, each label + ``label``;
    ``bad``: with a coordinate that is no number (the file is refused, naming itself)."""
    with open(os.path.join(BRACKET, "measured.csv")) as f:
        rows = [r for r in f.read().splitlines() if r and not r.startswith(("#", "id"))]
    rows = [f'"{r.split(",", 1)[0]}{label}",{r.split(",", 1)[1]}' for r in rows]
    if bad:
        rows[3] = rows[3].rsplit(",", 1)[0] + ",oops"
    path = os.path.join(str(d), name + ".csv")
    with open(path, "w", encoding="utf-8") as f:
        f.write("id,x,y,z\n" + "\n".join(rows) + "\n")
    return path


def lines_of(text: str) -> list[str]:
    return text.splitlines()  # splits at \u2028, \x85 ... too: none may be left


def test_a_file_name_cannot_forge_a_line_on_the_terminal(tmp_path, capsys):
    """The refusal of a bad file names it on one line; a run's summary too (its output's name
    here): the forged line and the escape sequence are shown as text."""
    bad = measured(tmp_path, NAME, bad=True)
    assert main(["inspect", os.path.join(BRACKET, "nominal.xyz"), bad, "--tol", "0.05"]) == 65
    err = capsys.readouterr().err
    assert len(lines_of(err)) == 1 and not any(c in err for c in RAW)
    assert f"m\\n{FORGED}\\x1b[2J.csv:5: 'oops' is not a number" in err
    good = measured(tmp_path, NAME)
    out_json = str(tmp_path / f"r\n{FORGED}.json")
    code = main(["inspect", os.path.join(BRACKET, "nominal.xyz"), good, "--plan",
                 os.path.join(BRACKET, "plan.toml"), "--json", out_json])
    out = capsys.readouterr().out
    assert code == 1 and out.startswith("REJECT: ")
    assert not any(line.startswith("ACCEPT") for line in lines_of(out))
    assert not any(c in out for c in RAW)
    assert f"r\\n{FORGED}.json" in out


def test_a_batch_summary_shows_file_names_on_their_lines():
    """A lot's ERROR rows name the part's file and serial (its name): one line each."""
    from qa_app.batch import summary_text

    row = {"serial": NAME, "file": f"lot/{NAME}.csv", "verdict": "ERROR", "skipped": False,
           "message": f"lot/{NAME}.csv:2: 'oops' is not a number"}
    text = summary_text([row], 1.0, ["/out/summary.csv"])
    lines = lines_of(text)
    assert len(lines) == 3 and not any(c in text for c in RAW)
    assert lines[1] == (f"  ERROR m\\n{FORGED}\\x1b[2J (lot/m\\n{FORGED}\\x1b[2J.csv): "
                        f"lot/m\\n{FORGED}\\x1b[2J.csv:2: 'oops' is not a number")


@pytest.mark.parametrize("text, shown", [
    ("a\nACCEPT", "a\\nACCEPT"), ("\x1b[2J", "\\x1b[2J"), ("x\u2028y\u2029z", "x\\u2028y\\u2029z"),
    ("tab\tcr\r\x7f\x85", "tab\\tcr\\r\\x7f\\x85"), ("rlo\u202eevil", "rlo\\u202eevil"),
    ("b\udcff", "b\\udcff"), ("naïve ⌀8 µm C:\\parts", "naïve ⌀8 µm C:\\parts"), (7, "7")])
def test_printable_writes_out_what_would_act_on_a_line(text, shown):
    assert printable(text) == shown
    assert printable(shown) == shown  # once is enough
