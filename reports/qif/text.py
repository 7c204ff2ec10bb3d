"""Numbers and words as a QIF document spells them: 6 decimals (1 nm), exact vectors, point
and flag lists, escaped XML text, id lists, attributes and a feature's geometry elements."""

from __future__ import annotations

import os
import re
from urllib.parse import quote

import numpy as np

from ..messages import printable


def numbers(values: np.ndarray, per_line: int) -> str:
    """'%.6f' numbers, ``per_line`` a line; one %-format over the whole array is the fast path."""
    flat = np.asarray(values, dtype=float).ravel()
    if flat.size == 0:
        return ""
    text = (("%.6f " * (per_line - 1) + "%.6f\n") * (flat.size // per_line)) % tuple(flat.tolist())
    if not np.isfinite(flat).all():
        # '%f' gives nan/inf; xs:double spells them NaN/INF.
        text = re.sub(r"-?nan|-?inf", lambda m: {"nan": "NaN", "-nan": "NaN", "inf": "INF",
                                                  "-inf": "-INF"}[m.group(0)], text)
    return text


def flags(mask: np.ndarray) -> str:
    return (np.asarray(mask, dtype=bool).astype(np.uint8) + ord("0")).tobytes().decode("ascii")


def fixed(v: float) -> str:
    s = f"{v:.6f}"
    return "0.000000" if s == "-0.000000" else s


def exact(vec) -> str:
    return " ".join(repr(float(v)) for v in vec)


def id_list(tag: str, values, indent: int) -> str:
    s = " " * indent
    return (f'{s}<{tag} n="{len(values)}">\n' + "".join(f"{s}  <Id>{v}</Id>\n" for v in values)
            + f"{s}</{tag}>\n")


def algorithm(name: str, indent: int) -> str:
    s = " " * indent
    return (f"{s}<SubstituteFeatureAlgorithm>\n"
            f"{s}  <SubstituteFeatureAlgorithmEnum>{name}</SubstituteFeatureAlgorithmEnum>\n"
            f"{s}</SubstituteFeatureAlgorithm>\n")


def signed(v: float) -> str:
    s = fixed(v)
    return s if s.startswith("-") else "+" + s


def point_text(p) -> str:
    return " ".join(fixed(float(v)) for v in p)


def nmtoken(s: str) -> str:
    """``s`` as an xs:NMTOKEN (a datum label): characters other than ASCII letters, digits and
    . - _ : become '_'."""
    return re.sub(r"[^A-Za-z0-9._:-]", "_", str(s)) or "_"


def xml_text(s) -> str:
    """``s`` (a file name, a label, a certificate field) as XML text: its control characters
    written out (reports.messages.printable: most are not allowed in XML 1.0 at all, and a
    dropped one would change the name), then the XML specials escaped."""
    return (printable(s).replace("&", "&amp;").replace("<", "&lt;")
            .replace(">", "&gt;"))


def xml_attr(s) -> str:
    return xml_text(s).replace('"', "&quot;")


def uri(path: str) -> str:
    # A file name's bytes that are not UTF-8 (lone surrogates) are percent-encoded as they are.
    return quote(path.replace("\\", "/"), safe="/:._-~", errors="surrogateescape")


def format_name(path: str, is_template: bool) -> str:
    ext = os.path.splitext(path)[1].lstrip(".").upper() or "unknown"
    return f"{ext} 2D template" if is_template else ext


def file_description(role: str, rec: dict) -> str:
    bits = [f"{role} file"]
    if rec.get("sha256"):
        bits.append(f"sha256 {rec['sha256']}")
    if rec.get("n_points") is not None:
        bits.append(f"{rec['n_points']} points")
    if rec.get("n_primitives") is not None:
        bits.append(f"{rec['n_primitives']} primitives")
    return ", ".join(bits)


def attributes(items, indent: int) -> str:
    """QIF Attributes of (kind, name, value) items whose value is given ("" when none):
    kind "Str" (AttributeStr) or "D1" (AttributeD1, a number)."""
    items = [(k, n, v) for k, n, v in items if v not in (None, "")]
    if not items:
        return ""
    pad = " " * indent
    body = "".join(f'{pad}  <Attribute{k} name="{n}" value="'
                   f'{xml_attr(v) if k == "Str" else fixed(float(v))}"/>\n' for k, n, v in items)
    return f'{pad}<Attributes n="{len(items)}">\n{body}{pad}</Attributes>\n'


def geometry(kind: str, g: dict, measured: bool, indent: int) -> str:
    """A plane's, cylinder's or sphere's elements (nominal; measured: with the diameter of a
    cylinder or sphere and the form error)."""
    s = " " * indent
    if kind == "Plane":
        out = (f"{s}<Location>{point_text(g['point'])}</Location>\n"
               f"{s}<Normal>{exact(g['normal'])}</Normal>\n")
    elif kind == "Cylinder":
        out = (f"{s}<Axis>\n{s}  <AxisPoint>{point_text(g['point'])}</AxisPoint>\n"
               f"{s}  <Direction>{exact(g['direction'])}</Direction>\n{s}</Axis>\n")
    else:
        out = f"{s}<Location>{point_text(g['centre'])}</Location>\n"
    if measured and kind != "Plane":
        out += f"{s}<Diameter>{fixed(g['diameter'])}</Diameter>\n"
    if measured and g.get("form_error") is not None:
        out += f"{s}<Form>{fixed(g['form_error'])}</Form>\n"
    return out
