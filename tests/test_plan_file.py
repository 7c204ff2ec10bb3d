"""Inspection plan files (engine.io.plan.read_plan): the issue's example read into the exact plan
objects, and every bad-plan class decidable from the file refused with an InputError that names the
file, the table and the key."""

import hashlib

import pytest

from engine.errors import InputError, InputNotFoundError
from engine.io import formats
from engine.io.plan import read_plan
from engine.gdt.plan import (Alignment, Characteristic, Datum, Part, Plan, Region, RpsPoint)

PART = """\
[part]
number = "SB-1020"
name = "Seat bracket"
revision = "C"
"""
REGIONS = """
[[region]]
name = "A"
box = [[-1.0, -1.0, -0.5], [101.0, 61.0, 0.5]]

[[region]]
name = "B"
labels = "B*"

[[region]]
name = "C"
group = "side"
measured_labels = "C*"

[[region]]
name = "skin"
box = [[0, 0, 1], [100, 60, 40]]

[[region]]
name = "hole1"
labels = "H1*"
"""
DATUMS = """
[[datum]]
label = "A"
region = "A"
feature = "plane"
fit = "tangent"

[[datum]]
label = "B"
region = "B"
feature = "plane"
fit = "lsq"

[[datum]]
label = "C"
region = "C"
feature = "cylinder"
"""
ALIGNMENT = """
[alignment]
method = "datums"
reference = ["A", "B", "C"]
best_fit_regions = ["skin"]
"""
CHARACTERISTICS = """
[[characteristic]]
id = "1"
type = "profile"
region = "skin"
zone = 0.1
datums = ["A", "B", "C"]

[[characteristic]]
id = "2"
type = "flatness"
region = "A"
zone = 0.02

[[characteristic]]
id = "3"
type = "position"
region = "hole1"
zone = 0.1
datums = ["A", "B", "C"]

[[characteristic]]
id = "4"
type = "size"
region = "hole1"
nominal = 8.0
lower = -0.05
upper = 0.05
"""
EXAMPLE = PART + REGIONS + DATUMS + ALIGNMENT + CHARACTERISTICS
BASE = PART + REGIONS + DATUMS
"""A valid plan without alignment or characteristics: the bad plans add to it."""


def write(tmp_path, text, name="plan.toml"):
    f = tmp_path / name
    f.write_text(text, encoding="utf-8")
    return str(f)


def refused(tmp_path, text, name="plan.toml") -> InputError:
    path = write(tmp_path, text, name)
    with pytest.raises(InputError) as e:
        read_plan(path)
    assert not isinstance(e.value, InputNotFoundError)
    assert e.value.path == path and str(e.value).startswith(f"{path}:")
    return e.value


def test_the_issues_example_reads_into_the_exact_plan(tmp_path):
    path = write(tmp_path, EXAMPLE)
    plan = read_plan(path)
    assert plan == Plan(
        path=path,
        sha256=hashlib.sha256(EXAMPLE.encode()).hexdigest(),
        part=Part(number="SB-1020", name="Seat bracket", revision="C"),
        regions=(Region("A", box=((-1.0, -1.0, -0.5), (101.0, 61.0, 0.5))),
                 Region("B", labels="B*"),
                 Region("C", group="side", measured_labels="C*"),
                 Region("skin", box=((0.0, 0.0, 1.0), (100.0, 60.0, 40.0))),
                 Region("hole1", labels="H1*")),
        datums=(Datum("A", "A", "plane", "tangent"), Datum("B", "B", "plane", "lsq"),
                Datum("C", "C", "cylinder", "tangent")),
        alignment=Alignment("datums", ("A", "B", "C"), ("skin",)),
        characteristics=(
            Characteristic("1", "profile", "skin", -0.05, 0.05, ("A", "B", "C")),
            Characteristic("2", "flatness", "A", 0.0, 0.02),
            Characteristic("3", "position", "hole1", 0.0, 0.1, ("A", "B", "C")),
            Characteristic("4", "size", "hole1", -0.05, 0.05, nominal=8.0)),
        rps=())
    assert plan.sha256 == hashlib.sha256((tmp_path / "plan.toml").read_bytes()).hexdigest()
    assert plan.region("hole1").labels == "H1*" and plan.datum("C").feature == "cylinder"
    assert plan.characteristics[0].width == pytest.approx(0.1)
    assert all(isinstance(v, float) for v in plan.regions[3].box[0])


