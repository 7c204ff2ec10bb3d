"""``qa-inspect``'s subcommands and their options (argparse): what each option means, its
type and its help. The command line (qa_app.cli) builds its parser over :func:`add_commands`."""

from __future__ import annotations

import argparse
import math

from engine.choices import DecisionRule, Fit
from engine.seeds import DEFAULT_SEED
from qa_app.sections import BAND_HELP, SECTION_HELP, section_spec
from qa_app.usage import EXAMPLES, EXIT_CODES


def add_commands(sub: argparse._SubParsersAction) -> None:
    """The subcommands ``inspect``, ``batch``, ``keygen``, ``verify``, ``faces`` and ``plan``,
    with their options."""
    _add_inspect(sub)
    _add_batch(sub)
    _add_keygen(sub)
    _add_verify(sub)
    _add_faces(sub)
    _add_plan(sub)


NOMINAL_HELP = ("nominal: points (.csv .txt .xyz .asc .npy, optional I J K normals, '# grid: NU x "
                "NV' header for a u-v grid), mesh (.stl .ply .obj .vtk .vtp), structured grid "
                "(.vts), an E57 scan (.e57: every scan in the file's frame), a STEP model (.stp "
                ".step: deviations exact to its faces), or a 2D "
                "contour template: a DXF drawing (.dxf) or airfoil ordinates (.dat, with "
                "--scale)")


def _finite_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"'{text}' is not a finite number")
    return v


def _seed(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"'{text}' is negative (a seed is >= 0)")
    return v


