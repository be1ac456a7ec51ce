"""Hardening, third round, kind 1: a report reads only its run.

A received run folder is hostile: its ``report.json`` and ``manifest.json`` are consistent (the attacker writes
the sha256 of what they changed) but name files outside the run, links lead out of it, file names are URLs.
``gflat report`` and :func:`reports.html.render_run` refuse in one line, never read (nor embed) a file outside
the run, and link only relative paths inside it.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import pytest

from gna.errors import InputError
from harness.cli import main
from harness.recorded import confined, file_problem, href, safe_name, sha256
from harness.rundir import MANIFEST
from reports.html import pdf_view, render_run

from .harness.test_validation import SHORT

SECRET = "the contents of a private key, never to leave this machine"


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    """A finished ``gflat compare`` run of one case (J = 0), copied by each test."""
    base = tmp_path_factory.mktemp("hostile")
    (base / "short.toml").write_text(SHORT)
    assert main(["compare", str(base / "short.toml"), "--J", "0", "--out", str(base / "run")]) == 0
    return base / "run"


@pytest.fixture
def received(run, tmp_path) -> tuple[Path, Path]:
    """A copy of the run as received, and a secret file beside it (outside the run)."""
    secret = tmp_path / "home" / "u" / ".ssh" / "id_rsa"
    secret.parent.mkdir(parents=True)
    secret.write_text(SECRET)
    folder = tmp_path / "mail" / "run"
    shutil.copytree(run, folder, symlinks=True)
    return folder, secret


def _reseal(folder: Path) -> None:
    """Rewrite the manifest's checksums after a change (what an attacker does: the manifest then matches)."""
    m = json.loads((folder / MANIFEST).read_text())
    names = sorted({f["path"] for f in m["files"]} | _walk(folder)) if m["files"] else []
    m["files"] = [
        {
            "path": n,
            "sha256": sha256(folder / n) if (folder / n).is_file() else "0" * 64,
            "bytes": os.lstat(folder / n).st_size,
        }
        for n in names
        if n != MANIFEST and (folder / n).exists()
    ]
    (folder / MANIFEST).write_text(json.dumps(m))


def _walk(folder: Path) -> set:
    return {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file() or p.is_symlink()}


def _name_figure(folder: Path, name: str) -> None:
    model = json.loads((folder / "report.json").read_text())
    model["figures"][0]["file"] = name
    (folder / "report.json").write_text(json.dumps(model))


def _everything(where: Path) -> str:
    return "".join(p.read_bytes().decode("latin-1") for p in where.rglob("*") if p.is_file() and not p.is_symlink())


def _refused(folder: Path, capsys, *words) -> str:
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file() and not p.is_symlink()}
    assert main(["report", str(folder), "--self-contained"]) == 2  # the PDF too: refused before anything is printed
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    for w in words:
        assert w in err, err
    assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file() and not p.is_symlink()} == before
    assert SECRET not in _everything(folder.parent)
    assert sorted(p.name for p in folder.parent.iterdir()) == ["run"]  # no staging folder left
    return err


def test_a_figure_that_is_no_png_is_refused(received, capsys):
    folder, _ = received
    _name_figure(folder, "report.json")
    _reseal(folder)
    err = _refused(folder, capsys, "is not {'file': NAME.png, 'caption': TEXT}")
    assert ".gflat-" not in err and f"{folder}/report.json" in err  # named as the run's file, not its staged copy


@pytest.mark.parametrize("figure", ["../../home/u/.ssh/id_rsa", "../../../../../../../../etc/passwd", "ABS"])
def test_a_figure_outside_the_run_is_refused(received, capsys, figure):
    folder, secret = received
    figure = str(secret) if figure == "ABS" else figure
    _name_figure(folder, figure)
    _reseal(folder)
    cause = "an absolute path" if figure.startswith("/") else "a path with '..'"
    _refused(folder, capsys, f"names the figure {figure!r}: {cause}", "only files inside")
    with pytest.raises(InputError, match="only files inside"):
        render_run(folder, self_contained=True, pdf=False)
    assert SECRET not in _everything(folder)


def test_a_figure_that_is_a_link_out_of_the_run_is_refused(received, capsys):
    folder, secret = received
    (folder / "states.png").unlink()
    (folder / "states.png").symlink_to(secret)
    _reseal(folder)
    _refused(folder, capsys, "lists the file 'states.png': a symbolic link leading out of the folder")
    with pytest.raises(InputError, match="states.png'?: a symbolic link leading out of the folder"):
        render_run(folder, self_contained=True, pdf=False)  # a plain folder (no gflat report): still confined
    assert SECRET not in _everything(folder)


