"""Localisation: the paper's particle filter, its improved variant and the baselines.

Pure estimators (no file, no clock) behind one interface (:class:`Estimator`), usable from
Python without a log::

    from lgvtool.localize import ParticleFilter, Motion, ScanObservation
    pf = ParticleFilter(ParticleFilter.configure(particles=500), vehicle=cfg.vehicle,
                        reflectors=cfg.reflectors, area=cfg.area, rng=np.random.default_rng(1))
    pf.predict(Motion(0.018, 0.0, 0.026))
    pf.update(ScanObservation.simple(t, ranges, bearings, nav_x=1.0))
    pf.estimate()

and the replay driver that runs them over a log (:func:`run_replay`). An estimator's parameters
are a frozen dataclass (``ParticleFilter.Params``, :class:`PfParams`); ``Cls.configure(**values)``
makes them from overrides, each value checked. The filters' array operations go through one
backend per filter (:mod:`lgvtool.localize.particle_backend`,
:mod:`lgvtool.localize.gaussian_backend`), the compiled kernels or numpy chosen once
(:mod:`lgvtool.localize.kernel_choice`).
"""

from typing import TYPE_CHECKING

from lgvtool.lazy_names import lazy_names

if TYPE_CHECKING:
    from lgvtool.localize.deadreckoning import DeadReckoning, DeadReckoningParams
    from lgvtool.localize.ekf import Ekf, EkfParams
    from lgvtool.localize.estimator import Estimate, Estimator, Motion
    from lgvtool.localize.laser import LaserBaseline, LaserParams
    from lgvtool.localize.motion import MotionSettings, MotionTrack
    from lgvtool.localize.observations import PoseObservation, RawScan, ScanObservation
    from lgvtool.localize.paper_pf import PaperParticleFilter, PaperPfParams
    from lgvtool.localize.particle_filter import ParticleFilter, PfParams
    from lgvtool.localize.registry import DEFAULT_ESTIMATORS, ESTIMATORS
    from lgvtool.localize.replay_driver import ReplayResult, run_replay

#: public name -> module that defines it (imported on first use, so that a command running
#: one estimator does not import the others)
_EXPORTS = {
    "DeadReckoning": "deadreckoning", "DeadReckoningParams": "deadreckoning",
    "Ekf": "ekf", "EkfParams": "ekf",
    "Estimate": "estimator", "Estimator": "estimator", "Motion": "estimator",
    "LaserBaseline": "laser", "LaserParams": "laser",
    "MotionSettings": "motion", "MotionTrack": "motion",
    "PoseObservation": "observations", "RawScan": "observations",
    "ScanObservation": "observations",
    "PaperParticleFilter": "paper_pf", "PaperPfParams": "paper_pf",
    "ParticleFilter": "particle_filter", "PfParams": "particle_filter",
    "DEFAULT_ESTIMATORS": "registry", "ESTIMATORS": "registry",
    "ReplayResult": "replay_driver", "run_replay": "replay_driver",
}


__getattr__, __dir__ = lazy_names(__name__, _EXPORTS, globals())

__all__ = [
    "DEFAULT_ESTIMATORS",
    "ESTIMATORS",
    "DeadReckoning",
    "DeadReckoningParams",
    "Ekf",
    "EkfParams",
    "Estimate",
    "Estimator",
    "LaserBaseline",
    "LaserParams",
    "Motion",
    "MotionSettings",
    "MotionTrack",
    "PaperParticleFilter",
    "PaperPfParams",
    "ParticleFilter",
    "PfParams",
    "PoseObservation",
    "RawScan",
    "ReplayResult",
    "ScanObservation",
    "run_replay",
]