def test_defaults_an_empty_plan_is_todays_best_fit(tmp_path):
    plan = read_plan(write(tmp_path, "# nothing planned\n"))
    assert plan.part == Part() and plan.alignment == Alignment(method="best-fit")
    assert plan.regions == plan.datums == plan.characteristics == plan.rps == ()


def test_explicit_profile_limits_form_only_fit_and_utf8_bom(tmp_path):
    text = REGIONS + """
[[characteristic]]
id = "7"
type = "profile"
region = "skin"
lower = -0.02
upper = 0.08
fit = "minimax"

[[characteristic]]
id = "8"
type = "profile"
region = "skin"
zone = 1
"""
    path = tmp_path / "plan.toml"
    path.write_bytes(b"\xef\xbb\xbf" + text.encode())
    c7, c8 = read_plan(str(path)).characteristics
    assert c7 == Characteristic("7", "profile", "skin", -0.02, 0.08, fit="minimax")
    assert c8 == Characteristic("8", "profile", "skin", -0.5, 0.5)


def test_rps_alignment(tmp_path):
    text = """
[alignment]
method = "rps"

[[rps]]
label = "R1"
nominal = [0, 0, 0]
lock = ["z", "x", "y"]

[[rps]]
label = "R2"
nominal = [100.0, 0.0, 0.0]
lock = ["z"]
"""
    plan = read_plan(write(tmp_path, text))
    assert plan.alignment == Alignment(method="rps")
    assert plan.rps == (RpsPoint("R1", (0.0, 0.0, 0.0), ("x", "y", "z")),
                        RpsPoint("R2", (100.0, 0.0, 0.0), ("z",)))


def test_a_plan_nested_too_deeply_is_refused_not_a_recursion_error(tmp_path):
    """Issue 22: arrays nested 5,000 deep made tomllib recurse out of the stack: exit 70 with
    RecursionError. It is bad input, named as such."""
    e = refused(tmp_path, "x = " + "[" * 5000 + "]" * 5000 + "\n")
    assert "nested too deeply" in str(e)


def _characteristics(n: int, inline: bool) -> str:
    """A plan of ``n`` flatness characteristics on one region, as [[characteristic]] tables or
    as one inline array of them."""
    head = '[[region]]\nname = "A"\nlabels = "A*"\n'
    if inline:  # top-level keys come before the first table
        return "characteristic = [\n" + "".join(
            f'  {{id = "{k}", type = "flatness", region = "A", zone = 0.1}},\n'
            for k in range(n)) + "]\n" + head
    return head + "".join(f'[[characteristic]]\nid = "{k}"\ntype = "flatness"\n'
                          f'region = "A"\nzone = 0.1\n' for k in range(n))


@pytest.mark.parametrize("inline", [False, True])
def test_a_plan_holds_at_most_the_stated_number_of_characteristics(tmp_path, monkeypatch,
                                                                   inline):
    """Issue 22: 100,000 characteristics ran for minutes with nothing on the terminal. A plan
    holds at most MAX_CHARACTERISTICS (10,000, README); more is bad input that names the plan,
    the count and the limit. (The limit is lowered here to keep the test quick.)"""
    import engine.gdt.plan
    from engine.gdt.plan import MAX_CHARACTERISTICS

    assert MAX_CHARACTERISTICS == 10_000
    monkeypatch.setattr(engine.gdt.plan, "MAX_CHARACTERISTICS", 40)
    assert len(read_plan(write(tmp_path, _characteristics(40, inline))).characteristics) == 40
    e = refused(tmp_path, _characteristics(41, inline))
    assert "holds 41 characteristics; a plan may hold at most 40" in str(e)


def test_too_many_characteristics_are_refused_before_the_plan_is_parsed(tmp_path, monkeypatch):
    """100,000 [[characteristic]] tables take tomllib half a minute: they are counted first."""
    import tomllib

    def parse(text):
        raise AssertionError("the plan was parsed")

    monkeypatch.setattr(tomllib, "loads", parse)
    e = refused(tmp_path, _characteristics(100_000, inline=False))
    assert "holds 100,000 characteristics; a plan may hold at most 10,000" in str(e)


@pytest.mark.parametrize("value", ["A\nACCEPT: all 5 characteristics are within tolerance",
                                   "tab\there", "esc\u001b[2J", "line\u2028sep"])