def test_a_folder_link_out_of_the_run_is_never_followed(received, capsys):
    folder, secret = received
    shutil.rmtree(folder / "plan")
    (folder / "plan").symlink_to(secret.parent, target_is_directory=True)
    _refused(folder, capsys, "holds plan, which is not a file of its gflat run")
    _reseal(folder)  # listed now: a link is no file of a run
    _refused(folder, capsys, "lists the file 'plan': a symbolic link leading out of the folder")
    render_run(folder, self_contained=True, pdf=True)  # a plain folder: the link's files are not listed
    assert "id_rsa" not in _everything(folder) and SECRET not in _everything(folder)
    text = _pdf_text(folder / "report.pdf")  # the PDF's text (its streams are compressed)
    assert "Provenance" in text and "id_rsa" not in text and SECRET not in text


@pytest.mark.parametrize(
    "entry, cause",
    [
        ("../outside.txt", "a path with '..'"),
        ("/etc/passwd", "an absolute path"),
        ("plan/../../outside.txt", "a path with '..'"),
        ("~/.ssh/id_rsa", "an absolute path"),
        (7, "a file entry 7 lacks a string path, an integer bytes or a string sha256"),
        ({"path": ["a"], "sha256": "0", "bytes": 1}, "lacks a string path, an integer bytes or a string sha256"),
    ],
)
def test_a_manifest_listing_files_outside_the_run_is_refused(received, capsys, entry, cause):
    folder, secret = received
    (folder.parent / "outside.txt").write_text(SECRET)
    m = json.loads((folder / MANIFEST).read_text())
    if isinstance(entry, str):
        target = folder / entry if not entry.startswith(("/", "~")) else Path(entry).expanduser()
        digest = sha256(target) if target.exists() else "0" * 64
        entry = {"path": entry, "sha256": digest, "bytes": target.stat().st_size if target.exists() else 0}
    m["files"].insert(0, entry)
    (folder / MANIFEST).write_text(json.dumps(m))
    (folder.parent / "outside.txt").unlink()
    _refused(folder, capsys, cause)


def test_a_manifest_whose_files_are_no_list_is_one_line(received, capsys):
    folder, _ = received
    m = json.loads((folder / MANIFEST).read_text())
    m["files"] = 5
    (folder / MANIFEST).write_text(json.dumps(m))
    _refused(folder, capsys, f"{folder / MANIFEST}: 'files' is a JSON number, not a list")  # the cause, not its effect


def test_a_data_file_named_as_a_url_is_a_relative_link(received):
    folder, _ = received
    for name in ("javascript:alert(1)", "data:text;html,<script>x<script>", "http:x.csv", "a b#c?.txt"):
        (folder / name).write_text("x")
    model = json.loads((folder / "report.json").read_text())
    model["title"] = "<script>alert('title')</script>"
    model["figures"][0]["caption"] = '"><img src=x onerror=alert(1)>'
    (folder / "report.json").write_text(json.dumps(model))
    _reseal(folder)
    assert main(["report", str(folder), "--self-contained"]) == 0
    pdf = pytest.importorskip("pypdf").PdfReader(folder / "report.pdf")
    text = _pdf_text(folder / "report.pdf")
    assert "<script>alert('title')</script>" in text and '"><img src=x onerror=alert(1)>' in text  # as text
    for page in pdf.pages:  # the PDF's links all internal (no URI, no launch, no file)
        for annot in page.get("/Annots") or []:
            action = annot.get_object().get("/A")
            assert action is None or action.get_object().get("/S") == "/GoTo", action
    for page in ("index.html", "case.html", "report.html"):
        html = (folder / page).read_text()
        assert "<script>" not in html and "<img src=x" not in html  # every model text escaped
        for attr, url in re.findall(r'\b(href|src)="([^"]*)"', html):
            if (
                url in ("data:,",)
                or url.startswith("#")
                or (page == "report.html" and url.startswith("data:image/png"))
            ):
                continue  # the page's own icon, anchors, and the single file's embedded figures
            assert not re.match(r"^[A-Za-z][A-Za-z0-9+.-]*:", url) and not url.startswith("/"), (page, attr, url)
            assert (folder / _unquote(url)).resolve().is_relative_to(folder), url
    assert 'href="javascript%3Aalert%281%29"' in (folder / "case.html").read_text()


def _pdf_text(path: Path) -> str:
    pypdf = pytest.importorskip("pypdf")
    return re.sub(r"\s+", " ", "\n".join(p.extract_text() for p in pypdf.PdfReader(path).pages))


def _unquote(url: str) -> str:
    from urllib.parse import unquote

    return unquote(url.split("#")[0])


