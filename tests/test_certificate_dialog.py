"""The certificate dialog's traceability fields (Qt offscreen): each one reaches the
certificate's CertificateInfo as the command line's option would, a calibration date that is no
date or a temperature that is no number is said in the dialog, which stays open."""

from reports.certificate import TRACEABILITY, CertificateInfo
from qa_app.desktop.dialogs import CertificateDialog

TYPED = {"device": "Zeiss Contura G2", "device_serial": "C-4711",
         "calibration_date": "2025-03-01", "probe": "VAST XT, 3 mm ruby",
         "temperature_c": "21,5", "program": "SB-1020_C.mpp", "drawing": "SB-1020-D",
         "cad_revision": "C.2"}


def test_traceability_fields_reach_the_certificate(qtbot, tmp_path):
    d = CertificateDialog(None, {"device": "Laser tracker LT-3"}, str(tmp_path / "c.pdf"))
    qtbot.addWidget(d)
    assert [k for k, _ in TRACEABILITY] == list(TYPED)
    assert d.edits["device"].text() == "Laser tracker LT-3"  # a remembered default
    for key, text in TYPED.items():
        d.edits[key].setText(text)
    info = d.info()
    assert isinstance(info, CertificateInfo)
    want = dict(TYPED, temperature_c=21.5)  # a decimal comma is read as a point
    assert {k: getattr(info, k) for k in TYPED} == want
    assert d.problems() is None


def test_traceability_fields_that_are_wrong_are_said(qtbot, tmp_path):
    d = CertificateDialog(None, {}, str(tmp_path / "c.pdf"))
    qtbot.addWidget(d)
    d.edits["calibration_date"].setText("1 March 2025")
    assert d.problems() == "calibration date: '1 March 2025' is not a date YYYY-MM-DD"
    d.accept()
    assert d.result() != CertificateDialog.Accepted and d.problem.isVisibleTo(d)
    d.edits["calibration_date"].setText("2025-03-01")
    d.edits["temperature_c"].setText("warm")
    assert d.problems() == "temperature: 'warm' is not a number (°C)"
    d.edits["temperature_c"].setText("")
    assert d.problems() is None and d.info().temperature_c is None
