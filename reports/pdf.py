"""PDF validation report: the run's single HTML document printed by weasyprint (text stays extractable).

Each case starts a new page under a level-1 heading (a PDF bookmark) that
carries its PASS/FAIL; the figures are the case folder's PNG files.
"""

from __future__ import annotations

import os
from pathlib import Path

from harness.fileio import replacing


def write_pdf(html: str, base_dir: str | Path, path: str | Path) -> Path:
    """Print an HTML document to PDF with weasyprint, through a temporary file renamed into place.

    Parameters
    ----------
    html : str
        The document (:func:`reports.html.single_document`).
    base_dir : str or Path
        Folder its relative image paths resolve against.
    path : str or Path
        The PDF to write; its folder must exist.

    Returns
    -------
    Path
        ``path``.
    """
    import weasyprint

    path = Path(path)
    with replacing(path) as tmp:
        weasyprint.HTML(string=html, base_url=str(Path(base_dir).resolve()) + os.sep).write_pdf(tmp)
    return path
