"""The estimators by name, and how ``--set`` style settings reach their parameters."""

from __future__ import annotations

import importlib
from collections.abc import Iterable, Iterator, Mapping
from typing import TYPE_CHECKING

from lgvtool.errors import InputError
from lgvtool.localize.params import make_params
from lgvtool.suggest import unknown_tail

if TYPE_CHECKING:
    from lgvtool.localize.estimator import Estimator
    from lgvtool.localize.noise import MotionParams

#: name -> (module, class) of every estimator
_WHERE: dict[str, tuple[str, str]] = {
    "laser": ("lgvtool.localize.laser", "LaserBaseline"),
    "deadreckoning": ("lgvtool.localize.deadreckoning", "DeadReckoning"),
    "ekf": ("lgvtool.localize.ekf", "Ekf"),
    "pf-paper": ("lgvtool.localize.paper_pf", "PaperParticleFilter"),
    "pf": ("lgvtool.localize.particle_filter", "ParticleFilter"),
}


class _Estimators(Mapping[str, "type[Estimator[object]]"]):
    """The estimator classes by name. A class's module is imported when the class is first
    asked for, so that running one estimator does not import the others."""

    def __init__(self) -> None:
        self._classes: dict[str, type[Estimator[object]]] = {}

    def __getitem__(self, name: str) -> type[Estimator[object]]:
        cls = self._classes.get(name)
        if cls is None:
            module, attr = _WHERE[name]
            cls = self._classes[name] = getattr(importlib.import_module(module), attr)
        return cls

    def forget(self, name: str) -> None:
        """Drop the imported class of ``name`` (after :func:`unregister`)."""
        self._classes.pop(name, None)

    def __contains__(self, name: object) -> bool:
        return name in _WHERE

    def __iter__(self) -> Iterator[str]:
        return iter(_WHERE)

    def __len__(self) -> int:
        return len(_WHERE)

    def __repr__(self) -> str:
        return f"ESTIMATORS({', '.join(_WHERE)})"


#: name -> estimator class
_CLASSES = _Estimators()
ESTIMATORS: Mapping[str, type[Estimator[object]]] = _CLASSES

def register(name: str, module: str, cls: str) -> None:
    """Make the estimator class ``cls`` of ``module`` known as ``name``, after the others: an
    estimator is its class and its ``Params`` declarations (:mod:`lgvtool.declared`), so from
    here on ``-e name``, ``--set name.<param>``, ``[estimators.name]`` and ``lgvtool config
    --parameters`` know it. The module is imported when the class is first asked for.

    :raises ValueError: ``name`` is already an estimator.
    """
    if name in _WHERE:
        raise ValueError(f"estimator '{name}' is already registered")
    _WHERE[name] = (module, cls)


def unregister(name: str) -> None:
    """Forget an estimator that :func:`register` made known."""
    _WHERE.pop(name, None)
    _CLASSES.forget(name)


#: what replay runs when no estimator is named
DEFAULT_ESTIMATORS: tuple[str, ...] = ("laser", "deadreckoning", "ekf", "pf-paper", "pf")


def in_run_order(names: list[str] | tuple[str, ...]) -> list[str]:
    """``names`` (e.g. the estimates a log holds) in the order replay runs and reports the
    estimators (:data:`ESTIMATORS`), names of no known estimator after them, sorted."""
    known = {n: i for i, n in enumerate(_WHERE)}
    return sorted(names, key=lambda n: (known.get(n, len(known)), n))


def unknown_estimator(name: str, also: Iterable[str] = (), where: str = "") -> InputError:
    """The one error for an estimator name that is none of :data:`ESTIMATORS` (nor of
    ``also``, e.g. the estimates a log holds): the closest names first ("did you mean
    'pf-paper'?"), then the known ones. ``where`` follows the name (`` in setting 'x.y'``)."""
    known = [*ESTIMATORS, *(n for n in also if n not in ESTIMATORS)]
    return InputError(f"unknown estimator '{name}'{where}{unknown_tail(name, known)}")


def check_names(names: list[str] | tuple[str, ...], also: Iterable[str] = ()) -> list[str]:
    """The names, deduplicated in order; InputError for one that is neither an estimator nor
    one of ``also`` (names accepted besides, e.g. the estimates a log holds), suggesting the
    closest ("unknown estimator 'pf-papr': did you mean 'pf-paper'? (known: ...)")."""
    accepted = set(also)
    out: list[str] = []
    for n in names:
        if n not in ESTIMATORS and n not in accepted:
            raise unknown_estimator(n, also)
        if n not in out:
            out.append(n)
    return out


def split_settings(settings: Mapping[str, object] | None) -> dict[str, dict[str, object]]:
    """``{"pf.particles": 500}`` -> ``{"pf": {"particles": 500}}``; nested dicts pass through.

    Raises InputError for a key without an estimator part or an unknown estimator.
    """
    out: dict[str, dict[str, object]] = {}
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
            raise unknown_estimator(name, where=f" in setting '{key}'")
        out.setdefault(name, {}).update(sub)
    return out


def resolve_params(name: str, config_estimators: Mapping[str, Mapping[str, object]] | None,
                   overrides: Mapping[str, object] | None) -> object:
    """Parameters of estimator ``name`` (its ``Params``): defaults, then the config's
    ``[estimators.<name>]``, then ``overrides``; every key checked."""
    cls = ESTIMATORS[name]
    base: object = make_params(cls.Params, name, dict((config_estimators or {}).get(name, {})))
    return make_params(cls.Params, name, overrides or {}, base=base)


def motion_params(name: str, params: object) -> MotionParams:
    """``params``, the parameters of estimator ``name``, as its motion parameters: an
    estimator that uses motion declares them (:class:`lgvtool.localize.noise.MotionParams`,
    its motion noise and odometry settings).

    :raises TypeError: ``params`` are no MotionParams (an estimator's programming error).
    """
    from lgvtool.localize.noise import MotionParams

    if not isinstance(params, MotionParams):
        raise TypeError(f"estimator '{name}' uses motion, but its parameters "
                        f"({type(params).__name__}) are no MotionParams")
    return params
