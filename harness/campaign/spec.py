"""Campaign files: a product of validation cases and aircraft dispersions, with one seed.

A campaign file (TOML)::

    name = "my-campaign"
    seed = 12345                  # campaign seed: every sample's seed derives from it
    samples = 16                  # per case and dispersion (``--samples`` overrides)
    case_budget_s = 600           # wall-time budget of one case [s] (``--case-budget`` overrides; inf: none)

    [[cases]]                     # one or more; a list in scenario, J or loop expands into a product
    id = "to"                     # optional label (default the scenario's stem)
    scenario = "twin-otter-single-engine"
    loop = "closed"               # or ["open", "closed"]
    engines = ["inhouse", "jsbsim"]
    J = 4                         # optional, or [0, 4]
    tolerances = 1e-2             # optional, as in a validation case
    dt_out = 0.05                 # optional output grid [s]; also rtol, jsbsim_dt, windows (the [compare] keys)
    tracking = "lqr"              # optional tracking design, over the scenario's [tracking] design

    [dispersions.fit]             # one or more named dispersion sets (all zero: the nominal aircraft)
    aero = "std_error"            # "std_error" (fitted sets), "relative" or "none"
    aero_sigma = 1.0              # multiple of each term's standard error
    aero_relative = 0.05          # 1-sigma relative spread (terms without a standard error, or aero = "relative")
    mass = 0.02                   # 1-sigma relative mass spread
    inertia = 0.05                # 1-sigma relative spread of the inertia matrix
    cg_cbar = 0.01                # 1-sigma shift of the centre of gravity along body x [fraction of cbar]
    position_m = 2.0              # 1-sigma initial position offset per NED axis [m]
    speed_mps = 0.5               # 1-sigma initial airspeed offset [m/s]
    angle_rad = 0.005             # 1-sigma offset of each of gamma, chi, alpha, beta, mu [rad]
    truncate = 3.0                # normal draws truncated at this many sigmas

    [output]
    trajectories = true           # write each case's trajectories (Parquet)

Unknown keys are refused with one line naming the closest known key.  Every
expanded case is checked before anything runs (:func:`harness.campaign.checks.check_case`):
its scenario exists (the closest bundled name suggested) and loads with the
case's J, J is within the planner's bounds, the comparison settings are valid
with the scenario's ``[compare]``, ``dt_out`` divides the scenario's span;
``id`` and the dispersion names, which name folders, are safe identifiers.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from gna.catalogue import bundled
from gna.errors import InputError
from gna.schema import check_name, find_file, read_toml, unknown_key_message
from planners.flat import check_iterations

from ..validation import ValidationCase
from .checks import check_case

__all__ = [
    "Campaign",
    "CaseSpec",
    "Dispersion",
    "SampleTask",
    "load_campaign",
    "campaign_from_dict",
    "bundled_campaigns",
    "AERO_MODES",
    "CASE_BUDGET_S",
    "MAX_CASE_SPECS",
    "MAX_DISPERSIONS",
]

#: Most expanded cases of a campaign file (each [[cases]] table's products of scenario, J and loop lists): every
#: one is checked when the file is read (its scenario loaded with its J); the bundled campaign has 3.
MAX_CASE_SPECS = 1000

#: Most dispersion sets of a campaign file (each multiplies the cases).
MAX_DISPERSIONS = 100

#: Default per-case time budget [s] (``case_budget_s``, ``gflat campaign run --case-budget``): a bundled sample
#: takes 7-11 s on a 2-core machine; a case beyond the budget ends as a timeout and the campaign goes on.
CASE_BUDGET_S = 600.0

#: How the aerodynamic terms are dispersed.
AERO_MODES: tuple[str, ...] = ("std_error", "relative", "none")

_TOP_KEYS = ("name", "description", "seed", "samples", "case_budget_s", "cases", "dispersions", "output")
_CASE_KEYS = (
    "id",
    "scenario",
    "J",
    "loop",
    "engines",
    "tolerances",
    "rtol",
    "dt_out",
    "jsbsim_dt",
    "windows",
    "tracking",
)
_EXPANDED = ("scenario", "J", "loop")
_DISP_KEYS = (
    "aero",
    "aero_sigma",
    "aero_relative",
    "mass",
    "inertia",
    "cg_cbar",
    "position_m",
    "speed_mps",
    "angle_rad",
    "truncate",
)
_OUTPUT_KEYS = ("trajectories",)


def _check_keys(table: Mapping, known, where: str) -> None:
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: must be a table, got {table!r}")
    for key in table:
        if key not in known:
            raise InputError(unknown_key_message(key, known, where))


def _number(value, key: str, where: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(float(value)):
        raise InputError(f"{where}: {key} must be a finite number, got {value!r}")
    if value < 0 or (positive and value == 0):
        raise InputError(f"{where}: {key} must be {'positive' if positive else '>= 0'}, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Dispersion:
    """A named set of 1-sigma spreads of the aircraft data and the initial state.

    Attributes
    ----------
    name : str
        Label of the set (part of every case id).
    aero : {"std_error", "relative", "none"}
        ``std_error``: each term ``theta_i + aero_sigma * se_i * z`` with the term's
        standard error ``se_i`` from the aircraft file (``aero_relative`` for a term
        without one); ``relative``: ``theta_i (1 + aero_relative z)``; ``none``.
    aero_sigma : float
        Multiple of the standard errors.
    aero_relative : float
        Relative 1-sigma spread of a term [-].
    mass, inertia : float
        Relative 1-sigma spreads of the mass and of the whole inertia matrix [-].
    cg_cbar : float
        1-sigma shift of ``x_cg`` along body x, as a fraction of the mean chord [-].
    position_m : float
        1-sigma offset of each of x, y, z at the start [m].
    speed_mps : float
        1-sigma offset of V at the start [m/s].
    angle_rad : float
        1-sigma offset of each of gamma, chi, alpha, beta, mu at the start [rad].
    truncate : float
        Normal draws ``z`` are clipped to ``[-truncate, truncate]``.
    """

    name: str = "nominal"
    aero: str = "std_error"
    aero_sigma: float = 1.0
    aero_relative: float = 0.0
    mass: float = 0.0
    inertia: float = 0.0
    cg_cbar: float = 0.0
    position_m: float = 0.0
    speed_mps: float = 0.0
    angle_rad: float = 0.0
    truncate: float = 3.0

    @classmethod
    def from_dict(cls, name: str, table: Mapping[str, Any], where: str) -> Dispersion:
        """A dispersion set from a TOML table.

        Parameters
        ----------
        name : str
            The set's name (the table's key).
        table : mapping
            Keys as the class attributes.
        where : str
            File and table, for messages.

        Returns
        -------
        Dispersion

        Raises
        ------
        InputError
            Unknown keys (with the closest known key), bad values.
        """
        _check_keys(table, _DISP_KEYS, where)
        kw: dict[str, Any] = {}
        for key in _DISP_KEYS:
            if key == "aero" or key not in table:
                continue
            kw[key] = _number(table[key], key, where, positive=key == "truncate")
        mode = table.get("aero", "std_error")
        if mode not in AERO_MODES:
            raise InputError(f"{where}: aero must be one of {', '.join(AERO_MODES)}, got {mode!r}")
        if (
            kw.get("mass", 0.0) * kw.get("truncate", 3.0) >= 1.0
            or kw.get("inertia", 0.0) * kw.get("truncate", 3.0) >= 1.0
        ):
            raise InputError(f"{where}: mass and inertia spreads times truncate must stay below 1 (positive mass)")
        return cls(name=name, aero=mode, **kw)

    def to_dict(self) -> dict:
        """The set as a plain dict (for the store).

        Returns
        -------
        dict
        """
        return {k: getattr(self, k) for k in ("name",) + _DISP_KEYS}


@dataclass(frozen=True)
class CaseSpec:
    """One expanded case of a campaign: a validation case with its label.

    Attributes
    ----------
    label : str
        Unique label (``id`` plus the expanded values).
    case : ValidationCase
        What to plan, fly and compare.
    """

    label: str
    case: ValidationCase


@dataclass(frozen=True)
class SampleTask:
    """One unit of work: a case, a dispersion set, a sample index and its seed (picklable).

    Attributes
    ----------
    case_id : str
        ``<label>.<dispersion>.<sample:04d>``, unique in the campaign.
    spec : CaseSpec
    dispersion : Dispersion
    sample : int
    seed : int
        The sample's seed (:func:`harness.campaign.sampling.sample_seed`).
    trajectories : bool
        Return the trajectories for the store.
    budget_s : float
        Wall-time budget of the case [s] (``inf``: none; :func:`harness.campaign.execute.run_sample`).
    """

    case_id: str
    spec: CaseSpec
    dispersion: Dispersion
    sample: int
    seed: int
    trajectories: bool = True
    budget_s: float = CASE_BUDGET_S

    def parameters(self) -> dict:
        """The task's parameters as JSON-able data (the store's ``params`` column).

        Returns
        -------
        dict
        """
        c = self.spec.case
        return {
            "label": self.spec.label,
            "scenario": c.scenario,
            "J": c.J,
            "loop": c.loop,
            "engines": list(c.engines),
            **c.overrides,
            **({"tracking": c.tracking} if c.tracking is not None else {}),
            "dispersion": self.dispersion.to_dict(),
            "sample": self.sample,
            "seed": self.seed,
        }


@dataclass(frozen=True)
class Campaign:
    """A parsed campaign file.

    Attributes
    ----------
    name : str
    seed : int
        Campaign seed (every sample's seed derives from it).
    samples : int
        Samples per case and dispersion set.
    cases : tuple of CaseSpec
    dispersions : tuple of Dispersion
    description : str
    trajectories : bool
        Write each case's trajectories.
    case_budget_s : float
        Wall-time budget of one case [s] (``inf``: none); a case beyond it ends as a timeout.
    source : str
        The file read (or the bundled name).
    raw : dict
        The parsed table (stored with the campaign).
    tracking : {"paper", "lqr"} or None
        The tracking design set for every case (``gflat campaign run --tracking``,
        :meth:`with_tracking`); part of the campaign's identity in its folder.
    """

    name: str
    seed: int
    samples: int
    cases: tuple
    dispersions: tuple
    description: str = ""
    trajectories: bool = True
    case_budget_s: float = CASE_BUDGET_S
    source: str = ""
    raw: dict = field(default_factory=dict, repr=False, compare=False)
    tracking: str | None = None

    def with_tracking(self, design: str | None) -> Campaign:
        """The campaign with every case flying the tracking design ``design`` (None: unchanged).

        Parameters
        ----------
        design : {"paper", "lqr"} or None

        Returns
        -------
        Campaign

        Raises
        ------
        InputError
            Another design name.
        """
        if design is None:
            return self
        cases = tuple(replace(c, case=replace(c.case, tracking=design)) for c in self.cases)
        return replace(self, cases=cases, tracking=design)

    def tasks(self, samples: int | None = None) -> list[SampleTask]:
        """Every sample of the campaign, in a fixed order (case, dispersion, sample).

        Parameters
        ----------
        samples : int, optional
            Samples per case and dispersion; default the file's.

        Returns
        -------
        list of SampleTask
            Seeds from :func:`harness.campaign.sampling.sample_seed` (the same
            whatever ``samples``: sample k's seed does not depend on the count).

        Raises
        ------
        InputError
            ``samples`` not a positive integer.
        """
        from .sampling import sample_seed

        n = self.samples if samples is None else samples
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise InputError(f"samples must be a positive integer, got {n!r}")
        out = []
        for spec in self.cases:
            for disp in self.dispersions:
                key = f"{spec.label}.{disp.name}"
                for k in range(n):
                    seed = sample_seed(self.seed, key, k)
                    out.append(SampleTask(f"{key}.{k:04d}", spec, disp, k, seed, self.trajectories, self.case_budget_s))
        return out


def _expand_case(entry: Mapping, where: str, base: Path | None, loaded: dict) -> list[CaseSpec]:
    _check_keys(entry, _CASE_KEYS, where)
    if "scenario" not in entry:
        raise InputError(f"{where}: missing 'scenario'")
    if "id" in entry:
        check_name(entry["id"], "id", where)  # part of every case folder's name
    lists = {k: entry[k] for k in _EXPANDED if isinstance(entry.get(k), list)}
    if any(len(v) == 0 for v in lists.values()):
        raise InputError(f"{where}: an empty list in {', '.join(k for k, v in lists.items() if not v)}")
    out = []
    for combo in itertools.product(*lists.values()):
        data = {k: v for k, v in entry.items() if k != "id"}
        data.update(dict(zip(lists, combo)))
        label = str(entry.get("id") or Path(str(data["scenario"])).stem)
        for k, v in zip(lists, combo):
            label += f"-{Path(str(v)).stem}" if k == "scenario" else f"-{k}{v}" if k == "J" else f"-{v}"
        if data.get("J") is not None and not isinstance(data["J"], str):  # the planner's bounds, first
            check_iterations(data["J"], f"{where} (case {label})")
        case = ValidationCase.from_dict(data, where=where, base=base)
        check_case(case, f"{where} (case {label})", loaded)
        out.append(CaseSpec(label, case))
    return out


def campaign_from_dict(data: Mapping[str, Any], where: str = "campaign", base: Path | None = None) -> Campaign:
    """Build a :class:`Campaign` from a parsed TOML table.

    Parameters
    ----------
    data : mapping
        Keys as in the module docstring.
    where : str
        Name of the source, for messages.
    base : Path, optional
        Folder that relative scenario paths are resolved against.

    Returns
    -------
    Campaign

    Raises
    ------
    InputError
        Unknown keys (with the closest known key), missing or bad values, duplicate case labels,
        a case that cannot run (:func:`harness.campaign.checks.check_case`: unknown scenario, J out
        of bounds, ...): one line naming the file, the case, the key and the value.
    """
    _check_keys(data, _TOP_KEYS, where)
    seed = data.get("seed")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"{where}: seed must be a non-negative whole number, got {seed!r}")
    samples = data.get("samples", 1)
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise InputError(f"{where}: samples must be a positive whole number, got {samples!r}")
    cases_raw = data.get("cases")
    if not isinstance(cases_raw, list) or not cases_raw:
        raise InputError(f"{where}: needs at least one [[cases]] table")
    expanded = sum(
        math.prod(len(v) for k, v in entry.items() if k in _EXPANDED and isinstance(v, list))
        for entry in cases_raw
        if isinstance(entry, Mapping)
    )
    if expanded > MAX_CASE_SPECS:
        raise InputError(
            f"{where}: the [[cases]] tables expand to {expanded} cases (products of their scenario, J and loop "
            f"lists), above the bound of {MAX_CASE_SPECS}"
        )
    budget = data.get("case_budget_s", CASE_BUDGET_S)
    if isinstance(budget, bool) or not isinstance(budget, (int, float)) or not budget > 0:
        raise InputError(f"{where}: case_budget_s must be a positive number of seconds (or inf), got {budget!r}")
    cases: list[CaseSpec] = []
    loaded: dict = {}  # scenarios by (name, J), loaded once
    for i, entry in enumerate(cases_raw):
        cases += _expand_case(entry, f"{where} [[cases]] #{i + 1}", base, loaded)
    labels = [c.label for c in cases]
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise InputError(f"{where}: duplicate case labels {', '.join(dup)} (give each [[cases]] an id)")
    disp_raw = data.get("dispersions", {"nominal": {"aero": "none"}})
    if not isinstance(disp_raw, Mapping) or not disp_raw:
        raise InputError(f"{where}: [dispersions.NAME] tables expected, got {disp_raw!r}")
    if len(disp_raw) > MAX_DISPERSIONS:
        raise InputError(f"{where}: {len(disp_raw)} dispersion sets, above the bound of {MAX_DISPERSIONS}")
    disps = tuple(
        Dispersion.from_dict(check_name(n, "name", f"{where} [dispersions.{n}]"), t, f"{where} [dispersions.{n}]")
        for n, t in disp_raw.items()
    )
    out = data.get("output", {})
    _check_keys(out, _OUTPUT_KEYS, f"{where} [output]")
    traj = out.get("trajectories", True)
    if not isinstance(traj, bool):
        raise InputError(f"{where} [output]: trajectories must be true or false, got {traj!r}")
    return Campaign(
        name=str(data.get("name", where)),
        seed=seed,
        samples=samples,
        cases=tuple(cases),
        dispersions=disps,
        description=str(data.get("description", "")),
        trajectories=traj,
        case_budget_s=float(budget),
        source=where,
        raw=dict(data),
    )


def bundled_campaigns() -> dict[str, Path]:
    """The campaigns shipped with gflat.

    Returns
    -------
    dict
        Name -> path of the TOML file.
    """
    return bundled("harness", "campaign", "campaigns")


def load_campaign(name_or_path: str | Path) -> Campaign:
    """Load a bundled campaign by name, or a campaign file by path.

    Parameters
    ----------
    name_or_path : str or Path
        Bundled name (``paper-dispersions``) or path of a TOML file.

    Returns
    -------
    Campaign

    Raises
    ------
    InputError
        Unknown name, unreadable or invalid file, unknown keys, bad values.
    """
    cat = bundled_campaigns()
    path = find_file(name_or_path, cat, "campaign")  # a missing file, a folder, a name not ending in .toml
    if path is None:
        raise InputError(
            f"unknown campaign {str(name_or_path)!r}; bundled campaigns: {', '.join(cat)} "
            f"(or give the path of a .toml file)"
        )
    camp = campaign_from_dict(read_toml(path), where=path.name, base=path.parent)  # UTF-8 (BOM accepted), TOML
    return replace(camp, source=str(path.resolve()))
