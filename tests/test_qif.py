"""QIF 3.0 results export: valid against the official schemas, faithful to the inspection (points,
deviations, zone, status), deterministic.

The documents come from real inspections of the bundled samples through the command line; the
JSON and CSV it writes are read back as the inputs, and the QIF is checked against them with an
independent parser (lxml), not with reports.qif's own code.
"""

import copy
import csv
import json
import os

import numpy as np
import pytest
from lxml import etree

from qa_app.cli import main
from reports.qif import qif_results_document

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
XSD = os.path.join(ROOT, "tests", "data", "qif-3.0-xsd", "QIFDocument.xsd")
# Loading the schema set (20 files) once for the whole module.
SCHEMA = etree.XMLSchema(etree.parse(XSD))
NS = {"q": "http://qifstandards.org/xsd/qif3"}
STATUS = {"ACCEPT": ("PASS", "PASS"), "REJECT": ("FAIL", "FAIL"),
          "INCONCLUSIVE": ("INDETERMINATE", "UNKNOWN")}

BELLY = ("samples/belly_fairing/nominal.csv", "samples/belly_fairing/measured.csv")
FRAME = ("samples/fuselage_frame/template.dxf", "samples/fuselage_frame/measured.csv")
# The belly fairing's points measured against the seat bracket: not this part, no trusted pose.
WRONG_PART = ("samples/seat_bracket/nominal.xyz", "samples/belly_fairing/measured.csv")
CASES = {
    "accept": (BELLY, ["--tol", "0.25"]),
    "reject": (BELLY, ["--tol", "0.05"]),
    "inconclusive": (WRONG_PART, ["--tol", "0.05"]),
    "template": (FRAME, ["--tol", "0.05"]),
    "asymmetric": (FRAME, ["--tol-lower", "-0.1", "--tol-upper", "0.3"]),
}
CERTIFICATE = {"number": "QA-2024-0042", "part_number": "D52-1100-7",
               "part_name": "Belly fairing", "serial": "SN 0815 & <7>", "revision": "C",
               "order": "PO-77", "inspector": "A. Inspector", "organisation": "ACME Aero QA",
               "device": "Laser tracker LT-3", "issued": "2024-05-01T12:30:00+02:00"}


class Inspection:
    """One command-line inspection read back: the JSON document and the CSV's per-point columns."""

    def __init__(self, d, files, args):
        nominal, measured = (os.path.join(ROOT, f) for f in files)
        self.code = main(["inspect", nominal, measured, *args, "--json", str(d / "r.json"),
                          "--csv", str(d / "r.csv")])
        with open(d / "r.json") as f:
            self.doc = json.load(f)
        with open(d / "r.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        self.registered = np.array([[float(r[k]) for k in ("x_reg", "y_reg", "z_reg")]
                                    for r in rows])
        self.deviations = np.array([float(r["deviation"]) for r in rows])
        self.inside = np.array([r["in_tolerance"] == "true" for r in rows])
        self.labels = np.array([r["label"] for r in rows])

    def qif(self, doc=None, **kw) -> bytes:
        return qif_results_document(self.doc if doc is None else doc, self.registered,
                                    self.deviations, self.inside, self.labels, **kw)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    for name, (files, args) in CASES.items():
        out[name] = Inspection(tmp_path_factory.mktemp(name), files, args)
    return out


def parse_valid(data: bytes):
    tree = etree.ElementTree(etree.fromstring(data))
    assert SCHEMA.validate(tree), "\n".join(str(e) for e in SCHEMA.error_log)
    return tree.getroot()


def one(root, path):
    found = root.xpath(path, namespaces=NS)
    assert len(found) == 1, (path, len(found))
    return found[0]


def numbers(el):
    return np.array([float(v) for v in el.text.split()])


def attribute(point_set, name):
    return one(point_set, f"q:Attributes/q:AttributeStr[@name='{name}']").get("value")


@pytest.mark.parametrize("case, verdict", [("accept", "ACCEPT"), ("reject", "REJECT"),
                                           ("inconclusive", "INCONCLUSIVE"),
                                           ("template", "ACCEPT")])
