"""The controller protocol: a feedback block with its own states, flown by every engine.

A controller sees the time ``t`` [s] and the 12 wind-frame states ``x``
(:data:`gna.eom.STATE_NAMES`, SI units, radians) and adds a correction
``delta_u`` to the reference controls ``(F, eta, dl, dm, dn)`` [N, -, rad, rad,
rad].  It may carry ``n_states`` states of its own ``xc`` (integral terms of a
tracking feedback, filter states), integrated together with the aircraft:

* the in-house engine appends ``xc`` to the 12 aircraft states and integrates
  ``(x, xc)`` with one integrator (``dxc/dt = derivative(t, x, xc)``);
* a sampled engine (JSBSim) advances ``xc`` at every one of its steps with an
  explicit scheme that it records in its result.

This follows python-control's ``create_statefbk_iosystem``: the controller is
its own block with its own states, not a closure over mutable variables, so
the same object can be flown by several engines (and pickled for campaigns).
A stateless feedback ``f(t, x) -> delta_u`` is the zero-state case
(:class:`StatelessController`, made by :func:`as_controller`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from .errors import InputError


@runtime_checkable
class Controller(Protocol):
    """What an engine needs of a feedback block.

    Attributes
    ----------
    n_states : int
        Number of controller states (0 for a static feedback).

    Notes
    -----
    An optional attribute ``state_names`` (``n_states`` strings) names the
    columns of a result's ``controller_states`` (:func:`state_names`).
    """

    n_states: int

    def initial_state(self, t0: float, x0: np.ndarray) -> np.ndarray:
        """Controller states at the start of a run.

        Parameters
        ----------
        t0 : float
            Start time [s].
        x0 : ndarray, shape (12,)
            Initial aircraft state (wind-frame, SI, rad).

        Returns
        -------
        ndarray, shape (n_states,)
        """

    def derivative(self, t: float, x: np.ndarray, xc: np.ndarray) -> np.ndarray:
        """Time derivative of the controller states.

        Parameters
        ----------
        t : float
            Time [s].
        x : ndarray, shape (12,)
            Aircraft state.
        xc : ndarray, shape (n_states,)
            Controller state.

        Returns
        -------
        ndarray, shape (n_states,)
        """

    def output(self, t: float, x: np.ndarray, xc: np.ndarray) -> np.ndarray:
        """Correction added to the reference controls.

        Parameters
        ----------
        t : float
            Time [s].
        x : ndarray, shape (12,)
            Aircraft state.
        xc : ndarray, shape (n_states,)
            Controller state.

        Returns
        -------
        ndarray, shape (5,)
            ``(dF [N], d_eta [-], d_dl, d_dm, d_dn [rad])``.
        """


_EMPTY = np.zeros(0)


@dataclass(frozen=True)
class StatelessController:
    """A static feedback ``f(t, x) -> delta_u`` seen as a zero-state :class:`Controller`.

    Parameters
    ----------
    function : callable
        ``function(t, x) -> 5 corrections`` with ``t`` [s] and ``x`` the 12 states.
    """

    function: Callable

    n_states = 0

    def initial_state(self, t0: float, x0: np.ndarray) -> np.ndarray:
        """Initial controller state: none.

        Parameters
        ----------
        t0 : float
            Initial time [s].
        x0 : ndarray, shape (12,)
            Initial aircraft state (SI, rad).

        Returns
        -------
        ndarray, shape (0,)
            An empty array.
        """
        return _EMPTY

    def derivative(self, t: float, x: np.ndarray, xc: np.ndarray) -> np.ndarray:
        """Derivative of the controller state: none.

        Parameters
        ----------
        t : float
            Time [s].
        x : ndarray, shape (12,)
            Aircraft state (SI, rad).
        xc : ndarray, shape (0,)
            Controller state (empty).

        Returns
        -------
        ndarray, shape (0,)
            An empty array.
        """
        return _EMPTY

    def output(self, t: float, x: np.ndarray, xc: np.ndarray) -> np.ndarray:
        """Control corrections ``function(t, x)``.

        Parameters
        ----------
        t : float
            Time [s].
        x : ndarray, shape (12,)
            Aircraft state (SI, rad).
        xc : ndarray, shape (0,)
            Controller state (empty, unused).

        Returns
        -------
        ndarray, shape (5,)
            Corrections of ``(F, eta, dl, dm, dn)`` [N, -, rad, rad, rad], as floats.
        """
        return np.asarray(self.function(t, x), dtype=float).reshape(5)


def as_controller(obj) -> Controller | None:
    """A :class:`Controller` from ``None``, a controller, or a callable ``(t, x) -> 5 corrections``.

    Parameters
    ----------
    obj : None, Controller or callable
        What a user passed as ``controller=``.

    Returns
    -------
    Controller or None

    Raises
    ------
    InputError
        If ``obj`` is neither, or declares a negative number of states.
    """
    if obj is None:
        return None
    if all(callable(getattr(obj, m, None)) for m in ("initial_state", "derivative", "output")) and hasattr(
        obj, "n_states"
    ):
        n = obj.n_states
        if not (isinstance(n, (int, np.integer)) and n >= 0):
            raise InputError(f"a controller's n_states must be a non-negative integer, got {n!r}")
        return obj
    if callable(obj):
        return StatelessController(obj)
    raise InputError(
        f"controller must be a Controller (n_states, initial_state, derivative, output) or a "
        f"callable (t, x) -> 5 corrections; got {type(obj).__name__}"
    )


def evaluate(controller: Controller, t: float, x: np.ndarray, xc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A controller's output and state derivative at one point, in one call when it offers one.

    Engines need both at the same ``(t, x, xc)``; a controller may define
    ``output_and_derivative(t, x, xc)`` to share the work (the tracking feedback
    evaluates its reference and gains once), otherwise :meth:`Controller.output`
    and :meth:`Controller.derivative` are called in turn.  Both ways give the same
    numbers.

    Parameters
    ----------
    controller : Controller
        The feedback block.
    t : float
        Time [s].
    x : ndarray, shape (12,)
        Aircraft state (wind-frame, SI, rad).
    xc : ndarray, shape (n_states,)
        Controller state.

    Returns
    -------
    output : ndarray, shape (5,)
        Correction to the reference controls ``(dF [N], d_eta [-], d_dl, d_dm, d_dn [rad])``.
    derivative : ndarray, shape (n_states,)
        Time derivative of the controller state.
    """
    both = getattr(controller, "output_and_derivative", None)
    if both is not None:
        out, der = both(t, x, xc)
    else:
        out, der = controller.output(t, x, xc), controller.derivative(t, x, xc)
    return (np.asarray(out, dtype=float).reshape(5), np.asarray(der, dtype=float).reshape(int(controller.n_states)))