def _add_inspect(sub: argparse._SubParsersAction) -> None:
    """``qa-inspect inspect NOMINAL MEASURED``: the inputs, the tolerance zone (mm), the
    template options, the fit and decision rule, the JSON and CSV outputs, and the certificate."""
    i = sub.add_parser("inspect", help="register measured points to a nominal and judge them",
                       description="Register MEASURED to NOMINAL from any pose, measure every "
                       "point's signed deviation (positive = excess material, mm) and judge it "
                       "against the tolerance zone. Exit code 0 ACCEPT, 1 REJECT, 2 INCONCLUSIVE.",
                       epilog=EXAMPLES + "\n\n" + EXIT_CODES,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    i.add_argument("nominal", metavar="NOMINAL",
                   help=NOMINAL_HELP)
    i.add_argument("measured", metavar="MEASURED", help="measured points (same formats)")
    _add_zone_options(i)
    _add_template_options(i)
    _add_fit_options(i)
    _add_scene_options(i)
    g = i.add_argument_group("sections")
    g.add_argument("--section", action="append", type=section_spec, metavar="AXIS=MM",
                   help=SECTION_HELP)
    g.add_argument("--section-band", type=_finite_float, metavar="MM", help=BAND_HELP)
    i.add_argument("--json", metavar="FILE|-", help="write the JSON results (- for stdout)")
    i.add_argument("--csv", metavar="FILE|-",
                   help="write one CSV row per measured point (- for stdout)")
    i.add_argument("--qif", metavar="FILE|-",
                   help="write the QIF 3.0 results (- for stdout); with a QIF plan, that "
                        "plan's own document with results referencing its ids")
    i.add_argument("--quiet", action="store_true",
                   help="no progress line on the terminal (drawn when a run lasts over 2 s)")
    _add_certificate_options(i)


def _add_zone_options(i: argparse.ArgumentParser) -> None:
    """The tolerance zone (mm) or the inspection plan, of ``inspect`` and ``batch``."""
    i.add_argument("--tol", type=_finite_float, metavar="T",
                   help="symmetric tolerance: deviations within ±T mm are in tolerance")
    i.add_argument("--tol-lower", type=_finite_float, metavar="L",
                   help="lower limit of an asymmetric zone, mm (e.g. -0.1)")
    i.add_argument("--tol-upper", type=_finite_float, metavar="U",
                   help="upper limit of an asymmetric zone, mm (e.g. 0.3)")
    i.add_argument("--plan", metavar="PLAN.toml",
                   help="inspection plan: regions, datums, alignment and characteristics "
                        "(profile, flatness, position, size), or a QIF 3.0 MBD (PART.qif) "
                        "with a STEP nominal; with it --tol is optional and adds a profile "
                        "over all points")


def _add_template_options(i: argparse.ArgumentParser) -> None:
    """How a 2D template file is read (engine.io.templates), of ``inspect`` and ``batch``."""
    i.add_argument("--layer", action="append", metavar="NAME",
                   help="DXF template: take this layer (repeatable; default: every layer)")
    i.add_argument("--units", metavar="U", choices=["mm", "cm", "m", "in"],
                   help="DXF template: its units, overriding the file's $INSUNITS")
    i.add_argument("--scale", type=_finite_float, metavar="CHORD",
                   help="airfoil ordinate template (.dat): chord length in mm")


def _add_fit_options(i: argparse.ArgumentParser) -> None:
    """The fit and the decision rule, of ``inspect`` and ``batch``."""
    i.add_argument("--fit", choices=list(Fit), default=Fit.LSQ,
                   help="lsq: least-squares best fit (default); minimax: the pose minimising the "
                        "largest excursion from the zone's centre ('can the part be placed "
                        "inside its zone?')")
    i.add_argument("--decision-rule", choices=list(DecisionRule), default=None,
                   help="simple: every point inside the zone (the default without an "
                        "instrument); guarded (ISO 14253-1, the default with --uncertainty or a "
                        "plan's [measurement] instrument): accept inside the zone shrunk by each "
                        "point's expanded uncertainty U, reject outside the zone grown by it, "
                        "INCONCLUSIVE between")
    i.add_argument("--uncertainty", type=_finite_float, metavar="U",
                   help="the instrument's expanded measurement uncertainty, mm (k = 2); "
                        "combined per point with the registration's pose uncertainty and the "
                        "nominal-sampling margin (replaces a plan's [measurement] instrument)")
    i.add_argument("--seed", type=_seed, metavar="N", default=DEFAULT_SEED,
                   help="the seed of every random choice of the inspection (seeded subsets of "
                        "the points, RANSAC); the same files, options and seed give the same "
                        f"numbers (default {DEFAULT_SEED}; reported in the JSON's settings)")


def _add_scene_options(i: argparse.ArgumentParser) -> None:
    """The measured scene's crop and plane removal (engine.scene), of ``inspect`` and
    ``batch``."""
    g = i.add_argument_group("measured scene (a scan holding more than the part)")
    g.add_argument("--crop", type=_finite_float, nargs=6,
                   metavar=("XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX"),
                   help="inspect only the measured points inside this box (mm, the measured "
                        "file's coordinates)")
    g.add_argument("--remove-plane", action="store_true",
                   help="remove the dominant plane (the table under the part) from the measured "
                        "points, after the crop (seeded RANSAC; the distance from the data: 3 "
                        "robust standard deviations of the plane's points, at least their "
                        "spacing), and the other objects standing on it")
    g.add_argument("--remove-plane-distance", type=_finite_float, metavar="MM",
                   help="with --remove-plane: remove the points within MM of the plane")


def _add_certificate_options(i: argparse.ArgumentParser) -> None:
    """The ``certificate`` group of ``inspect``: the PDF, its signing identity and the fields
    printed on it."""
    c = i.add_argument_group("certificate")
    c.add_argument("--report", metavar="FILE.pdf",
                   help="write the inspection certificate (PDF; an UNSIGNED DRAFT without "
                        "--sign)")
    c.add_argument("--sign", metavar="IDENTITY.p12",
                   help="sign the certificate with this PKCS#12 identity (PAdES)")
    c.add_argument("--sign-pass-env", metavar="VAR",
                   help="read the PKCS#12 passphrase from environment variable VAR (default: "
                        "ask without echo)")
    _add_part_fields(c, PART_FIELDS)
    _add_traceability_options(c)


PART_FIELDS = (("part-number", "part number"), ("part-name", "part name"),
               ("revision", "drawing/part revision"), ("serial", "serial number"),
               ("order", "order or job number"),
               ("inspector", "inspector's name (signed: the signer's, which is the default)"),
               ("organisation", "inspecting organisation"),
               ("device", "measuring device (CMM, scanner)"),
               ("notes", "free text printed on the certificate"))
"""The certificate's fields the inspector states (``--part-number TEXT``, ...)."""


def _add_part_fields(group, fields) -> None:
    for name, text in fields:
        group.add_argument(f"--{name}", metavar="TEXT", help=text)


def _add_batch(sub: argparse._SubParsersAction) -> None:
    """``qa-inspect batch NOMINAL MEASURED...``: the parts, the zone or plan, the output folder,
    the certificates, and the Dask cluster."""
    b = sub.add_parser("batch", help="inspect many parts against one nominal (on Dask)",
                       description="Inspect every MEASURED part against NOMINAL on a local Dask "
                       "cluster (or an existing one, --scheduler) and write DIR/parts/SERIAL."
                       "json/.csv (and .pdf with --report), DIR/summary.csv and "
                       "DIR/summary.json. A part that fails is an ERROR row. Re-running skips "
                       "the parts already done for the same inputs and settings. Exit code 0 "
                       "all ACCEPT, else 1 any REJECT, else 2 any INCONCLUSIVE, else 65.")
    b.add_argument("nominal", metavar="NOMINAL", help=NOMINAL_HELP)
    b.add_argument("measured", metavar="MEASURED", nargs="+",
                   help="measured files or quoted globs ('lot7/*.csv'), one part each, in "
                        "measurement order (a glob's matches sorted by name); a part's serial "
                        "is its file's stem")
    _add_zone_options(b)
    _add_template_options(b)
    b.add_argument("--out", required=True, metavar="DIR", help="output folder")
    _add_fit_options(b)
    _add_scene_options(b)
    c = b.add_argument_group("certificates")
    c.add_argument("--report", action="store_true",
                   help="write each part's certificate DIR/parts/SERIAL.pdf (an UNSIGNED DRAFT "
                        "without --sign)")
    c.add_argument("--sign", metavar="IDENTITY.p12",
                   help="sign the certificates with this PKCS#12 identity (in this process: the "
                        "key is never sent to the workers)")
    c.add_argument("--sign-pass-env", metavar="VAR",
                   help="read the PKCS#12 passphrase from environment variable VAR (default: "
                        "ask without echo)")
    _add_part_fields(c, [(name, "part number (also the title of the lot's spc.pdf, with or "
                          "without --report)" if name == "part-number" else text)
                         for name, text in PART_FIELDS if name != "serial"])
    _add_traceability_options(c)
    d = b.add_argument_group("cluster")
    d.add_argument("--scheduler", metavar="ADDRESS",
                   help="the Dask scheduler of an existing cluster (tcp://HOST:PORT); its "
                        "workers must read the files at the same paths")
    d.add_argument("--workers", type=int, metavar="N",
                   help="worker processes of the local cluster (default: the cores)")
    d.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_traceability_options(c) -> None:
    """The certificate's traceability fields (also the plan's [measurement] and [part] keys,
    which fill in what is not given here)."""
    for name, text in (("device-serial", "the measuring device's serial number"),
                       ("probe", "probe and stylus (e.g. 'TP20, M2 ruby 2 x 20 mm')"),
                       ("program", "measurement program (name or file)"),
                       ("drawing", "drawing number (its revision: --revision)"),
                       ("cad-revision", "revision of the CAD model (the nominal)")):
        c.add_argument(f"--{name}", metavar="TEXT", help=text)
    c.add_argument("--calibration-date", metavar="YYYY-MM-DD", type=_iso_date,
                   help="the measuring device's last calibration")
    c.add_argument("--temperature", metavar="C", type=_finite_float, dest="temperature_c",
                   help="the part's temperature during the measurement, °C")


def _iso_date(text: str) -> str:
    import datetime as dt

    try:
        return dt.date.fromisoformat(text.strip()).isoformat()
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a date YYYY-MM-DD") from None


def _add_keygen(sub: argparse._SubParsersAction) -> None:
    """``qa-inspect keygen``: a demonstration CA and inspector identity."""
    k = sub.add_parser("keygen", help="make a DEMONSTRATION CA and inspector signing identity",
                       description="Write DIR/ca.pem (the trust anchor to give verifiers) and "
                       "DIR/inspector.p12 (the inspector's key and certificate, passphrase-"
                       "protected). For trials and demonstrations only: real users sign with "
                       "the PKCS#12 identity their organisation issues.")
    k.add_argument("--name", required=True, help="the inspector's name")
    k.add_argument("--organisation", default="", help="the organisation's name")
    k.add_argument("--out", required=True, metavar="DIR", help="folder to write into")
    k.add_argument("--pass-env", metavar="VAR",
                   help="read the passphrase from environment variable VAR (default: ask "
                        "twice without echo)")


def _add_verify(sub: argparse._SubParsersAction) -> None:
    """``qa-inspect verify CERTIFICATE.pdf``: the certificate, the trusted CAs and the files to
    re-run it on."""
    v = sub.add_parser("verify", help="verify a signed certificate",
                       description="Exit 0 only if every signature is intact, the signer "
                       "chains to a trusted CA and nothing was changed after signing (and, "
                       "with --nominal/--measured (and --plan), the files match the "
                       "certificate and the inspection re-run gives the same verdict); 1 "
                       "otherwise.")
    v.add_argument("certificate", metavar="CERTIFICATE.pdf")
    v.add_argument("--trust", required=True, action="append", metavar="CA.pem",
                   help="trusted CA certificate(s), PEM or DER (repeatable); nothing else is "
                        "trusted")
    v.add_argument("--nominal", metavar="FILE", help="the nominal file, to check and re-run")
    v.add_argument("--measured", metavar="FILE", help="the measured file, to check and re-run")
    v.add_argument("--plan", metavar="PLAN.toml",
                   help="the inspection plan, to check and re-run (required with --nominal/"
                        "--measured when the certificate was made with one)")


def _add_faces(sub: argparse._SubParsersAction) -> None:
    """``qa-inspect faces PART.stp``: every face of a STEP model, as a table or CSV."""
    f = sub.add_parser("faces", help="list the faces of a STEP model (the ids plans name)",
                       description="Print every face of a STEP model: its id (a plan's region "
                       "selects face N with group = \"face:N\"; a QIF plan's features are "
                       "matched to these ids), its surface (plane, cylinder, cone, sphere, "
                       "torus, bspline …), its exact geometry (mm), its area (mm²) and its "
                       "name. Exit code 0, 65 for a file that is no readable STEP model.")
    f.add_argument("part", metavar="PART.stp", help="the STEP model (.stp .step)")
    f.add_argument("--csv", metavar="FILE|-",
                   help="also write one CSV row per face (- for stdout instead of the table)")


def _add_plan(sub: argparse._SubParsersAction) -> None:
    """``qa-inspect plan SOURCE``: an inspection plan as a table, or as a TOML plan."""
    p = sub.add_parser("plan", help="show an inspection plan (TOML or QIF), write it as TOML",
                       description="Print the characteristics of an inspection plan (a TOML "
                       "plan, or a QIF 3.0 MBD as --plan takes it): id, name, type, tolerance "
                       "and modifiers, datum reference frame, features -> STEP face ids, and "
                       "whether the product judges it (no: the reason). With --toml, write it "
                       "as a TOML plan to review and edit; the characteristics it cannot judge "
                       "are [[not_judged]] tables there, with their reasons. Exit code 0, 65 "
                       "for a bad plan or model.")
    p.add_argument("source", metavar="SOURCE", help="the plan: PLAN.toml or PART.qif")
    p.add_argument("--nominal", metavar="PART.stp",
                   help="the STEP nominal a QIF plan's features are matched to (by geometry): "
                        "shows their face ids; needed with --toml")
    p.add_argument("--toml", metavar="OUT.toml", help="write the plan as a TOML plan")
