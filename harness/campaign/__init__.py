"""Validation campaigns: many cases and dispersed aircraft, run in parallel, stored, resumable, reported.

Rooms
-----
spec
    Campaign files (:func:`load_campaign`, :class:`Campaign`, :class:`Dispersion`, :class:`SampleTask`).
sampling
    Seeds and draws (:func:`sample_seed`, :func:`draw_sample`, :func:`dispersed_aircraft`).
execute
    One sample as a pure function (:func:`run_sample`).
store
    The campaign folder: SQLite index and case files (:class:`CampaignStore`).
runner
    :func:`run_campaign` (process pool or Dask), :func:`rerun_case`.
batch, integrators, montecarlo
    Many samples of the in-house model integrated at once (:func:`harness.campaign.batch.simulate_batch`,
    per-sample DOP853 vectorised over the samples), a plan's Monte Carlo and its metrics
    (:func:`harness.campaign.montecarlo.fly_batch`).
report
    :func:`campaign_summary`, :func:`write_report`, :func:`render_campaign`.
"""

from .execute import run_sample
from .runner import rerun_case, run_campaign
from .sampling import dispersed_aircraft, draw_sample, sample_seed
from .spec import Campaign, Dispersion, SampleTask, bundled_campaigns, campaign_from_dict, load_campaign
from .store import CampaignStore

__all__ = [
    "run_sample",
    "rerun_case",
    "run_campaign",
    "dispersed_aircraft",
    "draw_sample",
    "sample_seed",
    "Campaign",
    "Dispersion",
    "SampleTask",
    "bundled_campaigns",
    "campaign_from_dict",
    "load_campaign",
    "CampaignStore",
]
