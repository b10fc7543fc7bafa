"""Estimator parameters: each estimator's ``Params`` is a group of declared settings
(:mod:`lgvtool.declared`, the one mechanism shared with the simulator and the configuration).

:func:`param` declares one parameter (default, documentation ending in its unit, range or
choices); :func:`make_params` applies ``{param: value}`` overrides with one clear error for a
mistake; :func:`params_dict` gives the values as JSON.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TypeVar

from lgvtool.declared import JSONScalar, as_dict, make, setting

P = TypeVar("P")

param = setting
"""Declare one estimator parameter (:func:`lgvtool.declared.setting`)."""


def make_params(cls: type[P], owner: str, overrides: Mapping[str, object] | None = None,
                base: P | None = None) -> P:
    """``cls`` with ``overrides`` applied over ``base`` (or the defaults).

    Raises :class:`lgvtool.errors.ConfigError` naming ``owner.param`` for an unknown parameter
    or a value of the wrong type or range.
    """
    return make(cls, owner, overrides, base,
                more="{n} parameters of " + owner + "; lgvtool config --parameters lists them")


def params_dict(params: object) -> dict[str, JSONScalar]:
    """The parameters as a plain JSON-able dict (infinities as strings)."""
    return as_dict(params)
