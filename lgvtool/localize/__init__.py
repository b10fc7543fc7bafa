"""Localisation: the paper's particle filter, its improved variant and the baselines.

Pure estimators (no file, no clock) behind one interface (:class:`Estimator`), usable from
Python without a log::

    from lgvtool.localize import ParticleFilter, Motion, ScanObservation
    pf = ParticleFilter(vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                        rng=np.random.default_rng(1), particles=500)
    pf.predict(Motion(0.018, 0.0, 0.026))
    pf.update(ScanObservation.simple(t, ranges, bearings, nav_x=1.0))
    pf.estimate()

and the replay driver that runs them over a log (:func:`run_replay`).
"""

from lgvtool.localize.deadreckoning import DeadReckoning, DeadReckoningParams
from lgvtool.localize.ekf import Ekf, EkfParams
from lgvtool.localize.estimator import Estimate, Estimator, Motion
from lgvtool.localize.laser import LaserBaseline, LaserParams
from lgvtool.localize.motion import MotionSettings, MotionTrack
from lgvtool.localize.observations import PoseObservation, RawScan, ScanObservation
from lgvtool.localize.paper_pf import PaperParticleFilter, PaperPfParams
from lgvtool.localize.particle_filter import ParticleFilter, PfParams
from lgvtool.localize.registry import DEFAULT_ESTIMATORS, ESTIMATORS
from lgvtool.localize.replay import ReplayResult, run_replay

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
