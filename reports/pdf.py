"""PDF validation report: the run's single HTML document printed by weasyprint (text stays extractable).

Each case starts a new page under a level-1 heading (a PDF bookmark) that
carries its PASS/FAIL; the figures are the case folder's PNG files.  The
document may come in parts cut at case boundaries
(:func:`reports.html.document_parts`): the parts are printed concurrently in
worker processes and put end to end with pypdf, bookmarks and the summary's
links to the cases kept.
"""

from __future__ import annotations

import io
import os
from collections.abc import Sequence
from pathlib import Path

from gna.errors import writing


def can_merge() -> bool:
    """Whether printed parts can be put together (pypdf is installed).

    Returns
    -------
    bool
    """
    try:
        import pypdf  # noqa: F401
    except ImportError:
        return False
    return True


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


def _print(html: str, base_url: str) -> bytes:
    import gc

    import weasyprint

    gc.collect()
    gc.freeze()  # the objects alive before printing are not scanned again by every collection
    try:
        return weasyprint.HTML(string=html, base_url=base_url, url_fetcher=_fetcher(base_url)).write_pdf()
    finally:
        gc.unfreeze()


def _merge(parts: list[bytes]) -> bytes:
    """PDF documents end to end: pages, bookmarks, links and the named destinations they point to."""
    from pypdf import PdfReader, PdfWriter
    from pypdf.generic import ArrayObject, DictionaryObject, FloatObject, NameObject, NumberObject, TextStringObject

    readers = [PdfReader(io.BytesIO(p)) for p in parts]
    writer = PdfWriter()
    for reader in readers:
        writer.append(reader, import_outline=True)
    # named destinations: the last part's of each name (the first part's anchors of later cases are placeholders
    # that let weasyprint print the summary's links)
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
    buf = io.BytesIO()
    writer.write(buf)
    return buf.getvalue()


def write_pdf(html: str | Sequence[str], base_dir: str | Path, path: str | Path, *, run_all=None) -> Path:
    """Print an HTML document (or its parts, end to end) to PDF with weasyprint.

    Parameters
    ----------
    html : str or sequence of str
        The document (:func:`reports.html.single_document`), or its parts
        (:func:`reports.html.document_parts`; several need pypdf).
    base_dir : str or Path
        Folder its relative image paths resolve against.
    path : str or Path
        The PDF to write; its folder must exist.
    run_all : callable, optional
        ``run_all(callables, jobs)`` -> their results in order: prints the parts concurrently (a command gives
        :func:`harness.parallel.run_all`); default one after the other.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    docs = [html] if isinstance(html, str) else list(html)
    base_url = str(Path(base_dir).resolve()) + os.sep
    if len(docs) == 1:
        data = _print(docs[0], base_url)
    else:
        prints = [lambda doc=doc: _print(doc, base_url) for doc in docs]
        printed = run_all(prints, len(docs)) if run_all is not None else [p() for p in prints]
        data = _merge(list(printed))
    with writing(path):
        path.write_bytes(data)
    return path