def test_valid_and_faithful(runs, case, verdict):
    run = runs[case]
    assert run.doc["verdict"] == verdict and run.code == {"ACCEPT": 0, "REJECT": 1,
                                                          "INCONCLUSIVE": 2}[verdict]
    root = parse_valid(run.qif())
    assert root.get("versionQIF") == "3.0.0"
    n = run.deviations.size
    assert n == run.doc["deviations"]["count"] > 0

    ps = one(root, "//q:MeasurementResults/q:MeasuredPointSets/q:MeasuredPointSet")
    assert int(ps.get("count")) == n
    pts = numbers(one(ps, "q:Points")).reshape(-1, 3)
    dev = numbers(one(ps, "q:Deviations"))
    assert pts.shape == (n, 3) and dev.shape == (n,)
    np.testing.assert_allclose(pts, run.registered, rtol=0, atol=1e-6)
    np.testing.assert_allclose(dev, run.deviations, rtol=0, atol=1e-6)
    flags = attribute(ps, "qa-inspect:in-tolerance")
    assert flags == "".join("1" if v else "0" for v in run.inside)
    assert json.loads(attribute(ps, "qa-inspect:labels")) == list(run.labels)

    char_status, inspection_status = STATUS[verdict]
    profile = "LineProfile" if case == "template" else "SurfaceProfile"
    meas = one(root, f"//q:MeasuredCharacteristics//q:{profile}CharacteristicMeasurement")
    assert one(meas, "q:Status/q:CharacteristicStatusEnum").text == char_status
    assert one(root, "//q:MeasurementResults/q:InspectionStatus/q:InspectionStatusEnum").text \
        == inspection_status
    assert float(one(meas, "q:WorstPositiveDeviation").text) == pytest.approx(
        run.deviations.max(), abs=1e-6)
    assert float(one(meas, "q:WorstNegativeDeviation").text) == pytest.approx(
        run.deviations.min(), abs=1e-6)

    # The measurement chain resolves: characteristic -> feature measurement -> this point set.
    fm_id = one(meas, "q:FeatureMeasurementIds/q:Id").text
    fm = one(root, f"//q:MeasuredFeatures/*[@id='{fm_id}']")
    assert one(fm, "q:PointList/q:WholePointSetId").text == ps.get("id")
    assert fm.tag.endswith("OtherCurveFeatureMeasurement" if case == "template"
                           else "OtherSurfaceFeatureMeasurement")
    ids = [int(v) for v in root.xpath("//@id")]
    assert len(ids) == len(set(ids)) and int(root.get("idMax")) == max(ids)


def test_symmetric_zone_and_value(runs):
    run = runs["reject"]
    root = parse_valid(run.qif())
    definition = one(root, "//q:SurfaceProfileCharacteristicDefinition")
    assert float(one(definition, "q:ToleranceValue").text) == pytest.approx(0.1, abs=1e-9)
    assert not definition.xpath("q:OuterDisposition", namespaces=NS)
    value = float(one(root, "//q:SurfaceProfileCharacteristicMeasurement/q:Value").text)
    assert value == pytest.approx(2 * np.abs(run.deviations).max(), abs=2e-6)
    assert value > 0.1  # REJECT: the points need a wider zone than the tolerance


def test_asymmetric_zone_round_trips(runs):
    run = runs["asymmetric"]
    assert (run.doc["tolerance"]["lower"], run.doc["tolerance"]["upper"]) == (-0.1, 0.3)
    root = parse_valid(run.qif())
    definition = one(root, "//q:LineProfileCharacteristicDefinition")
    width = float(one(definition, "q:ToleranceValue").text)
    upper = float(one(definition, "q:OuterDisposition").text)
    assert upper == pytest.approx(0.3, abs=1e-9)
    assert upper - width == pytest.approx(-0.1, abs=1e-9)
    assert one(root, "//q:LineProfileCharacteristicNominal/q:Vector").text.split() == \
        ["0", "0", "1"]
    # Value is the width of the smallest zone centred like [-0.1, 0.3] that holds every point.
    value = float(one(root, "//q:LineProfileCharacteristicMeasurement/q:Value").text)
    assert value == pytest.approx(2 * np.abs(run.deviations - 0.1).max(), abs=2e-6)
    assert (value <= width) == (run.doc["verdict"] == "ACCEPT")


def test_certificate_traceability(runs):
    run = runs["accept"]
    doc = dict(run.doc, certificate=CERTIFICATE)
    root = parse_valid(run.qif(doc))
    mr = one(root, "//q:MeasurementResults")
    assert one(mr, "q:InspectionTraceability/q:ReportNumber").text == "QA-2024-0042"
    assert one(mr, "q:InspectionTraceability/q:OrderNumber").text == "PO-77"
    assert one(mr, "q:InspectionTraceability/q:InspectionOperator/q:Name").text == "A. Inspector"
    assert one(mr, "q:InspectionTraceability/q:InspectingOrganization/q:Name").text == \
        "ACME Aero QA"
    assert one(mr, "q:InspectionTraceability/q:ReportPreparationDate").text == \
        "2024-05-01T10:30:00Z"
    part = one(root, "//q:Product/q:PartSet/q:Part")
    assert one(part, "q:ModelNumber").text == "D52-1100-7"
    assert one(part, "q:Header/q:Name").text == "Belly fairing"
    assert one(part, "q:Version").text == "C"
    assert one(part, "q:DefinitionExternal/q:DigitalModel/q:Name").text == "nominal.csv"
    serial = one(root, "//q:ActualComponentSets//q:ActualComponent")
    assert one(serial, "q:SerialNumber").text == "SN 0815 & <7>"
    assert one(mr, "q:ActualComponentIds/q:Id").text == serial.get("id")
    device = one(root, "//q:MeasurementResources//q:MeasurementDevice")
    assert one(device, "q:Name").text == "Laser tracker LT-3"
    assert one(mr, "q:MeasuredPointSets/q:MeasuredPointSet/q:MeasurementDeviceId").text == \
        device.get("id")
    assert one(root, "q:Header/q:Application/q:Name").text.startswith("qa-inspect ")
    # No device named: no MeasurementResources at all.
    bare = dict(run.doc, certificate={"number": "X-1", "device": None})
    assert not parse_valid(run.qif(bare)).xpath("//q:MeasurementResources", namespaces=NS)


