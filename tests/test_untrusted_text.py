"""Strings from the inputs are shown as text, never acted on (issue 22 item 8): a file name
holding a line break and a forged "ACCEPT: ..." line, an ANSI escape sequence, a point label
with Paragraph markup (<b>, &) and control characters. On the terminal, in the certificate
(read back with pdftotext) and in its QIF (parsed with lxml, validated against the schema)
each appears once, on its own line, its control characters written out
(reports.messages.printable)."""

import os
import shutil
import subprocess

import pytest
from lxml import etree

from qa_app.cli import main
from reports.messages import printable

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BRACKET = os.path.join(ROOT, "samples", "seat_bracket")
XSD = os.path.join(ROOT, "tests", "data", "qif-3.0-xsd", "QIFDocument.xsd")
FORGED = "ACCEPT: all 5 characteristics are within tolerance"
NAME = f"m\n{FORGED}\x1b[2J"
"""A measured file's name (before .csv): a line break, a forged verdict line, 'clear screen'."""
LABEL = "<b>&</b><font size=80>\x1b[31m\u2028"
"""What each point label gains: Paragraph markup and control characters."""
RAW = ("\x1b", "\u2028", "\r")
"""Characters that must not reach the terminal or the certificate's text as they are (nor a
line break but between lines: counted apart)."""


def tool(name: str) -> str:
    path = shutil.which(name)
    if path is None:
        pytest.fail(f"{name} is not installed (poppler-utils)", pytrace=False)
    return path


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
    from qa_app.lot_summary import summary_text

    row = {"serial": NAME, "file": f"lot/{NAME}.csv", "verdict": "ERROR", "skipped": False,
           "message": f"lot/{NAME}.csv:2: 'oops' is not a number"}
    text = summary_text([row], 1.0, ["/out/summary.csv"])
    lines = lines_of(text)
    assert len(lines) == 3 and not any(c in text for c in RAW)
    assert lines[1] == (f"  ERROR m\\n{FORGED}\\x1b[2J (lot/m\\n{FORGED}\\x1b[2J.csv): "
                        f"lot/m\\n{FORGED}\\x1b[2J.csv:2: 'oops' is not a number")


@pytest.fixture(scope="module")
def certificate(tmp_path_factory):
    """An unsigned certificate of a nominal and a measured file with hostile names and labels:
    its text (pdftotext) and its QIF (pdfdetach)."""
    d = tmp_path_factory.mktemp("hostile")
    nominal = str(d / "n\x1b[2J\nACCEPT.xyz")
    shutil.copy(os.path.join(BRACKET, "nominal.xyz"), nominal)
    pdf = d / "c.pdf"
    code = main(["inspect", nominal, measured(d, NAME, LABEL), "--tol", "0.01", "--report",
                 str(pdf)])
    assert code == 1
    # Content-stream order: a table cell's lines stay together.
    text = subprocess.run([tool("pdftotext"), "-raw", str(pdf), "-"], capture_output=True,
                          text=True, check=True).stdout
    subprocess.run([tool("pdfdetach"), "-saveall", "-o", str(d), str(pdf)], check=True,
                   capture_output=True)
    return text, (d / "results.qif").read_bytes()


def test_the_certificate_shows_names_and_labels_literally(certificate):
    text, _ = certificate
    assert not any(c in text for c in RAW)
    # The point list and the statement (the worst point) show the label as written, markup
    # and all; the inputs section the file name, its line break written out.
    shown = "<b>&</b><font size=80>\\x1b[31m\\u2028"
    assert text.count(shown) >= 2
    joined = " ".join(text.split())
    assert "nominal n\\x1b[2J\\nACCEPT.xyz" in joined
    assert f"measured m\\n{FORGED}\\x1b[2J.csv" in joined
    assert not any(line.strip().startswith("ACCEPT") for line in lines_of(text))


def test_the_qif_is_valid_and_holds_the_names_written_out(certificate):
    _, qif = certificate
    doc = etree.fromstring(qif)
    schema = etree.XMLSchema(etree.parse(XSD))
    assert schema.validate(doc), schema.error_log
    ns = {"q": "http://qifstandards.org/xsd/qif3"}
    names = doc.xpath("//q:DigitalModel/q:Name/text()", namespaces=ns)
    assert names == ["n\\x1b[2J\\nACCEPT.xyz"]  # written out, not dropped
    uri = doc.xpath("//q:URI/text()", namespaces=ns)  # the measured file, percent-encoded
    assert len(uri) == 1 and uri[0].endswith("/m%0AACCEPT:%20all%205%20characteristics%20are"
                                             "%20within%20tolerance%1B%5B2J.csv")


