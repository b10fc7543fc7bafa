"""The estimators by name, and how ``--set`` style settings reach their parameters."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from lgvtool.errors import InputError
from lgvtool.localize.deadreckoning import DeadReckoning
from lgvtool.localize.ekf import Ekf
from lgvtool.localize.estimator import Estimator
from lgvtool.localize.laser import LaserBaseline
from lgvtool.localize.paper_pf import PaperParticleFilter
from lgvtool.localize.params import make_params
from lgvtool.localize.particle_filter import ParticleFilter

#: name -> estimator class
ESTIMATORS: dict[str, type[Estimator]] = {
    cls.name: cls
    for cls in (LaserBaseline, DeadReckoning, Ekf, PaperParticleFilter, ParticleFilter)
}

#: what replay runs when no estimator is named
DEFAULT_ESTIMATORS: tuple[str, ...] = ("laser", "deadreckoning", "ekf", "pf-paper", "pf")


def check_names(names: list[str] | tuple[str, ...]) -> list[str]:
    """The names, deduplicated in order; InputError for an unknown one."""
    out: list[str] = []
    for n in names:
        if n not in ESTIMATORS:
            raise InputError(f"unknown estimator '{n}' (known: {', '.join(ESTIMATORS)})")
        if n not in out:
            out.append(n)
    return out


def split_settings(settings: Mapping[str, Any] | None) -> dict[str, dict[str, Any]]:
    """``{"pf.particles": 500}`` -> ``{"pf": {"particles": 500}}``; nested dicts pass through.

    Raises InputError for a key without an estimator part or an unknown estimator.
    """
    out: dict[str, dict[str, Any]] = {}
    for key, value in (settings or {}).items():
        if isinstance(value, Mapping):
            name, sub = key, dict(value)
        else:
            name, dot, param_name = key.rpartition(".")
            if not dot or not name or not param_name:
                raise InputError(f"setting '{key}' must be <estimator>.<param> "
                                 f"(estimators: {', '.join(ESTIMATORS)})")
            sub = {param_name: value}
        if name not in ESTIMATORS:
            raise InputError(f"unknown estimator '{name}' in setting '{key}' (known: "
                             f"{', '.join(ESTIMATORS)})")
        out.setdefault(name, {}).update(sub)
    return out


def resolve_params(name: str, config_estimators: Mapping[str, Mapping[str, Any]] | None,
                   overrides: Mapping[str, Any] | None) -> Any:
    """Parameters of estimator ``name``: defaults, then the config's ``[estimators.<name>]``,
    then ``overrides``; every key checked."""
    cls = ESTIMATORS[name]
    base: Any = make_params(cls.Params, name, dict((config_estimators or {}).get(name, {})))
    return make_params(cls.Params, name, overrides or {}, base=base)
