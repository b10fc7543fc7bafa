"""The checks of the configuration's ``[estimators.*]`` and ``[simulator]`` tables, against the
layers that own their names: the estimators (:mod:`lgvtool.localize.registry`) and the
simulator (:mod:`lgvtool.sim.scenarios`, :mod:`lgvtool.sim.settings`).

:mod:`lgvtool.config` sits below both and imports neither; it calls these through its table of
section checks (:func:`lgvtool.config.register_section_check`), into which
``lgvtool/__init__.py`` registers them, so every configuration built
(:func:`lgvtool.config.load_config`, :func:`lgvtool.config.config_from_dict`, a log's stored
one) is checked as ``replay`` and ``lgvtool simulate`` would check it. The estimators and the
simulator are imported inside the checks, when a configuration holds their tables.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from lgvtool.config import Config, config_from_dict
from lgvtool.errors import ConfigError
from lgvtool.suggest import unknown_tail


def check_estimators(table: Mapping[str, Any], cfg: Config) -> dict[str, Any]:
    """``[estimators.*]`` checked as a replay would check it: known estimators and parameters,
    values of the right type and range (``cfg``, the configuration so far, is not needed)."""
    from lgvtool.localize.registry import ESTIMATORS, resolve_params

    for name, params in table.items():
        if name not in ESTIMATORS:
            raise ConfigError(f"unknown estimator [estimators.{name}]"
                              + unknown_tail(name, ESTIMATORS, prefix="estimators."))
        if not isinstance(params, dict):
            raise ConfigError(f"[estimators.{name}] must be a table")
        resolve_params(name, None, params)
    return dict(table)


def check_simulator(table: Mapping[str, Any], cfg: Config) -> dict[str, Any]:
    """``[simulator]`` checked as ``lgvtool simulate`` would check it (keys, types, ranges)."""
    from lgvtool.sim.scenarios import SCENARIOS
    from lgvtool.sim.settings import SimSettings, apply_overrides, flatten

    flat = flatten(table)
    vehicle = {k.partition(".")[2]: v for k, v in flat.items() if k.startswith("vehicle.")}
    if vehicle:
        config_from_dict({"vehicle": vehicle}, base=cfg)
    rest = {k: v for k, v in flat.items() if not k.startswith("vehicle.")}
    settings = apply_overrides(SimSettings(), rest)
    known = {k for sc in SCENARIOS.values() for k in sc.defaults}
    for key, value in settings.scenario.items():
        if key not in known:
            raise ConfigError(f"unknown setting 'scenario.{key}'"
                              + unknown_tail(key, sorted(known), prefix="scenario.", more=(
                                  f"{len(known)} scenario settings; lgvtool simulate --list "
                                  "lists them")))
        sc = next(sc for sc in SCENARIOS.values() if key in sc.defaults)
        sc.parameters({key: value})
    return dict(table)