def test_ids_names_and_labels_with_control_characters_are_refused(tmp_path, value):
    """Issue 22: a characteristic id holding a line break and "ACCEPT: ..." printed a forged
    verdict line on a REJECT run. Every string of the plan is plain text or the plan is bad
    input."""
    import json

    text = json.dumps(value)  # a TOML basic string with the escapes
    e = refused(tmp_path, f'[[region]]\nname = "skin"\nlabels = "s*"\n'
                          f'[[characteristic]]\nid = {text}\ntype = "profile"\n'
                          f'region = "skin"\nzone = 0.1\n')
    assert "control character" in str(e) and "id" in str(e)
    e = refused(tmp_path, f'[[region]]\nname = {text}\nlabels = "s*"\n')
    assert "control character" in str(e)
    e = refused(tmp_path, f'[[region]]\nname = "skin"\nlabels = {text}\n')
    assert "control character" in str(e)


def test_toml_and_qif_are_the_plan_rows_of_the_file_table():
    assert formats.kind_of("Plan.TOML") == formats.PLAN and formats.kind_of("P.QIF") == formats.QIF
    assert formats.PLAN_SUFFIXES == (".toml", ".qif")
    assert not {".toml", ".qif"} & set(formats.ALL_SUFFIXES + formats.TEMPLATE_SUFFIXES)


def test_the_message_of_a_bad_zone_reads_as_the_contract_says(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, EXAMPLE.replace("zone = 0.1\ndatums", "zone = -0.1\ndatums", 2)
          .replace("zone = -0.1", "zone = 0.1", 1))
    with pytest.raises(InputError) as e:
        read_plan("plan.toml")
    assert str(e.value) == ("plan.toml: [[characteristic]] #3 (id \"3\"): 'zone' must be > 0, "
                            "got -0.1")


@pytest.mark.parametrize("text, line", [
    ('[part]\nnumber = "SB-1020"\nname = Seat bracket\n', 3),
    ('[[region]]\nname = "A"\n\n[[region]\nname = "B"\n', 4),
    ('[part]\nname = "x"\nname = "y"\n', 3),
    ('[part]\nnumber = "SB-1020"\nname = \n', 3),
    ('[part]\nnumber = "SB-1020"\nname = ', 3),  # tomllib says "at end of document"
])
def test_toml_syntax_errors_give_the_line(tmp_path, text, line):
    e = refused(tmp_path, text)
    assert e.line == line
    assert str(e).startswith(f"{e.path}:{line}: not valid TOML: ")
    assert "(at line" not in str(e)


def test_missing_unreadable_and_foreign_files(tmp_path):
    with pytest.raises(InputNotFoundError):
        read_plan(str(tmp_path / "no_such_plan.toml"))
    with pytest.raises(InputError, match="is a folder"):
        read_plan(str(tmp_path))
    e = refused(tmp_path, "x, y, z\n1, 2, 3\n", name="nominal.csv")
    assert "a .toml or .qif file, not '.csv'" in str(e)
    path = tmp_path / "latin.toml"
    path.write_bytes(b'[part]\nname = "Tr\xe4ger"\n')
    with pytest.raises(InputError, match="not UTF-8") as e:
        read_plan(str(path))
    assert e.value.line == 2


def region(name, body):
    return f'\n[[region]]\nname = "{name}"\n{body}\n'


def datum(label, region_name, feature="plane", extra=""):
    return (f'\n[[datum]]\nlabel = "{label}"\nregion = "{region_name}"\nfeature = "{feature}"\n'
            f'{extra}\n')


def char(ident, body):
    return f'\n[[characteristic]]\nid = "{ident}"\n{body}\n'


PROFILE = 'type = "profile"\nregion = "skin"\n'
POSITION = 'type = "position"\nregion = "hole1"\n'
SIZE = 'type = "size"\nregion = "hole1"\n'
FLAT = 'type = "flatness"\nregion = "A"\n'
RPS = '\n[[rps]]\nlabel = "R1"\nnominal = [0, 0, 0]\nlock = ["x", "y", "z"]\n'

