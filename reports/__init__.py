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
    ``manifest.json`` (:func:`case_files.write_case`), into a plain folder (a
    command's staging folder, :class:`harness.rundir.RunDir`, which the
    command puts in place whole).
tracking
    The paper's four-curve figure of a closed-loop case (:func:`tracking.write_tracking_figure`).
model
    A case's report model, saved as ``report.json`` in its folder
    (:func:`model.write_case_report`), with the report's own figures
    (:mod:`report_figures`: singularity monitor, controls with their limits,
    signed differences).
html, pdf, templates/
    The run's ``index.html``, a ``case.html`` per case, the single-file
    ``report.html`` rendered with jinja2, and ``report.pdf`` printed by Typst
    (``templates/report.typ``, given a JSON view: :mod:`pdf`), from the saved
    models only (:func:`html.render_run`, ``gflat report DIR``).

Rooms to come: campaign summaries (one table over many cases).
"""
