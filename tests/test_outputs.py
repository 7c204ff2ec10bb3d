"""reports.outputs: every output of a run or none, whatever fails and when."""

import json
import os
import socket
import stat
import threading

import numpy as np
import pytest

from reports.outputs import (Output, OutputConflictError, check_outputs, is_key_material,
                             same_file, write_all)


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


# ---------------------------------------------------------------- what a target may be (10.6)
def _char_device(tmp_path):
    """A character device to write to: a fresh null device (mknod, as root: CI) or else a
    symbolic link to /dev/null (the same code path; a faulty rename would replace the link,
    never /dev/null itself)."""
    path = tmp_path / "mynull"
    if os.geteuid() == 0:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    else:
        os.symlink("/dev/null", path)
    return path


def test_a_character_device_is_written_through_not_replaced(tmp_path):
    dev = _char_device(tmp_path)
    kind = stat.S_IFMT(os.lstat(dev).st_mode)  # a device, or a link to one
    (tmp_path / "r.csv").write_text("old\n")
    check_outputs({"--csv": str(dev)}, {})
    write_all([Output(str(tmp_path / "r.csv"), "new\n"), Output(str(dev), "x" * 100_000)])
    assert stat.S_IFMT(os.lstat(dev).st_mode) == kind and stat.S_ISCHR(os.stat(dev).st_mode)
    assert sorted(os.listdir(tmp_path)) == ["mynull", "r.csv"]  # no temporary file left
    assert (tmp_path / "r.csv").read_text() == "new\n"


def _reader(path, got):
    with open(path, "rb") as f:
        got.append(f.read())


def test_a_fifo_is_written_through_to_its_reader(tmp_path):
    """1 MB through a named pipe (more than a pipe holds: the writer must stream to the reader),
    after the regular file; the FIFO stays a FIFO."""
    fifo = tmp_path / "myfifo"
    os.mkfifo(fifo)
    os.link(fifo, tmp_path / ".spare")  # to release the reader should the FIFO be replaced
    data = bytes(np.random.default_rng(1).integers(0, 256, 1 << 20, dtype=np.uint8))
    got: list[bytes] = []
    reader = threading.Thread(target=_reader, args=(fifo, got), daemon=True)
    reader.start()
    try:
        check_outputs({"--json": str(fifo)}, {})
        write_all([Output(str(fifo), data), Output(str(tmp_path / "r.json"), "{}\n")])
        reader.join(timeout=20)
        assert not reader.is_alive() and got == [data]
        assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
        assert (tmp_path / "r.json").read_text() == "{}\n"
    finally:
        if reader.is_alive():
            os.close(os.open(tmp_path / ".spare", os.O_WRONLY | os.O_NONBLOCK))


def test_a_link_to_this_process_stdout_is_written_through(tmp_path):
    """``ln -s /proc/self/fd/N out``: the open file N gets the data, the link stays a link."""
    r, w = os.pipe()
    try:
        link = tmp_path / "mystdout"
        os.symlink(f"/proc/self/fd/{w}", link)
        write_all([Output(str(link), "to the pipe\n")])
        os.set_blocking(r, False)  # an empty pipe fails the test instead of hanging it
        assert os.read(r, 100) == b"to the pipe\n"
        assert os.readlink(link) == f"/proc/self/fd/{w}"
    finally:
        os.close(r)
        os.close(w)


def test_a_link_to_a_regular_file_replaces_that_file(tmp_path):
    (tmp_path / "real").mkdir()
    target = tmp_path / "real" / "r.csv"
    target.write_text("old\n")
    link = tmp_path / "r.csv"
    os.symlink(target, link)
    write_all([Output(str(link), "new\n")])
    assert os.path.islink(link) and os.readlink(link) == str(target)
    assert target.read_text() == "new\n"
    assert sorted(os.listdir(tmp_path / "real")) == ["r.csv"]
    # All or none holds through the link: a later failure leaves the linked file as it was.
    (tmp_path / "blocker").write_text("")
    with pytest.raises(OSError):
        write_all([Output(str(link), "newer\n"), Output(str(tmp_path / "blocker" / "x"), "x")])
    assert target.read_text() == "new\n" and os.path.islink(link)