def test_a_file_name_that_is_not_utf8_is_no_internal_error(tmp_path, capsys):
    """A file name's bytes that are not UTF-8 reach Python as lone surrogates; writing them to
    the certificate's QIF raised UnicodeEncodeError: exit 70 and no certificate."""
    path = measured(tmp_path, "b\udcff")
    assert os.path.exists(os.fsencode(path)) and b"\xff" in os.fsencode(path)
    pdf = tmp_path / "c.pdf"
    code = main(["inspect", os.path.join(BRACKET, "nominal.xyz"), path, "--tol", "0.05",
                 "--report", str(pdf)])
    captured = capsys.readouterr()
    assert code in (0, 1, 2), captured.err
    assert pdf.exists()


def test_the_spc_report_shows_names_literally():
    """A lot's SPC report titles its pages with the nominal's and the plan's file names and
    names each characteristic: a '$' pair there was read as a formula (an unbalanced one raised
    ValueError), a line break broke the title."""
    import numpy as np

    from engine.spc import Series
    from reports.spc import spc_pdf

    odd = "$\\frac{$ x\ny"
    series = Series(f"1 {odd}", "mm", np.array([0.10, 0.20, 0.15, 0.12]), ("a", "b", "c", "d"),
                    None, 0.3)
    pdf = spc_pdf([series], f"lot {odd}", {"nominal": f"n {odd}.csv"})
    text = subprocess.run([tool("pdftotext"), "-raw", "-", "-"], input=pdf,
                          capture_output=True, check=True).stdout.decode()
    shown = "$\\frac{$ x\\ny"
    assert f"lot {shown}" in text and f"n {shown}.csv" in text and f"1 {shown}" in text


@pytest.mark.parametrize("text, shown", [
    ("a\nACCEPT", "a\\nACCEPT"), ("\x1b[2J", "\\x1b[2J"), ("x\u2028y\u2029z", "x\\u2028y\\u2029z"),
    ("tab\tcr\r\x7f\x85", "tab\\tcr\\r\\x7f\\x85"), ("rlo\u202eevil", "rlo\\u202eevil"),
    ("b\udcff", "b\\udcff"), ("naïve ⌀8 µm C:\\parts", "naïve ⌀8 µm C:\\parts"), (7, "7")])
def test_printable_writes_out_what_would_act_on_a_line(text, shown):
    assert printable(text) == shown
    assert printable(shown) == shown  # once is enough


def test_a_point_label_that_is_a_spreadsheet_formula_is_written_as_text(tmp_path):
    """Point labels are free text in a CMM file: in the results CSV a label a spreadsheet would
    run as a formula ('=...', '+...', '-...', '@...') gets a leading apostrophe; a label that is
    a plain number ('-7', '+3.5') stays as it is, and every other column is untouched."""
    with open(os.path.join(BRACKET, "measured.csv")) as f:
        rows = [r for r in f.read().splitlines() if r and not r.startswith(("#", "id"))]
    labels = ["=HYPERLINK(A1)", "+cmd|' /C calc'!A0", "-P7", "@SUM(A1:A9)",
              "-7", "+3.5", "P1"]
    rows = [f'"{labels[i % len(labels)].replace(chr(34), chr(34) * 2)}",{r.split(",", 1)[1]}'
            for i, r in enumerate(rows)]
    path = tmp_path / "m.csv"
    path.write_text("id,x,y,z\n" + "\n".join(rows) + "\n", encoding="utf-8")
    out = tmp_path / "out.csv"
    code = main(["inspect", os.path.join(BRACKET, "nominal.xyz"), str(path), "--tol", "0.05",
                 "--csv", str(out), "--quiet"])
    assert code in (0, 1)
    import csv
    with open(out, newline="") as f:
        got = [r["label"] for r in csv.DictReader(f)]
    want = {"=HYPERLINK(A1)": "'=HYPERLINK(A1)",
            "+cmd|' /C calc'!A0": "'+cmd|' /C calc'!A0", "-P7": "'-P7",
            "@SUM(A1:A9)": "'@SUM(A1:A9)", "-7": "-7", "+3.5": "+3.5", "P1": "P1"}
    assert got == [want[labels[i % len(labels)]] for i in range(len(rows))]