def at_sample_times(controller: Controller | None, times: np.ndarray) -> Controller | None:
    """The controller prepared for a sampled engine that will call it at ``times`` only.

    A controller may define ``at_times(times)`` returning an equivalent controller
    with work done in advance for those times (the tracking feedback
    precomputes its reference and gains there); others are returned unchanged.

    Parameters
    ----------
    controller : Controller or None
        The feedback block.
    times : ndarray, shape (M,)
        The times [s] at which the engine will evaluate it.

    Returns
    -------
    Controller or None
    """
    prepare = getattr(controller, "at_times", None)
    return controller if prepare is None else prepare(times)


def sample_evaluator(controller: Controller | None):
    """A prepared controller's per-sample evaluation on floats, when it offers one.

    A controller returned by :func:`at_sample_times` may define
    ``sample_evaluator()`` returning ``f(m, x, xc) -> (output, derivative)``:
    :func:`evaluate` at the m-th of those times, the same numbers, on
    sequences of floats and returning lists (the tracking feedback reads its
    table by index, without the array bookkeeping of a general call).

    Parameters
    ----------
    controller : Controller or None
        The feedback block, prepared by :func:`at_sample_times`.

    Returns
    -------
    callable or None
        ``f(m, x, xc)``: ``m`` the sample's index, ``x`` the 12 aircraft states and
        ``xc`` the ``n_states`` controller states (sequences of float); the 5
        corrections and the ``n_states`` derivatives as lists of float.  None when
        the controller has none.
    """
    make = getattr(controller, "sample_evaluator", None)
    return None if make is None else make()


def checked_initial_state(controller: Controller, t0: float, x0: np.ndarray) -> np.ndarray:
    """A controller's initial state, checked: ``n_states`` finite values.

    Parameters
    ----------
    controller : Controller
        The controller (as returned by :func:`as_controller`).
    t0 : float
        Start time [s].
    x0 : ndarray, shape (12,)
        Initial aircraft state (wind-frame, SI, rad); the controller gets a copy.

    Returns
    -------
    ndarray, shape (n_states,)
        ``controller.initial_state(t0, x0)`` as floats.

    Raises
    ------
    InputError
        If it is not ``n_states`` finite values.
    """
    nc = int(controller.n_states)
    xc0 = np.asarray(controller.initial_state(t0, np.array(x0, dtype=float)), dtype=float).reshape(-1)
    if xc0.shape != (nc,) or not np.all(np.isfinite(xc0)):
        raise InputError(f"the controller's initial state must be {nc} finite values, got {xc0}")
    return xc0


def state_names(controller: Controller | None) -> tuple[str, ...]:
    """Names of a controller's states: its ``state_names`` attribute if any, else ``xc0, xc1, ...``.

    Parameters
    ----------
    controller : Controller or None
        The controller (None: no states).

    Returns
    -------
    tuple of str
        ``n_states`` names (empty for None or a static feedback).

    Raises
    ------
    InputError
        If ``state_names`` does not have ``n_states`` entries.
    """
    if controller is None:
        return ()
    n = int(controller.n_states)
    names = getattr(controller, "state_names", None)
    if names is None:
        return tuple(f"xc{i}" for i in range(n))
    names = tuple(str(v) for v in names)
    if len(names) != n:
        raise InputError(f"the controller names {len(names)} states ({', '.join(names)}) but has n_states = {n}")
    return names
