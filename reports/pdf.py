"""PDF validation report: the run's HTML printed by weasyprint (text stays extractable).

Each case starts a new page under a level-1 heading (a PDF bookmark) that
carries its PASS/FAIL, its sections level-2 bookmarks; the figures are the
case folder's PNG files, embedded as they are (not drawn again).  The cases
come in documents cut at case boundaries (:func:`reports.html.pdf_documents`),
printed concurrently in worker processes (or already, by a command's workers as
the cases are written: :func:`reports.html.pdf_part`); the front matter (title, contents
with each case's page, summary, manifest) is printed once their pages are
known, and everything is put end to end with pypdf, bookmarks and links kept,
every page numbered ``k / N`` at its foot.
"""

from __future__ import annotations

import io
import os
import struct
from collections.abc import Mapping, Sequence
from pathlib import Path

from gna.errors import writing


def _fetcher(base_url: str):
    """A weasyprint URL fetcher that reads only ``data:`` URLs and files inside ``base_url`` (the run), links
    resolved: a page never prints a file from outside its run."""
    from urllib.parse import unquote, urlsplit

    from weasyprint.urls import URLFetcher

    base = Path(base_url).resolve()

    class RunFetcher(URLFetcher):
        def fetch(self, url, headers=None):
            parts = urlsplit(url)
            if parts.scheme != "data" and not (
                parts.scheme == "file" and Path(unquote(parts.path)).resolve().is_relative_to(base)
            ):
                raise ValueError(f"{url}: not a file of the run {base} (never printed)")
            return super().fetch(url, headers)

    return RunFetcher(allowed_protocols=("file", "data"))


def png_stream(data: bytes) -> bytes | None:
    """The compressed image data of an 8-bit RGB, non-interlaced PNG: its IDAT chunks end to end.

    That is a PDF image's ``FlateDecode`` stream with the PNG predictors, as weasyprint writes it: the
    figures (:meth:`reports.figures.Sheet.save`) go into the PDF without being decoded and compressed again.

    Parameters
    ----------
    data : bytes
        A PNG file.

    Returns
    -------
    bytes or None
        None for any other PNG (palette, alpha, 16-bit, interlaced) or a file that is not one.
    """
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    pos, out = 8, []
    while pos + 8 <= len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        chunk = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            depth, colour, interlace = chunk[8], chunk[9], chunk[12]
            if (depth, colour, interlace) != (8, 2, 0):  # 8-bit truecolour, not interlaced
                return None
        elif kind in (b"tRNS", b"PLTE"):
            return None
        elif kind == b"IDAT":
            out.append(chunk)
        elif kind == b"IEND":
            break
        pos += 12 + length
    return b"".join(out) or None


def _passthrough():
    """weasyprint's PNG re-encoding replaced, while printing, by :func:`png_stream` where it applies."""
    from weasyprint.images import RasterImage

    original = RasterImage._get_png_data  # noqa: SLF001

    def get_png_data(pillow_image):
        fp = getattr(pillow_image, "fp", None)
        if pillow_image.format == "PNG" and pillow_image.mode == "RGB" and hasattr(fp, "getvalue"):
            stream = png_stream(fp.getvalue())
            if stream is not None:
                return stream
        return original(pillow_image)

    return RasterImage, original, staticmethod(get_png_data)


def import_weasyprint():
    """weasyprint, imported without a search of the system's library paths for each name it tries.

    weasyprint loads pango, harfbuzz and fontconfig trying several names each; cffi looks a name that does not
    load as it is up with ``ctypes.util.find_library``, which runs ``ldconfig`` (and compilers) in
    subprocesses: most of the import's CPU.  The names weasyprint tries include each library's
    file name (``libpango-1.0.so.0``), loaded directly; where one is only found by the search, weasyprint is
    imported again the ordinary way.

    Returns
    -------
    module
        ``weasyprint``.
    """
    import contextlib
    import ctypes.util
    import io
    import sys

    if "weasyprint" in sys.modules:
        return sys.modules["weasyprint"]
    search = ctypes.util.find_library
    ctypes.util.find_library = lambda name: None
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # weasyprint prints its advice before raising
            import weasyprint

        return weasyprint
    except Exception:  # noqa: BLE001  (a library found by the search only)
        for name in [m for m in sys.modules if m == "weasyprint" or m.startswith("weasyprint.")]:
            del sys.modules[name]
    finally:
        ctypes.util.find_library = search
    import weasyprint

    return weasyprint


