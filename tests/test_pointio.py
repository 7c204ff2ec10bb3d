"""Every point-file layout the readers accept, and every bad-input class they refuse."""

import numpy as np
import pytest

from engine.errors import InputError, InputNotFoundError
from engine.io.points import read_points

P = np.array([[1.5, -2.25, 3.0], [4.0, 5.5, -6.125], [7.0, 8.0, 9.5], [0.1, 0.2, 0.3]])


def write(tmp_path, name, text):
    f = tmp_path / name
    f.write_text(text)
    return str(f)


@pytest.mark.parametrize("sep", [",", ";", "\t", " ", "   "])
def test_delimiters(tmp_path, sep):
    text = "\n".join(sep.join(f"{v:g}" for v in row) for row in P) + "\n"
    ps = read_points(write(tmp_path, "p.txt", text))
    assert np.allclose(ps.points, P) and ps.labels is None and ps.normals is None


def test_semicolon_with_decimal_commas(tmp_path):
    text = "\n".join(";".join(f"{v:g}".replace(".", ",") for v in row) for row in P)
    assert np.allclose(read_points(write(tmp_path, "p.csv", text)).points, P)


def test_header_labels_comments_and_normals(tmp_path):
    n = np.array([[0, 0, 2.0], [0, 3.0, 0], [1.0, 0, 0], [1.0, 1.0, 0]])
    lines = ["# exported by a CMM", "Name,X,Y,Z,I,J,K"]
    for i, (p, nn) in enumerate(zip(P, n)):
        lines.append(f"P{i + 1:04d},{p[0]},{p[1]},{p[2]},{nn[0]},{nn[1]},{nn[2]}")
        if i == 1:
            lines.append("# a comment between points")
            lines.append("")
    ps = read_points(write(tmp_path, "m.csv", "\n".join(lines) + "\n"))
    assert np.allclose(ps.points, P)
    assert list(ps.labels) == ["P0001", "P0002", "P0003", "P0004"]
    assert np.allclose(ps.normals, n / np.linalg.norm(n, axis=1, keepdims=True))


def test_header_in_other_column_order(tmp_path):
    text = "z y x\n" + "\n".join(f"{r[2]} {r[1]} {r[0]}" for r in P)
    assert np.allclose(read_points(write(tmp_path, "p.xyz", text)).points, P)


def test_leading_label_column_without_header(tmp_path):
    text = "\n".join(f"P{i}, {r[0]}, {r[1]}, {r[2]}" for i, r in enumerate(P))
    ps = read_points(write(tmp_path, "p.csv", text))
    assert np.allclose(ps.points, P) and list(ps.labels) == ["P0", "P1", "P2", "P3"]
    text = "\n".join(f"{i + 1} {r[0]} {r[1]} {r[2]}" for i, r in enumerate(P))
    ps = read_points(write(tmp_path, "p.asc", text))
    assert np.allclose(ps.points, P) and list(ps.labels) == ["1", "2", "3", "4"]


def test_two_columns_are_2d(tmp_path):
    ps = read_points(write(tmp_path, "c.txt", "0 0\n1 0\n1 1\n0 1\n"))
    assert ps.dim == 2 and np.allclose(ps.points[:, 2], 0)


def test_grid_header_and_units(tmp_path):
    rows = [f"{i * 1.0} {j * 2.0} {0.1 * i * j}" for j in range(3) for i in range(4)]
    ps = read_points(write(tmp_path, "g.txt", "# grid: 4 x 3\n# units: inch\n" + "\n".join(rows)))
    assert ps.grid_shape == (4, 3)
    assert ps.points[5, 0] == pytest.approx(1.0 * 25.4) and ps.points[5, 1] == pytest.approx(50.8)


def test_npy(tmp_path):
    np.save(tmp_path / "a.npy", P)
    assert np.allclose(read_points(tmp_path / "a.npy").points, P)
    six = np.hstack([P, np.tile([0, 0, 1.0], (4, 1))])
    np.save(tmp_path / "b.npy", six)
    assert np.allclose(read_points(tmp_path / "b.npy").normals, [[0, 0, 1.0]] * 4)
    np.save(tmp_path / "c.npy", P[:, :2])
    assert read_points(tmp_path / "c.npy").dim == 2