# (what is wrong, plan text, table as the message names it, key, words the message holds)
BAD = [
    # unknown tables and keys, anywhere
    ("unknown table", BASE + '\n[[characteristics]]\nid = "1"\n', "", "characteristics",
     "did you mean 'characteristic'"),
    ("unknown top key", 'method = "datums"\n' + BASE, "", "method",
     "unknown key 'method' at the top level (it belongs in [alignment] or [[characteristic]])"),
    ("unknown part key", '[part]\nnumbr = "1"\n', "[part]", "numbr", "did you mean 'number'"),
    ("unknown region key", BASE + region("D", 'label = "D*"'), '[[region]] #6 (name "D")',
     "label", "did you mean 'labels'"),
    ("unknown datum key", BASE + datum("D", "A", extra='fitt = "lsq"'),
     '[[datum]] #4 (label "D")', "fitt", "not a key of [[datum]]"),
    ("unknown alignment key", BASE + '[alignment]\nmethod = "datums"\nreferences = ["A"]\n',
     "[alignment]", "references", "did you mean 'reference'"),
    ("unknown characteristic key", BASE + char("1", FLAT + "zone = 0.1\ntolerance = 1"),
     '[[characteristic]] #1 (id "1")', "tolerance", "its keys are"),
    ("unknown rps key", '[alignment]\nmethod = "rps"\n' + RPS + "lck = 1\n",
     '[[rps]] #1 (label "R1")', "lck", "did you mean 'lock'"),
    # wrong types
    ("single table for an array", BASE + '\n[characteristic]\nid = "1"\n', "", "characteristic",
     "write [[characteristic]]"),
    ("array for a single table", '[[alignment]]\nmethod = "datums"\n', "", "alignment",
     "must be a table [alignment]"),
    ("string expected", '[part]\nnumber = 1020\n', "[part]", "number", "must be a string"),
    ("number expected", BASE + char("1", FLAT + 'zone = "0.02"'),
     '[[characteristic]] #1 (id "1")', "zone", 'must be a number, got "0.02" (a string)'),
    ("bool is no number", BASE + char("1", FLAT + 'zone = true'),
     '[[characteristic]] #1 (id "1")', "zone", "must be a number"),
    ("infinite zone", BASE + char("1", FLAT + 'zone = inf'),
     '[[characteristic]] #1 (id "1")', "zone", "finite"),
    ("integer id", BASE + '\n[[characteristic]]\nid = 1\n' + FLAT + "zone = 0.1\n",
     "[[characteristic]] #1", "id", "must be a string"),
    ("box of 2D corners", BASE + region("D", "box = [[0, 0], [1, 1]]"),
     '[[region]] #6 (name "D")', "box", "[x, y, z]"),
    ("box of one corner", BASE + region("D", "box = [0, 0, 0]"),
     '[[region]] #6 (name "D")', "box", "two corners"),
    ("reference not an array", BASE + '[alignment]\nmethod = "datums"\nreference = "A"\n',
     "[alignment]", "reference", "must be an array"),
    ("empty region name", '[[region]]\nname = ""\nlabels = "A*"\n', "[[region]] #1", "name",
     "must not be empty"),
    # regions
    ("region without selector", BASE + region("D", 'measured_labels = "D*"'),
     '[[region]] #6 (name "D")', "box", "exactly one of"),
    ("region with two selectors", BASE + region("D", 'labels = "D*"\ngroup = "d"'),
     '[[region]] #6 (name "D")', "labels", "exactly one of"),
    ("box corners swapped", BASE + region("D", "box = [[0, 0, 1], [1, 1, 0]]"),
     '[[region]] #6 (name "D")', "box", "z: 1 >= 0"),
    ("flat box", BASE + region("D", "box = [[0, 0, 0], [1, 1, 0]]"),
     '[[region]] #6 (name "D")', "box", "must be below the upper corner"),
    ("region without name", BASE + '\n[[region]]\nlabels = "D*"\n', "[[region]] #6", "name",
     "is missing"),
    ("reserved characteristic id", BASE + char("TOL", FLAT + "zone = 0.1"),
     '[[characteristic]] #1 (id "TOL")', "id", "is reserved for the zone over all points"),
    # duplicates
    ("duplicate region", BASE + region("skin", 'labels = "S*"'), '[[region]] #6 (name "skin")',
     "name", 'is also the name of [[region]] #4'),
    ("duplicate datum", BASE + datum("B", "skin"), '[[datum]] #4 (label "B")', "label",
     "is also the label of [[datum]] #2"),
    ("duplicate characteristic", BASE + char("1", FLAT + "zone = 0.1") + char("1", FLAT +
                                                                            "zone = 0.2"),
     '[[characteristic]] #2 (id "1")', "id", "is also the id of [[characteristic]] #1"),
    ("duplicate rps", '[alignment]\nmethod = "rps"\n' + RPS + RPS, '[[rps]] #2 (label "R1")',
     "label", "is also the label of [[rps]] #1"),
    # datums
    ("datum on a missing region", BASE + datum("D", "flange"), '[[datum]] #4 (label "D")',
     "region", '"flange" is not the name of any [[region]]'),
    ("unknown feature", BASE + datum("D", "A", "planar"), '[[datum]] #4 (label "D")', "feature",
     "must be one of plane, cylinder, sphere, width, line, circle"),
    ("unknown datum fit", BASE + datum("D", "A", extra='fit = "minimax"'),
     '[[datum]] #4 (label "D")', "fit", "must be one of tangent, lsq"),
    ("datum without feature", BASE + '\n[[datum]]\nlabel = "D"\nregion = "A"\n',
     '[[datum]] #4 (label "D")', "feature", "is missing"),
    ("2D and 3D datums mixed", BASE + datum("D", "hole1", "circle"), '[[datum]] #4 (label "D")',
     "feature", "all 3D"),
    # alignment
    ("unknown method", BASE + '[alignment]\nmethod = "3-2-1"\n', "[alignment]", "method",
     "must be one of best-fit, datums, rps"),
    ("datums without reference", BASE + '[alignment]\nmethod = "datums"\n', "[alignment]",
     "reference", "is missing"),
    ("empty reference", BASE + '[alignment]\nmethod = "datums"\nreference = []\n',
     "[alignment]", "reference", "at least a primary"),
    ("reference to a missing datum", BASE + '[alignment]\nmethod = "datums"\n'
     'reference = ["A", "D"]\n', "[alignment]", "reference", '"D", which is not the label'),
    ("reference repeated", BASE + '[alignment]\nmethod = "datums"\nreference = ["A", "B", "A"]\n',
     "[alignment]", "reference", 'names "A" twice'),
    ("four datums", BASE + datum("D", "skin") + '[alignment]\nmethod = "datums"\n'
     'reference = ["A", "B", "C", "D"]\n', "[alignment]", "reference", "at most 3"),
    ("reference with best-fit", BASE + '[alignment]\nreference = ["A"]\n', "[alignment]",
     "reference", 'applies to method "datums" only'),
    ("best_fit_regions missing region", BASE + '[alignment]\nmethod = "datums"\n'
     'reference = ["A"]\nbest_fit_regions = ["skin", "flange"]\n', "[alignment]",
     "best_fit_regions", '"flange", which is not the name of any [[region]]'),
    # rps
    ("rps without points", BASE + '[alignment]\nmethod = "rps"\n', "[alignment]", "method",
     "needs [[rps]] points"),
    ("rps points without rps", BASE + RPS, "[alignment]", "method",
     'apply to method "rps" only'),
    ("rps without label", '[alignment]\nmethod = "rps"\n[[rps]]\nnominal = [0, 0, 0]\n'
     'lock = ["x"]\n', "[[rps]] #1", "label", "is missing"),
    ("rps nominal not a point", '[alignment]\nmethod = "rps"\n[[rps]]\nlabel = "R1"\n'
     'nominal = [0, 0]\nlock = ["x"]\n', '[[rps]] #1 (label "R1")', "nominal", "[x, y, z]"),
    ("rps without nominal", '[alignment]\nmethod = "rps"\n[[rps]]\nlabel = "R1"\nlock = ["x"]\n',
     '[[rps]] #1 (label "R1")', "nominal", "is missing"),
    ("rps lock empty", '[alignment]\nmethod = "rps"\n[[rps]]\nlabel = "R1"\n'
     'nominal = [0, 0, 0]\nlock = []\n', '[[rps]] #1 (label "R1")', "lock", "some of the axes"),
    ("rps lock unknown axis", '[alignment]\nmethod = "rps"\n[[rps]]\nlabel = "R1"\n'
     'nominal = [0, 0, 0]\nlock = ["x", "u"]\n', '[[rps]] #1 (label "R1")', "lock",
     "some of the axes x, y, z"),
    ("rps lock missing", '[alignment]\nmethod = "rps"\n[[rps]]\nlabel = "R1"\n'
     'nominal = [0, 0, 0]\n', '[[rps]] #1 (label "R1")', "lock", "is missing"),
    # characteristics
    ("unknown type", BASE + char("1", 'type = "surface_finish"\nregion = "A"\nzone = 0.1'),
     '[[characteristic]] #1 (id "1")', "type", "must be one of profile, flatness"),
    ("characteristic on a missing region", BASE + char("1", 'type = "flatness"\n'
                                                       'region = "flange"\nzone = 0.1'),
     '[[characteristic]] #1 (id "1")', "region", '"flange" is not the name of any [[region]]'),
    ("characteristic without region", BASE + char("1", 'type = "flatness"\nzone = 0.1'),
     '[[characteristic]] #1 (id "1")', "region", "is missing"),
    ("datums naming a missing datum", BASE + char("1", PROFILE + 'zone = 0.1\n'
                                                  'datums = ["A", "Z"]'),
     '[[characteristic]] #1 (id "1")', "datums", '"Z", which is not the label of any [[datum]]'),
    ("datums repeated", BASE + char("1", PROFILE + 'zone = 0.1\ndatums = ["A", "A"]'),
     '[[characteristic]] #1 (id "1")', "datums", 'names "A" twice'),
    ("zone zero", BASE + char("1", PROFILE + "zone = 0"), '[[characteristic]] #1 (id "1")',
     "zone", "must be > 0, got 0"),
    ("flatness zone negative", BASE + char("2", FLAT + "zone = -0.02"),
     '[[characteristic]] #1 (id "2")', "zone", "must be > 0, got -0.02"),
    ("position zone negative", BASE + char("3", POSITION + 'zone = -0.1\ndatums = ["A"]'),
     '[[characteristic]] #1 (id "3")', "zone", "must be > 0, got -0.1"),
    ("profile without zone", BASE + char("1", PROFILE), '[[characteristic]] #1 (id "1")',
     "zone", "is missing"),
    ("profile upper below lower", BASE + char("1", PROFILE + "lower = 0.05\nupper = -0.05"),
     '[[characteristic]] #1 (id "1")', "upper", "must be above 'lower'"),
    ("profile upper equal to lower", BASE + char("1", PROFILE + "lower = 0.05\nupper = 0.05"),
     '[[characteristic]] #1 (id "1")', "upper", "must be above 'lower'"),
    ("profile lower without upper", BASE + char("1", PROFILE + "lower = -0.05"),
     '[[characteristic]] #1 (id "1")', "upper", "is missing"),
    ("profile zone and limits", BASE + char("1", PROFILE + "zone = 0.1\nlower = -0.05\n"
                                            "upper = 0.05"),
     '[[characteristic]] #1 (id "1")', "zone", "both given"),
    ("unknown profile fit", BASE + char("1", PROFILE + 'zone = 0.1\nfit = "tangent"'),
     '[[characteristic]] #1 (id "1")', "fit", "must be one of lsq, minimax"),
    ("fit on a datum profile", BASE + char("1", PROFILE + 'zone = 0.1\ndatums = ["A"]\n'
                                           'fit = "minimax"'),
     '[[characteristic]] #1 (id "1")', "fit", "form-only profile"),
    ("fit on flatness", BASE + char("2", FLAT + 'zone = 0.1\nfit = "lsq"'),
     '[[characteristic]] #1 (id "2")', "fit", "form-only profile"),
    ("size without nominal", BASE + char("4", SIZE + "lower = -0.05\nupper = 0.05"),
     '[[characteristic]] #1 (id "4")', "nominal", "is missing"),
    ("size with zone", BASE + char("4", SIZE + "nominal = 8.0\nzone = 0.1"),
     '[[characteristic]] #1 (id "4")', "zone", "does not apply to size"),
    ("size without limits", BASE + char("4", SIZE + "nominal = 8.0"),
     '[[characteristic]] #1 (id "4")', "lower", "is missing"),
    ("size upper below lower", BASE + char("4", SIZE + "nominal = 8.0\nlower = 0.05\n"
                                           "upper = -0.05"),
     '[[characteristic]] #1 (id "4")', "upper", "must be above 'lower'"),
    ("size nominal not positive", BASE + char("4", SIZE + "nominal = 0\nlower = -0.05\n"
                                              "upper = 0.05"),
     '[[characteristic]] #1 (id "4")', "nominal", "must be > 0"),
    ("size lower eats the diameter", BASE + char("4", SIZE + "nominal = 1\nlower = -1\n"
                                                 "upper = 0.05"),
     '[[characteristic]] #1 (id "4")', "lower", "leaves no diameter"),
    # issue 22 item 9: absurd zones are refused as coordinates beyond 1e9 mm are
    ("zone of 1e300", BASE + char("1", PROFILE + "zone = 1e300"), '[[characteristic]] #1 (id '
     '"1")', "", "tolerance zone -5e+299 … 5e+299 mm: a limit 5e+299 mm from the nominal is "
     "beyond 1e6 mm (1 km)"),
    ("upper limit of 2e6", BASE + char("1", PROFILE + "lower = -0.1\nupper = 2e6"),
     '[[characteristic]] #1 (id "1")', "", "beyond 1e6 mm"),
    ("size nominal of 1e300", BASE + char("4", SIZE + "nominal = 1e300\nlower = -0.05\n"
                                          "upper = 0.05"),
     '[[characteristic]] #1 (id "4")', "nominal", "a diameter of 1e+300 mm, beyond 1e6 mm"),
    ("size with datums", BASE + char("4", SIZE + 'nominal = 8.0\nlower = -0.05\nupper = 0.05\n'
                                     'datums = ["A"]'),
     '[[characteristic]] #1 (id "4")', "datums", "relative to no datum"),
    ("nominal on a profile", BASE + char("1", PROFILE + "zone = 0.1\nnominal = 8.0"),
     '[[characteristic]] #1 (id "1")', "nominal", "applies to size only"),
    ("limits on flatness", BASE + char("2", FLAT + "zone = 0.1\nupper = 0.1"),
     '[[characteristic]] #1 (id "2")', "upper", "does not apply to flatness"),
    ("position without datums", BASE + char("3", POSITION + "zone = 0.1"),
     '[[characteristic]] #1 (id "3")', "datums", "at least one datum"),
    ("position with empty datums", BASE + char("3", POSITION + "zone = 0.1\ndatums = []"),
     '[[characteristic]] #1 (id "3")', "datums", "at least one datum"),
    ("flatness with datums", BASE + char("2", FLAT + 'zone = 0.02\ndatums = ["B"]'),
     '[[characteristic]] #1 (id "2")', "datums", "flatness is form only"),
    ("four datums on a characteristic", BASE + datum("D", "skin") +
     char("1", PROFILE.replace("skin", "hole1") + 'zone = 0.1\ndatums = ["A", "B", "C", "D"]'),
     '[[characteristic]] #1 (id "1")', "datums", "at most 3"),
    ("feature relative to itself", BASE + char("3", 'type = "position"\nregion = "C"\n'
                                               'zone = 0.1\ndatums = ["A", "C"]'),
     '[[characteristic]] #1 (id "3")', "datums", "cannot be related to itself"),
    # An orientation's feature: a plane (its default) or a width's median plane, nothing else.
    ("orientation of a cylinder feature", BASE + char("5", 'type = "perpendicularity"\n'
                                                      'region = "hole1"\nzone = 0.1\n'
                                                      'datums = ["A"]\nfeature = "cylinder"'),
     '[[characteristic]] #1 (id "5")', "feature", "must be one of"),
    ("a width's orientation as an axis", BASE + char("5", 'type = "parallelism"\n'
                                                     'region = "hole1"\nzone = 0.1\n'
                                                     'datums = ["A"]\nfeature = "width"\n'
                                                     'diametral = true'),
     '[[characteristic]] #1 (id "5")', "feature", "'diametral' (an axis) does not go with it"),
    ("a plane's orientation as an axis", BASE + char("5", 'type = "parallelism"\n'
                                                     'region = "hole1"\nzone = 0.1\n'
                                                     'datums = ["A"]\nfeature = "plane"\n'
                                                     'diametral = true'),
     '[[characteristic]] #1 (id "5")', "feature", "a plane's parallelism is held between two"),
    ("feature on flatness", BASE + char("2", FLAT + 'zone = 0.1\nfeature = "width"'),
     '[[characteristic]] #1 (id "2")', "feature",
     "applies to size, location and orientation only, not flatness"),
    # A characteristic of the plan's source the plan cannot judge (qa-inspect plan --toml).
    ("not_judged without reason", BASE + char("1", PROFILE + "zone = 0.1")
     + '[[not_judged]]\nid = "9"\ntype = "angle"\n', '[[not_judged]] #1 (id "9")', "reason",
     "is missing"),
    ("not_judged with a characteristic's id", BASE + char("1", PROFILE + "zone = 0.1")
     + '[[not_judged]]\nid = "1"\ntype = "angle"\nreason = "no angle"\n',
     '[[not_judged]] #1 (id "1")', "id", 'is also the id of [[characteristic]] #1'),
    ("not_judged unknown key", BASE + char("1", PROFILE + "zone = 0.1")
     + '[[not_judged]]\nid = "9"\ntype = "angle"\nreason = "r"\nzone = 1.0\n',
     '[[not_judged]] #1 (id "9")', "zone", "is not a key of [[not_judged]]"),
]