def test_confinement_primitives(tmp_path):
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "a.txt").write_text("abc")
    (tmp_path / "out.txt").write_text("x")
    (tmp_path / "in" / "up").symlink_to(tmp_path)
    (tmp_path / "in" / "loop").symlink_to(tmp_path / "in" / "loop")
    root = tmp_path / "in"
    assert confined(root, "a.txt") == root / "a.txt"
    for bad, cause in (
        ("up/out.txt", "a symbolic link leading out"),
        ("loop", "cannot be resolved"),
        ("", "not a file name"),
        (".", "not a file name"),
        (None, "not a file name"),
        ("a\0b", "NUL"),
        ("..\\x", "backslash"),
    ):
        with pytest.raises(InputError, match=cause):
            confined(root, bad)
    assert file_problem(root / "a.txt", 3, sha256(root / "a.txt")) is None
    assert file_problem(root / "a.txt", 5) == "shorter than recorded (3 of 5 bytes: truncated or rewritten)"
    assert file_problem(root / "a.txt", 2) == "3 bytes, 2 recorded"
    assert file_problem(root / "a.txt", 3, "0" * 64) == "changed since it was recorded (sha256 differs)"
    assert file_problem(root / "b.txt") == "missing" and file_problem(root / "up") == "a symbolic link"
    assert file_problem(root) == "not a regular file"
    assert href(root / "javascript:alert(1)", root) == "javascript%3Aalert%281%29"
    assert href(tmp_path / "x y.png", root) == "../x%20y.png"
    assert safe_name("gtm.fit.0001") == "gtm.fit.0001"
    for bad in ("..", ".", "a/b", "../x", "", "a\nb", 3, "é"):
        with pytest.raises(InputError, match="not a plain name"):
            safe_name(bad, "case id")


def test_a_re_render_on_a_full_disk_leaves_the_run_as_it_was(received):
    """Kind 2: a re-render that cannot write (the file-size limit standing for a full disk) fails in one line;
    the run keeps its files, all matching its manifest, and no staging folder is left."""
    import resource
    import signal
    import subprocess
    import sys

    folder, _ = received
    m = json.loads((folder / MANIFEST).read_text())
    largest = max(f["bytes"] for f in m["files"])  # every file copies; the single report.html is larger

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails (EFBIG) instead of a kill
        resource.setrlimit(resource.RLIMIT_FSIZE, (largest + 1, largest + 1))

    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    root = Path(__file__).parents[1]
    proc = subprocess.run(
        [sys.executable, "-m", "harness.cli", "report", str(folder), "--self-contained", "--no-pdf"],
        capture_output=True,
        text=True,
        preexec_fn=limit,
        env={**os.environ, "PYTHONPATH": str(root)},
        cwd=root,
    )
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "File too large" in proc.stderr and "report.html" in proc.stderr
    assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()} == before
    for f in json.loads((folder / MANIFEST).read_text())["files"]:
        assert file_problem(folder / f["path"], f["bytes"], f["sha256"]) is None
    assert sorted(p.name for p in folder.parent.iterdir()) == ["run"]


# --- fourth round (docs/hardening.md): a model damaged inside, and one naming thousands of figures -----------


def _edit_model(folder: Path, edit) -> None:
    model = json.loads((folder / "report.json").read_text())
    edit(model)
    (folder / "report.json").write_text(json.dumps(model))
    _reseal(folder)


@pytest.mark.parametrize(
    "edit, words",
    [
        (lambda m: m["tables"]["engines"][0].update(rows=[[1]]), ("IndexError",)),
        (lambda m: m.update(plan={}), ("'J'",)),
        (lambda m: m.update(runs={"inhouse": 5}), ("status",)),
        (lambda m: m["settings"].clear(), ("dt_out",)),
    ],
)
def test_a_model_damaged_inside_is_one_line_naming_its_file(received, capsys, edit, words):
    folder, _ = received
    _edit_model(folder, edit)
    before = _walk(folder)
    assert main(["report", str(folder), "--no-pdf", "--self-contained"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert f"{folder / 'report.json'}: not a gflat report model (cannot render it" in err
    assert all(w in err for w in words)
    assert _walk(folder) == before  # the run as it was
    with pytest.raises(InputError, match="report.json: not a gflat report model") as exc:  # the PDF's view too
        pdf_view(folder)
    assert "\n" not in str(exc.value)


def test_a_model_naming_thousands_of_figures_is_refused_with_the_bound(received, capsys):
    folder, _ = received
    _edit_model(folder, lambda m: m.update(figures=m["figures"] * 1000))
    assert main(["report", str(folder), "--no-pdf"]) == 2
    err = capsys.readouterr().err.strip()
    assert "figures, above the bound of 64" in err and "\n" not in err
