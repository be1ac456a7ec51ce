"""What every source model provides, and helpers shared by the sources.

A source model is an aerodynamic model that a GNA term table is fitted to.
It evaluates the six coefficients in the project's conventions (stability-axis
CD, CL; body-axis CY, Cl, Cm, Cn about the moment reference; gna surface
signs), vectorised over numpy arrays, so it can also be flown: set it as
``aircraft.aero`` (``dataclasses.replace``) and :func:`gna.trim.trim` trims
it with the same equations of motion as the fitted model (``analytic`` is
False: tables are not complex-analytic, trim uses central differences).
"""

from __future__ import annotations

import abc
from collections.abc import Mapping

import numpy as np

from ...aero import AeroState, Coefficients
from ...errors import InputError
from ..design import SamplingDesign, format_range, format_value


def stability_from_body(alpha, CX, CZ):
    """Stability-axis ``(CD, CL)`` from body-axis ``CX`` (forward) and ``CZ`` (down).

    ``CD = -(CX cos a + CZ sin a)``, ``CL = CX sin a - CZ cos a``: the body force rotated through alpha
    about y into stability axes, drag along ``-x_s`` and lift along ``-z_s`` (docs/conventions.md).

    Parameters
    ----------
    alpha : float or ndarray
        Angle of attack [rad].
    CX, CZ : float or ndarray
        Body-axis force coefficients along x (forward) and z (down), broadcast with ``alpha``.

    Returns
    -------
    CD, CL : float or ndarray
        Stability-axis drag and lift coefficients.
    """
    ca, sa = np.cos(alpha), np.sin(alpha)
    return -(CX * ca + CZ * sa), CX * sa - CZ * ca


def broadcast_state(state: AeroState) -> tuple[AeroState, tuple[int, ...]]:
    """Float arrays of the state broadcast together, and their common shape.

    Parameters
    ----------
    state : AeroState
        The eight aerodynamic variables (floats or arrays) [rad / nondimensional].

    Returns
    -------
    state : AeroState
        The same variables as float arrays of one shape (read-only broadcast views).
    shape : tuple of int
        Their common shape.
    """
    arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in state))
    return AeroState(*arrays), arrays[0].shape


class SourceModel(abc.ABC):
    """Base class of the source models.

    Attributes
    ----------
    name : str
        Short description, e.g. ``"JSBSim F4N at Mach 0.6, 10000 ft"``.
    envelope : dict
        Variable -> (lo, hi) [rad or nondimensional]: the domain covered by the
        source's data.  A sampling design reaching outside it is refused.
    analytic : bool
        False: the model is tabulated (trim must not use complex step).
    """

    analytic = False
    name: str = "source"
    envelope: Mapping[str, tuple[float, float]] = {}

    @abc.abstractmethod
    def coefficients(self, state: AeroState) -> Coefficients:
        """The six coefficients in the project's conventions.

        Parameters
        ----------
        state : AeroState
            The eight aerodynamic variables (floats or arrays, broadcast together) [rad / nondimensional].

        Returns
        -------
        Coefficients
            Stability-axis CD, CL; body-axis CY, Cl, Cm, Cn about the moment reference; arrays of the
            broadcast shape.
        """

    def provenance(self) -> dict[str, str]:
        """Source description for the fitted aircraft file.

        Returns
        -------
        dict of str to str
            ``{"source": name}``; subclasses add ``"source_model"`` (how the model is evaluated).
        """
        return {"source": self.name}

    def check_design(self, design: SamplingDesign) -> None:
        """Refuse a design that samples outside :attr:`envelope`.

        Parameters
        ----------
        design : SamplingDesign
            Its blocks' ranges are compared with the envelope (relative tolerance 1e-9).

        Raises
        ------
        InputError
            Naming the block, the variable, the design's value and the source's range.
        """
        for block in design.blocks:
            for var, (lo_src, hi_src) in self.envelope.items():
                lo, hi = block.ranges[var]
                tol = 1e-9 * max(1.0, abs(lo_src), abs(hi_src))
                for value in (lo, hi):
                    if value < lo_src - tol or value > hi_src + tol:
                        why = getattr(self, "envelope_origin", {}).get(var)
                        raise InputError(
                            f"sampling envelope outside the source's data: {var} = {format_value(var, value)} "
                            f"(design block {block.name!r}) is outside {format_range(var, lo_src, hi_src)} "
                            f"covered by {self.name}" + (f" ({why})" if why else "")
                        )