def test_a_characteristic_not_judged_is_read_and_keeps_the_part_from_accept(tmp_path):
    """[[not_judged]] (written by qa-inspect plan --toml for what a QIF holds and the plan
    cannot judge): read into Plan.not_judged, whose summary the verdict carries."""
    from engine.gdt.plan import NotJudged

    path = write(tmp_path, BASE + char("1", PROFILE + "zone = 0.1")
                 + '[[not_judged]]\nid = "9"\ntype = "angle"\nname = "Angular Size.1"\n'
                 'reason = "an angular size is no characteristic type of the plan layer"\n')
    plan = read_plan(path)
    assert plan.not_judged == (NotJudged("9", "angle", "Angular Size.1", "an angular size is "
                                         "no characteristic type of the plan layer"),)
    assert plan.not_judged_summary == ("1 of 2 characteristics of plan.toml are not judged "
                                       "yet: angle")


@pytest.mark.parametrize("text, table, key, words", [b[1:] for b in BAD],
                         ids=[b[0] for b in BAD])
def test_bad_plans_are_refused_naming_file_table_and_key(tmp_path, text, table, key, words):
    message = str(refused(tmp_path, text))
    assert table in message, message
    assert not key or f"'{key}'" in message, message
    assert words in message, message
    # The table comes first after the file (a top-level problem names no table there).
    if table:
        assert message.split(": ", 1)[1].startswith(table), message