def test_deterministic(runs):
    run = runs["template"]
    doc = dict(run.doc, certificate=CERTIFICATE)
    first = run.qif(copy.deepcopy(doc), outlier=run.deviations > 0.02)
    assert run.qif(copy.deepcopy(doc), outlier=run.deviations > 0.02) == first
    other = run.qif(dict(doc, certificate=dict(CERTIFICATE, number="QA-2024-0043")),
                    outlier=run.deviations > 0.02)
    qpid = "q:QPId"
    assert one(etree.fromstring(other), qpid).text != one(etree.fromstring(first), qpid).text
    ps = one(parse_valid(first), "//q:MeasuredPointSet")
    assert attribute(ps, "qa-inspect:excluded-from-alignment") == "".join(
        "1" if v else "0" for v in run.deviations > 0.02)


def test_schema_checks_references(runs):
    """The validation is worth something: a dangling reference is caught (key/keyref)."""
    root = etree.fromstring(runs["accept"].qif())
    one(root, "//q:SurfaceProfileCharacteristicMeasurement/q:CharacteristicItemId").text = "9999"
    assert not SCHEMA.validate(etree.ElementTree(root))


def test_full_precision_inputs_and_non_finite(runs):
    """Unrounded arrays come back within half a nanometre; NaN stays a valid xs:double."""
    rng = np.random.default_rng(7)
    n = 5000
    pts = rng.uniform(-2000, 2000, (n, 3))
    dev = rng.normal(0, 0.1, n)
    dev[17] = np.nan
    doc = copy.deepcopy(runs["accept"].doc)
    root = parse_valid(qif_results_document(doc, pts, dev, np.abs(dev) <= 0.25))
    ps = one(root, "//q:MeasuredPointSet")
    np.testing.assert_allclose(numbers(one(ps, "q:Points")).reshape(-1, 3), pts, rtol=0,
                               atol=5e-7 + 1e-9)
    back = numbers(one(ps, "q:Deviations"))
    assert np.isnan(back[17]) and np.isnan(back).sum() == 1
    finite = np.isfinite(dev)
    np.testing.assert_allclose(back[finite], dev[finite], rtol=0, atol=5e-7 + 1e-12)
    assert ps.xpath("q:Attributes/q:AttributeStr[@name='qa-inspect:labels']",
                    namespaces=NS) == []


def test_arguments_that_do_not_fit_are_errors_of_the_product(runs):
    """Per-point arrays of another length, an unknown verdict or an issue time that is no time:
    a QAError (also a ValueError, as before) naming the problem, and no document."""
    from engine.errors import QAError

    run = runs["accept"]
    n = len(run.deviations)
    cases = [
        (lambda: qif_results_document(run.doc, run.registered[:, :1], run.deviations,
                                      run.inside), r"registered must be \(n, 3\)"),
        (lambda: qif_results_document(run.doc, run.registered, run.deviations[1:], run.inside),
         f"deviations has {n - 1} entries for {n} points"),
        (lambda: qif_results_document(run.doc, run.registered, run.deviations, run.inside[:3]),
         f"in_tolerance has 3 entries for {n} points"),
        (lambda: run.qif(outlier=np.zeros(n + 1, bool)), f"outlier has {n + 1} entries"),
        (lambda: qif_results_document(run.doc, run.registered, run.deviations, run.inside,
                                      ["a"]), f"labels has 1 entries for {n} points"),
        (lambda: run.qif(dict(run.doc, verdict="PASSED")), "unknown verdict 'PASSED'"),
        (lambda: run.qif(dict(run.doc, certificate={"issued": "yesterday"})),
         "certificate 'issued' is not an ISO 8601 time: 'yesterday'"),
    ]
    for make, message in cases:
        with pytest.raises(QAError, match=message) as caught:
            make()
        assert isinstance(caught.value, ValueError)