def test_large_file_fast_path_matches_values(tmp_path):
    rng = np.random.default_rng(0)
    big = rng.normal(size=(20000, 3)) * 100
    f = tmp_path / "big.xyz"
    np.savetxt(f, big, fmt="%.6f")
    assert np.allclose(read_points(f).points, big, atol=1e-6)


BAD = [
    ("x,y,z\n1,2,3\n4,x1.2,6\n7,8,9\n", r"bad\.csv:3: 'x1\.2' is not a number"),
    ("1 2 3\n4 5 6\n7 8\n", r"bad\.csv:3: 2 columns where the file has 3"),
    ("1 2 3\n4 5 6\n7 8 9 10\n", r"bad\.csv:3: 4 columns where the file has 3"),
    ("1 2 3\nnan 5 6\n7 8 9\n", r"bad\.csv:2: NaN or infinity"),
    ("1 2 3\n4 5 6\n7 inf 9\n", r"bad\.csv:3: NaN or infinity"),
    ("", r"bad\.csv: the file holds no points"),
    ("# only comments\n\n", r"bad\.csv: the file holds no points"),
    ("x,y,z\n", r"bad\.csv: the file holds a header but no points"),
    ("1 2 3\n4 5 6\n", r"only 2 point\(s\); at least 3"),
    ("1 1 1\n1 1 1\n1 1 1\n1 1 1\n", r"all 4 points are the same point \(1, 1, 1\): one "
                                       "distinct point"),
    # issue 22 item 10: their mean is not 1.1 to the last bit, and they "lay on one line"
    ("x,y,z\n" + "1.1,2.2,3.3\n" * 1000, r"bad\.csv: all 1,000 points are the same point "
                                          r"\(1\.1, 2\.2, 3\.3\): one distinct point$"),
    ("x,y\n" + "1.1,2.2\n" * 1000, r"all 1,000 points are the same point \(1\.1, 2\.2\)"),
    ("0 0 0\n1 1 1\n2 2 2\n3 3 3\n", r"all 4 points lie on one straight line"),
    ("# grid: 3 x 3\n0 0 0\n1 0 0\n0 1 0\n1 1 1\n", r"declares a 3 x 3 grid \(9 points\) but"),
    ("# units: furlong\n0 0 0\n1 0 0\n0 1 0\n", r"bad\.csv:1: unknown unit 'furlong'"),
    ("1 2 3 0 0 0\n4 5 6 0 0 1\n7 8 0 1 0 0\n", r"bad\.csv:1: normal \(I J K\) has zero length"),
    ("1 2 3 4 5\n6 7 8 9 10\n", r"5 columns without a header row"),
    ("a,b,c\n1,2,3\n", r"header row .* names no x and y columns"),
]


@pytest.mark.parametrize("text, message", BAD)
def test_bad_text_inputs_name_file_line_and_problem(tmp_path, text, message):
    with pytest.raises(InputError, match=message):
        read_points(write(tmp_path, "bad.csv", text))


def test_binary_garbage_and_missing_file(tmp_path):
    f = tmp_path / "junk.txt"
    f.write_bytes(b"\x00\x01\x02binary")
    with pytest.raises(InputError, match="binary file"):
        read_points(f)
    with pytest.raises(InputNotFoundError, match="no such file"):
        read_points(tmp_path / "missing.csv")
    with pytest.raises(InputError, match="unsupported point file type"):
        read_points(write(tmp_path, "p.dat", "1 2 3\n"))


def test_bad_npy(tmp_path):
    np.save(tmp_path / "a.npy", np.zeros((4, 5)))
    with pytest.raises(InputError, match=r"shape \(4, 5\)"):
        read_points(tmp_path / "a.npy")
    arr = P.copy()
    arr[2, 1] = np.nan
    np.save(tmp_path / "b.npy", arr)
    with pytest.raises(InputError, match="row 2 holds NaN"):
        read_points(tmp_path / "b.npy")
    (tmp_path / "c.npy").write_bytes(b"not numpy")
    with pytest.raises(InputError, match="not a readable .npy"):
        read_points(tmp_path / "c.npy")