def test_a_run_with_a_plan_parses_it_once_and_an_edited_plan_anew(monkeypatch, tmp_path):
    """qa-inspect --plan asks for the plan when it chooses the zone and again with the nominal:
    its bytes are parsed once (it parsed them twice, seconds at 10,000 characteristics); the
    same path with other bytes is parsed anew, never served stale."""
    import os
    import shutil

    import engine.io.plan as reader
    from qa_app.cli import main

    sample = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "samples",
                          "seat_bracket")
    plan = tmp_path / "plan.toml"
    shutil.copy(os.path.join(sample, "plan.toml"), plan)
    parsed = []
    real = reader._parse
    monkeypatch.setattr(reader, "_parse", lambda raw, path: parsed.append(path) or real(raw, path))
    args = ["inspect", os.path.join(sample, "nominal.xyz"), os.path.join(sample, "measured.csv"),
            "--plan", str(plan), "--json", str(tmp_path / "r.json")]
    assert main(args) == 1  # the sample's REJECT
    assert parsed == [str(plan)]
    plan.write_text(plan.read_text() + "\n# edited\n")
    assert read_plan(plan).sha256 == hashlib.sha256(plan.read_bytes()).hexdigest()
    assert len(parsed) == 2


def test_the_summary_of_many_kinds_not_judged_stays_short(tmp_path):
    """200 kinds not judged (one of them 5,000 characters long): the summary the verdict carries
    names 8 kinds, each at most 80 characters, and counts the rest (a certificate's verdict cell
    taller than a page ended in an internal error)."""
    long = "x" * 5000
    tables = "".join(f'[[not_judged]]\nid = "n{i}"\ntype = "kind {i}{long if i == 0 else ""}"'
                     f'\nreason = "r"\n' for i in range(200))
    plan = read_plan(write(tmp_path, BASE + char("1", PROFILE + "zone = 0.1") + tables))
    summary = plan.not_judged_summary
    assert summary.startswith("200 of 201 characteristics of plan.toml are not judged yet: ")
    assert summary.endswith(" and 192 more kinds") and len(summary) < 1000
    assert "kind 7" in summary and "kind 8" not in summary