def test_folders_sockets_and_block_devices_are_refused(tmp_path):
    folder = tmp_path / "d"
    folder.mkdir()
    sock_path = tmp_path / "s"
    sock = socket.socket(socket.AF_UNIX)
    try:
        sock.bind(str(sock_path))
        targets = [(folder, "is a folder"), (sock_path, "is a socket")]
        if os.geteuid() == 0:
            os.mknod(tmp_path / "disk", 0o600 | stat.S_IFBLK, os.makedev(7, 200))
            targets.append((tmp_path / "disk", "is a block device"))
        for path, why in targets:
            link = tmp_path / f"link-{path.name}"
            os.symlink(path, link)
            for p in (path, link):
                with pytest.raises(OutputConflictError, match=f"--csv {p} {why}"):
                    check_outputs({"--csv": str(p)}, {})
                with pytest.raises(OutputConflictError, match=why):
                    write_all([Output(str(tmp_path / "a.txt"), "a"), Output(str(p), "x")])
        assert not (tmp_path / "a.txt").exists()
        assert stat.S_ISSOCK(os.stat(sock_path).st_mode) and folder.is_dir()
    finally:
        sock.close()


@pytest.fixture(scope="module")
def key_material(tmp_path_factory):
    """{name: path} of keys and certificates in every common encoding, among them the files of
    ``qa-inspect keygen`` (inspector.p12 in DER, ca.pem)."""
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization as ser
    from cryptography.hazmat.primitives.asymmetric import ec

    from reports.signing import make_demo_identity

    d = tmp_path_factory.mktemp("keys")
    ca_pem, p12 = make_demo_identity("A. Inspector", "Org", str(d), b"secret")
    with open(ca_pem, "rb") as f:
        pem = f.read()
    cert = x509.load_pem_x509_certificate(pem)
    key = ec.generate_private_key(ec.SECP256R1())
    files = {"inspector.p12": p12, "ca.pem": ca_pem}
    contents = {
        "ca.der": cert.public_bytes(ser.Encoding.DER),
        "key.der": key.private_bytes(ser.Encoding.DER, ser.PrivateFormat.PKCS8,
                                     ser.NoEncryption()),
        "key.pem": key.private_bytes(ser.Encoding.PEM, ser.PrivateFormat.TraditionalOpenSSL,
                                     ser.BestAvailableEncryption(b"pw")),
        # openssl x509 -text: a text dump before the armour
        "ca-text.pem": b"Certificate:\n    Data:\n        Version: 3 (0x2)\n" + pem,
        "bundle.crt": b"# trusted roots\r\n" + pem.replace(b"\n", b"\r\n"),
    }
    for name, data in contents.items():
        (d / name).write_bytes(data)
        files[name] = str(d / name)
    return files


def test_keys_and_certificates_are_never_replaced(key_material):
    for name, path in key_material.items():
        with open(path, "rb") as f:
            before = f.read()
        assert is_key_material(before[:1 << 16], len(before)), name
        with pytest.raises(OutputConflictError, match="holds a key or certificate"):
            check_outputs({"--report": path}, {})
        with pytest.raises(OutputConflictError, match="holds a key or certificate"):
            write_all([Output(path, b"%PDF-1.7 ...")])
        with open(path, "rb") as f:
            assert f.read() == before, name


def test_ordinary_files_stay_replaceable(tmp_path):
    """What the product writes, and binary files that merely start like DER, are replaced."""
    rng = np.random.default_rng(2)
    der_like = b"\x30\x82\x01\x00" + bytes(rng.integers(0, 256, 100, dtype=np.uint8))
    samples = {
        "c.pdf": b"%PDF-1.7\n" + bytes(rng.integers(0, 256, 5000, dtype=np.uint8)),
        "r.csv": b"index,label,x,y,z\n0,P000,1,2,3\n",
        "r.json": json.dumps({"notes": "-----BEGIN CERTIFICATE-----\nMIIB\n"}).encode(),
        "der-like.bin": der_like,  # the DER length (256) is not the file's length (104)
        "short.bin": b"\x30\x05abc",
        "empty": b"",
    }
    for name, data in samples.items():
        (tmp_path / name).write_bytes(data)
        assert not is_key_material(data[:1 << 16], len(data)), name
    outs = {n: str(tmp_path / n) for n in samples}
    check_outputs(outs, {})
    write_all([Output(p, "new") for p in outs.values()])
    assert all((tmp_path / n).read_text() == "new" for n in samples)
