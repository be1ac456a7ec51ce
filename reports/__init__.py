"""Reports: rendering and writing of validation results (figures, text, JSON).

Fed by result objects only (:class:`harness.validation.CaseResult`, engine runs,
difference tables); nothing here plans or simulates.  Output goes under
``reports/out/`` by default (git-ignored).

Rooms
-----
figures
    Matplotlib figures of engine runs against each other and the plan: states,
    applied controls, differences to the reference engine (:func:`figures.write_figures`).
case_files
    A case's output folder: figures, and through :func:`harness.artefacts.write_artefacts`
    the trajectories (Parquet), ``differences.txt``, ``summary.json``, plan iterates and
    ``manifest.json`` (:func:`case_files.write_case`), all written atomically through
    :class:`harness.outdir.OutputDir`.

Rooms to come: HTML/PDF validation reports (one page per case, built from the
same result objects), campaign summaries (one table over many cases), the
paper's four-curve figures (flat plan, closed loop, generalized plan, open loop).
"""
