"""Source models a GNA term table can be fitted to.

* :mod:`.gtm` -- NASA GTM T2 aerodynamic database, evaluated as GTM_DesignSim does;
* :mod:`.jsbsim_aero` -- any JSBSim aircraft, evaluated through JSBSim itself;
* :mod:`.linear` -- linear stability-derivative models (UIUC Twin Otter).

Each is a :class:`~.base.SourceModel`.
"""

from .base import SourceModel, stability_from_body

__all__ = ["SourceModel", "stability_from_body"]