def _print(html: str, base_url: str) -> bytes:
    import gc

    weasyprint = import_weasyprint()

    gc.freeze()  # the objects there before printing are not scanned again by every collection (nor collected first:
    # a full collection of a command's heap costs more than the garbage it frees)
    cls, original, patched = _passthrough()
    cls._get_png_data = patched  # noqa: SLF001
    try:
        return weasyprint.HTML(string=html, base_url=base_url, url_fetcher=_fetcher(base_url)).write_pdf()
    finally:
        cls._get_png_data = staticmethod(original)  # noqa: SLF001
        gc.unfreeze()


def _merge(parts: list[bytes], number: bool = False) -> bytes:
    """PDF documents end to end: pages, bookmarks, links and the named destinations they point to; with
    ``number``, every page numbered at its foot (:func:`_number_pages`)."""
    from pypdf import PdfReader, PdfWriter
    from pypdf.generic import ArrayObject, DictionaryObject, FloatObject, NameObject, NumberObject, TextStringObject

    readers = [PdfReader(io.BytesIO(p)) for p in parts]
    writer = PdfWriter()
    for reader in readers:
        writer.append(reader, import_outline=True)
    # named destinations: the last document's of each name (the front matter's anchors of the cases are
    # placeholders that let weasyprint print its links)
    dests, offset = {}, 0
    for reader in readers:
        for name, d in reader.named_destinations.items():
            page = writer.pages[offset + reader.get_destination_page_number(d)]
            dests[str(name)] = ArrayObject(
                [
                    page.indirect_reference,
                    NameObject("/XYZ"),
                    FloatObject(d.left or 0),
                    FloatObject(d.top or 0),
                    NumberObject(0),
                ]
            )
        offset += len(reader.pages)
    tree = ArrayObject()
    for name in sorted(dests):
        tree += [TextStringObject(name), dests[name]]
    writer.root_object[NameObject("/Names")] = DictionaryObject(
        {NameObject("/Dests"): DictionaryObject({NameObject("/Names"): tree})}
    )
    if readers[0].metadata:
        writer.add_metadata(dict(readers[0].metadata))
    if number:
        _number_pages(writer)
    buf = io.BytesIO()
    writer.write(buf)
    return buf.getvalue()


#: Font size [pt] and distance from the page's foot [pt] of the page numbers.
PAGE_NUMBER_PT, PAGE_NUMBER_FOOT_PT = 8, 22


def _number_pages(writer) -> None:
    """Write ``k / N`` at the foot of every page (centred; Helvetica, a standard PDF font: nothing embedded).

    Each page's content is wrapped in ``q ... Q`` and a stream drawing its number appended: the page's own
    content streams are not parsed nor rewritten.
    """
    from pypdf.generic import ArrayObject, DecodedStreamObject, DictionaryObject, NameObject

    font = writer._add_object(  # noqa: SLF001  (pypdf's way to add an indirect object)
        DictionaryObject(
            {
                NameObject("/Type"): NameObject("/Font"),
                NameObject("/Subtype"): NameObject("/Type1"),
                NameObject("/BaseFont"): NameObject("/Helvetica"),
                NameObject("/Encoding"): NameObject("/WinAnsiEncoding"),
            }
        )
    )
    n = len(writer.pages)
    for k, page in enumerate(writer.pages, start=1):
        label = f"{k} / {n}"
        width = float(page.mediabox.width)
        x = float(page.mediabox.left) + 0.5 * width - 0.25 * PAGE_NUMBER_PT * len(label)
        y = float(page.mediabox.bottom) + PAGE_NUMBER_FOOT_PT
        resources = page.get("/Resources")
        resources = resources.get_object() if resources is not None else DictionaryObject()
        fonts = resources.get("/Font")
        fonts = DictionaryObject(fonts.get_object()) if fonts is not None else DictionaryObject()
        fonts[NameObject("/GflatPageNo")] = font
        resources = DictionaryObject(resources)
        resources[NameObject("/Font")] = fonts
        page[NameObject("/Resources")] = resources
        before, after = DecodedStreamObject(), DecodedStreamObject()
        before.set_data(b"q\n")
        after.set_data(
            f"Q\nq BT /GflatPageNo {PAGE_NUMBER_PT} Tf 0.35 g {x:.2f} {y:.2f} Td ({label}) Tj ET Q\n".encode("ascii")
        )
        contents = page.get("/Contents")
        streams = ArrayObject([writer._add_object(before)])  # noqa: SLF001
        if contents is not None:
            obj = contents.get_object()
            streams += list(obj) if isinstance(obj, ArrayObject) else [contents]
        streams.append(writer._add_object(after))  # noqa: SLF001
        page[NameObject("/Contents")] = streams


