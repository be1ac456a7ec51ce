"""Validation cases: what to plan, fly and compare, as a frozen, picklable value.

A :class:`ValidationCase` names the scenario, the number of generalized-flatness
iterations J, the engines (the reference first), open or closed loop, the
tolerances, the comparison windows and the output grid; it loads from TOML
(:meth:`ValidationCase.from_toml`, :func:`load_case`).  A case file::

    scenario = "gtm-forward-slip"       # bundled name, or a path relative to this file
    J = 4                               # optional: the scenario's
    engines = ["inhouse", "jsbsim"]     # the first is the reference
    loop = "open"
    dt_out = 0.05                       # output grid [s]
    jsbsim_dt = 0.0020833333            # JSBSim's own step [s]
    self_convergence = false            # JSBSim also at half its step
    tolerances = 1e-2                   # or a table quantity/variable -> absolute tolerance
    rtol = { position = 1e-6 }          # relative tolerances (fraction of max |reference|)
    [windows]                           # name -> duration from t0 [s], or "all"
    "first 10 s" = 10.0
    "whole span" = "all"

Every comparison setting left unset (None) is taken from the scenario's
``[compare]`` table, else the defaults (:mod:`harness.validation.tolerances`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gna.errors import InputError
from gna.schema import read_toml
from planners.lqr import check_design

from ..engines import check_engine_names
from ..metrics import DEFAULT_WINDOWS
from .tolerances import parse_compare, unknown_key

#: Loop kinds of a case: the plan's controls alone, or with the tracking feedback.
LOOPS: tuple[str, ...] = ("open", "closed")

_CASE_KEYS = (
    "scenario",
    "J",
    "engines",
    "loop",
    "tolerances",
    "rtol",
    "windows",
    "dt_out",
    "jsbsim_dt",
    "self_convergence",
    "tracking",
)


# --------------------------------------------------------------------------- the case


def _positive(value, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise InputError(f"{what} must be a positive number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class ValidationCase:
    """One validation run: a scenario planned and flown on several engines.

    Attributes
    ----------
    scenario : str
        Bundled scenario name or path of a scenario TOML file.
    J : int, "auto" or None
        Generalized-flatness iterations (``"auto"``: chosen by the convergence test,
        :func:`planners.generalized.choose_J`; ``None``: the scenario's).
    engines : tuple of str
        At least two distinct engine names (:func:`harness.engines.engine_names`); the first is the reference.
    loop : {"open", "closed"}
        ``"open"``: the plan's controls alone.  ``"closed"``: with the paper's
        tracking feedback (the scenario's ``[tracking]`` settings,
        :func:`harness.validation.closed.closed_loop_setup`).
    tolerances : None, float or tuple of (str, float) pairs
        Absolute tolerances of the engine-against-reference tables, per
        quantity (``position``, ``velocity``, ``angle``, ``rate``) or variable
        (:func:`harness.validation.tolerances.expand_tolerances`); a mapping
        given to the constructor is stored as sorted pairs (the case stays
        hashable).  None: the scenario's ``[compare]``, else the defaults.
    rtol : None, float or tuple of (str, float) pairs
        Relative tolerances, same forms.
    windows : None or tuple of (str, float or None) pairs
        Comparison windows: name -> duration from t0 [s] (``None``: whole span);
        a mapping given to the constructor is stored as pairs, in order.
    dt_out : float or None
        Output grid step of every engine and of the plan comparison [s].
    jsbsim_dt : float or None
        JSBSim's step [s], independent of ``dt_out``.
    self_convergence : bool or None
        Also fly JSBSim at half its step and report that difference.
    tracking : {"paper", "lqr"} or None
        Closed loop: the tracking design flown (``--tracking``), over the scenario's
        ``[tracking] design``; None: the scenario's.
    """

    scenario: str
    J: int | str | None = None
    engines: tuple = ("inhouse", "jsbsim")
    loop: str = "open"
    tolerances: Any = None
    windows: Any = None
    dt_out: float | None = None
    rtol: Any = None
    jsbsim_dt: float | None = None
    self_convergence: bool | None = None
    tracking: str | None = None

    def __post_init__(self):
        set_ = object.__setattr__
        if isinstance(self.scenario, Path):
            set_(self, "scenario", str(self.scenario))
        if not isinstance(self.scenario, str) or not self.scenario:
            raise InputError(f"scenario must be a name or a path, got {self.scenario!r}")
        if (
            self.J is not None
            and self.J != "auto"
            and (isinstance(self.J, bool) or not isinstance(self.J, int) or self.J < 0)
        ):
            raise InputError(f"J must be an integer >= 0, 'auto' or None, got {self.J!r}")
        # a comparison: at least two distinct engines, the rule of gflat compare --engines
        set_(self, "engines", check_engine_names(self.engines, minimum=2))
        if self.loop not in LOOPS:
            raise InputError(f"loop must be one of {', '.join(LOOPS)}, got {self.loop!r}")
        if self.tracking is not None:
            check_design(self.tracking, "tracking")
        for name in ("tolerances", "rtol"):
            tol = getattr(self, name)
            if isinstance(tol, Mapping):
                tol = tuple(sorted((str(k), v) for k, v in tol.items()))
            elif isinstance(tol, list):
                tol = tuple(tuple(p) for p in tol)
            set_(self, name, tol)
        if self.windows is not None:
            win = self.windows.items() if isinstance(self.windows, Mapping) else self.windows
            win = tuple((str(k), None if d is None else _positive(d, f"window {k!r}")) for k, d in win)
            names = [k for k, _ in win]
            repeated = sorted({k for k in names if names.count(k) > 1})
            if repeated:
                raise InputError(f"windows: each name once, {', '.join(map(repr, repeated))} repeated")
            if not win:
                raise InputError("a case needs at least one comparison window")
            set_(self, "windows", win)
        if self.dt_out is not None:
            set_(self, "dt_out", _positive(self.dt_out, "dt_out"))
        parse_compare(self.overrides, "case")  # refuse bad values now, not after flying

    @property
    def tolerance_spec(self):
        """The absolute tolerances as given (None, float or dict quantity/variable -> value)."""
        return dict(self.tolerances) if isinstance(self.tolerances, tuple) else self.tolerances

    @property
    def window_spec(self) -> dict:
        """The windows as a dict name -> duration [s] or None (the defaults when unset)."""
        return dict(self.windows) if self.windows is not None else dict(DEFAULT_WINDOWS)

    @property
    def overrides(self) -> dict:
        """The comparison settings this case sets, as a ``[compare]`` table (unset ones are None)."""
        return {
            "tolerances": self.tolerance_spec,
            "rtol": dict(self.rtol) if isinstance(self.rtol, tuple) else self.rtol,
            "windows": dict(self.windows) if self.windows is not None else None,
            "dt_out": self.dt_out,
            "jsbsim_dt": self.jsbsim_dt,
            "self_convergence": self.self_convergence,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "case", base: Path | None = None) -> ValidationCase:
        """A case from a mapping (a TOML table).

        Parameters
        ----------
        data : mapping
            Keys ``scenario`` (required), ``J``, ``engines`` (list of names),
            ``loop``, ``tolerances`` and ``rtol`` (number or table quantity or
            variable -> number), ``windows`` (table name -> duration [s], or
            ``"all"`` for the whole span), ``dt_out`` and ``jsbsim_dt`` [s],
            ``self_convergence``.
        where : str
            Name of the source, for messages.
        base : Path, optional
            Folder a relative scenario path (``*.toml``) is resolved against.

        Returns
        -------
        ValidationCase

        Raises
        ------
        InputError
            Unknown or missing keys, or bad values (naming the key).
        """
        for k in data:
            if k not in _CASE_KEYS:
                raise unknown_key(k, _CASE_KEYS, where)
        if "scenario" not in data:
            raise InputError(f"{where}: missing 'scenario'")
        kw = dict(data)
        sc = str(kw["scenario"])
        if base is not None and sc.endswith(".toml") and not Path(sc).is_absolute():
            sc = str(base / sc)
        kw["scenario"] = sc
        if "engines" in kw:
            kw["engines"] = tuple(kw["engines"]) if isinstance(kw["engines"], list) else kw["engines"]
        if isinstance(kw.get("windows"), Mapping):
            kw["windows"] = {k: (None if v == "all" else v) for k, v in kw["windows"].items()}
        try:
            return cls(**kw)
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> ValidationCase:
        """A case from a TOML file (keys as :meth:`from_dict`; scenario paths relative to the file).

        Parameters
        ----------
        path : str or Path
            The case file.

        Returns
        -------
        ValidationCase

        Raises
        ------
        InputError
            Missing file, invalid TOML, unknown keys or bad values.
        """
        p = Path(path)
        if not p.is_file():
            raise InputError(f"cannot read the case file {p}: {'it is a folder' if p.is_dir() else 'no such file'}")
        return cls.from_dict(read_toml(p), where=p.name, base=p.parent)  # UTF-8 (BOM accepted), valid TOML


def load_case(path: str | Path) -> ValidationCase:
    """A :class:`ValidationCase` from a TOML file (:meth:`ValidationCase.from_toml`).

    Parameters
    ----------
    path : str or Path
        The case file.

    Returns
    -------
    ValidationCase
        The case, scenario paths resolved against the file's folder.

    Raises
    ------
    InputError
        Missing file, invalid TOML, unknown keys or bad values.
    """
    return ValidationCase.from_toml(path)
