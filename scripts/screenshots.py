"""Regenerate every screenshot of docs/screenshots/ from the bundled samples.

    .venv/bin/python scripts/screenshots.py [OUT_DIR]

The certificate pages (:func:`certificate_pages`; :func:`demo_signed_first_page`: page 1
signed with a demonstration identity; :func:`section_page`: a section page), the desktop app at 1366x768 and 1920x1080
(scripts/app_screenshots.py, on virtual X displays: needs xvfb-run) and the SPC page of a
drifting lot (scripts/spc_screenshot.py).

:func:`certificate_pages` writes PNGs of the certificate pages that show the deviation maps
(the belly fairing at +-0.25 mm, the seat bracket judged by its plan, the fuselage frame's 2D
contour) and of every page of the belly fairing's certificate. It runs ``qa-inspect inspect
… --report`` as an inspector would and renders pages with poppler's ``pdftoppm``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CERTIFICATES = [
    ("belly_fairing", ["samples/belly_fairing/nominal.csv", "samples/belly_fairing/measured.csv",
                       "--tol", "0.25"]),
    ("seat_bracket", ["samples/seat_bracket/nominal.xyz", "samples/seat_bracket/measured.csv",
                      "--plan", "samples/seat_bracket/plan.toml"]),
    ("fuselage_frame", ["samples/fuselage_frame/template.dxf",
                        "samples/fuselage_frame/measured.csv",
                        "--plan", "samples/fuselage_frame/plan.toml"]),
]
PART = ["--part-number", "SAMPLE-1", "--serial", "SN-0001", "--inspector", "Screenshot script",
        "--organisation", "qa-inspect samples"]


def certificate_pages(out_dir: str, dpi: int = 80) -> list[str]:
    """Write ``certificate_<sample>_map.png`` (the page with section 7, the deviation map) for
    each sample and ``certificate_belly_fairing_p<k>.png`` for every page of the belly
    fairing's certificate into ``out_dir``; return the paths written."""
    os.makedirs(out_dir, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    written = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, args in CERTIFICATES:
            pdf = os.path.join(tmp, f"{name}.pdf")
            r = subprocess.run([sys.executable, "-m", "qa_app.cli", "inspect", *args,
                                "--report", pdf, *PART], cwd=ROOT, env=env,
                               capture_output=True, text=True)
            if r.returncode not in (0, 1, 2):
                raise SystemExit(f"{name}: qa-inspect exit {r.returncode}: {r.stderr}")
            pages = _page_count(pdf)
            for page in range(1, pages + 1):
                text = subprocess.run(["pdftotext", "-f", str(page), "-l", str(page), pdf, "-"],
                                      capture_output=True, text=True, check=True).stdout
                every = name == "belly_fairing"
                if "Deviation map" in text or every:
                    stem = f"certificate_{name}_" + ("map" if "Deviation map" in text and
                                                     not every else f"p{page}")
                    written.append(_render(pdf, page, dpi, os.path.join(out_dir, stem)))
    return written


def demo_signed_first_page(out_dir: str, dpi: int = 60) -> str:
    """Write ``certificate_demo_signed_p1.png``: page 1 of the belly fairing's certificate
    signed with a demonstration identity made by ``qa-inspect keygen`` (page 1 says so, as
    section 11 does); return its path."""
    os.makedirs(out_dir, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""),
               QA_SCREENSHOT_PASS="screenshot-demo-passphrase")
    with tempfile.TemporaryDirectory() as tmp:
        ident = os.path.join(tmp, "id")
        subprocess.run([sys.executable, "-m", "qa_app.cli", "keygen", "--name",
                        "Screenshot script", "--organisation", "qa-inspect samples", "--out",
                        ident, "--pass-env", "QA_SCREENSHOT_PASS"], cwd=ROOT, env=env,
                       check=True, capture_output=True)
        pdf = os.path.join(tmp, "signed.pdf")
        r = subprocess.run([sys.executable, "-m", "qa_app.cli", "inspect",
                            *CERTIFICATES[0][1], "--report", pdf, *PART, "--sign",
                            os.path.join(ident, "inspector.p12"), "--sign-pass-env",
                            "QA_SCREENSHOT_PASS"], cwd=ROOT, env=env, capture_output=True,
                           text=True)
        if r.returncode != 0:
            raise SystemExit(f"signed certificate: qa-inspect exit {r.returncode}: {r.stderr}")
        return _render(pdf, 1, dpi, os.path.join(out_dir, "certificate_demo_signed_p1"))


def section_page(out_dir: str, dpi: int = 80) -> str:
    """Write ``certificate_section.png``: the section page of the belly fairing's certificate
    at +-0.05 mm cut through its dent (``--section y=-40``); return its path."""
    os.makedirs(out_dir, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    with tempfile.TemporaryDirectory() as tmp:
        pdf = os.path.join(tmp, "section.pdf")
        r = subprocess.run([sys.executable, "-m", "qa_app.cli", "inspect",
                            *CERTIFICATES[0][1][:2], "--tol", "0.05", "--section", "y=-40",
                            "--report", pdf, *PART], cwd=ROOT, env=env, capture_output=True,
                           text=True)
        if r.returncode not in (0, 1, 2):
            raise SystemExit(f"section: qa-inspect exit {r.returncode}: {r.stderr}")
        text = subprocess.run(["pdftotext", pdf, "-"], capture_output=True, text=True,
                              check=True).stdout
        page = next(k for k, t in enumerate(text.split("\f"), 1) if "Section A-A" in t)
        return _render(pdf, page, dpi, os.path.join(out_dir, "certificate_section"))


def _page_count(pdf: str) -> int:
    info = subprocess.run(["pdfinfo", pdf], capture_output=True, text=True, check=True).stdout
    return int(next(line.split()[-1] for line in info.splitlines()
                    if line.startswith("Pages:")))


def _render(pdf: str, page: int, dpi: int, stem: str) -> str:
    subprocess.run(["pdftoppm", "-f", str(page), "-l", str(page), "-r", str(dpi), "-png",
                    "-singlefile", pdf, stem], check=True)
    return stem + ".png"


def main(out: str) -> list[str]:
    sys.path.insert(0, os.path.join(ROOT, "scripts"))
    sys.path.insert(0, ROOT)
    import app_screenshots
    import spc_screenshot

    return (certificate_pages(out) + [demo_signed_first_page(out), section_page(out)]
            + app_screenshots.app_screenshots(out, cases=tuple(app_screenshots.CASES))
            + [spc_screenshot.main(out)])


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out", nargs="?", metavar="OUT_DIR",
                   default=os.path.join(ROOT, "docs", "screenshots"),
                   help="the folder the PNGs are written to (default: docs/screenshots)")
    return p.parse_args(argv)


if __name__ == "__main__":
    for path in main(parse_args().out):
        print(path)