def _pages_of(data: bytes) -> tuple[int, dict]:
    """Page count of a printed PDF and the 0-based page of each of its named destinations."""
    from pypdf import PdfReader

    reader = PdfReader(io.BytesIO(data))
    return len(reader.pages), {
        str(name): reader.get_destination_page_number(d) for name, d in reader.named_destinations.items()
    }


def print_html(html: str, base_dir: str | Path) -> bytes:
    """Print one HTML document to PDF (weasyprint; the figures' PNG data embedded as it is).

    Parameters
    ----------
    html : str
        The document.
    base_dir : str or Path
        Folder its relative image paths resolve against (nothing outside it is read).

    Returns
    -------
    bytes
        The PDF.
    """
    return _print(html, str(Path(base_dir).resolve()) + os.sep)


def write_pdf(
    html: str | Sequence[str],
    base_dir: str | Path,
    path: str | Path,
    *,
    run_all=None,
    front=None,
    printed: Mapping[str, bytes] | None = None,
) -> Path:
    """Print an HTML document (or documents, end to end) to PDF with weasyprint.

    Parameters
    ----------
    html : str or sequence of str
        The document, or the documents of the cases (:func:`reports.html.pdf_documents`; more than one,
        or a ``front``, need pypdf).
    base_dir : str or Path
        Folder its relative image paths resolve against.
    path : str or Path
        The PDF to write; its folder must exist.
    run_all : callable, optional
        ``run_all(callables, jobs)`` -> their results in order: prints the documents concurrently (a command
        gives :func:`harness.parallel.run_all`); default one after the other.
    front : callable, optional
        ``front(pages) -> str``: the front matter, given the 1-based page of each named destination of the
        documents (:func:`reports.html.pdf_documents`); printed after them, put first, every page numbered.
    printed : mapping, optional
        Documents printed already (:func:`print_html`): HTML -> PDF; a document found there is not printed again.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    docs = [html] if isinstance(html, str) else list(html)
    base_url = str(Path(base_dir).resolve()) + os.sep
    import_weasyprint()  # imported once here, not in every printing worker

    if len(docs) == 1 and front is None:
        data = printed[docs[0]] if printed and docs[0] in printed else _print(docs[0], base_url)
    else:
        ready = dict(printed or {})
        todo = [doc for doc in dict.fromkeys(docs) if doc not in ready]
        prints = [lambda doc=doc: _print(doc, base_url) for doc in todo]
        done = list(run_all(prints, len(todo)) if run_all is not None and len(todo) > 1 else [p() for p in prints])
        ready.update(zip(todo, done))
        pdfs = [ready[doc] for doc in docs]
        if front is not None:
            where, offset = {}, 0
            for data in pdfs:
                n, dests = _pages_of(data)
                where.update({name: offset + p for name, p in dests.items()})
                offset += n
            guess = 1
            for _ in range(3):  # the front matter's own length shifts the pages it lists
                first = _print(front({name: guess + p + 1 for name, p in where.items()}), base_url)
                n = _pages_of(first)[0]
                if n == guess:
                    break
                guess = n
            pdfs = [first] + pdfs
        data = _merge(pdfs, number=front is not None)
    with writing(path):
        path.write_bytes(data)
    return path
