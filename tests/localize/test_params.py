"""Estimator parameters and settings."""

from __future__ import annotations

import numpy as np
import pytest

from lgvtool.errors import InputError
from lgvtool.localize import ESTIMATORS, ParticleFilter
from lgvtool.localize.geometry import nav_to_o, o_to_nav
from lgvtool.localize.registry import resolve_params, split_settings
from lgvtool.quantiles import chi2_cdf, chi2_quantile


def test_split_settings() -> None:
    assert split_settings({"pf.particles": 5, "pf-paper.spread_m": 0.3}) == {
        "pf": {"particles": 5}, "pf-paper": {"spread_m": 0.3}}
    with pytest.raises(InputError, match="unknown estimator 'nope'"):
        split_settings({"nope.x": 1})
    with pytest.raises(InputError, match=r"<estimator>\.<param>"):
        split_settings({"particles": 1})


def test_unknown_and_bad_parameters() -> None:
    with pytest.raises(InputError, match=r"unknown parameter 'pf\.nope'"):
        resolve_params("pf", {}, {"nope": 1})
    with pytest.raises(InputError, match=r"pf\.particles must be an integer"):
        resolve_params("pf", {}, {"particles": "many"})
    with pytest.raises(InputError, match=r"pf\.resample must be one of"):
        resolve_params("pf", {}, {"resample": "sometimes"})
    with pytest.raises(InputError, match="at least"):
        resolve_params("pf-paper", {}, {"spread_m": -1.0})
    p = resolve_params("pf", {"pf": {"particles": 300}}, {"kld": "false"})
    assert isinstance(p, ParticleFilter.Params)
    assert p.particles == 300 and p.kld is False


def test_paper_defaults() -> None:
    p = ESTIMATORS["pf-paper"].Params()
    assert (p.particles, p.top_fraction, p.local_fraction, p.spread_m) == (150, 0.25, 0.95, 0.25)
    # each reflector weighed at the particle carried to its own measurement time
    assert p.init == "uniform" and p.use_ids is False and p.deskew is True
    # a large uniform start for the first updates; 150 from then on
    assert p.start_particles > p.particles and p.start_updates > 0


def test_particle_filter_without_a_log() -> None:
    pf = ParticleFilter(ParticleFilter.configure(particles=50), rng=np.random.default_rng(0))
    assert pf.initialized and len(pf.x) == 50
    assert pf.estimate() is not None


def test_chi2_quantiles() -> None:
    assert abs(chi2_quantile(0.95, 1) - 3.841458820694124) < 1e-9
    assert abs(chi2_quantile(0.99, 2) - 9.210340371976182) < 1e-9
    assert abs(chi2_quantile(0.99, 3) - 11.344866730144373) < 1e-9
    assert abs(chi2_cdf(chi2_quantile(0.5, 3), 3) - 0.5) < 1e-12
    # more degrees of freedom (landmark fixes), against the tabulated quantiles
    for p, dof, q in ((0.99, 4, 13.276704135987622), (0.99, 7, 18.475306906582357),
                      (0.95, 10, 18.307038053275146), (0.5, 9, 8.342832692252955)):
        assert chi2_quantile(p, dof) == pytest.approx(q, rel=1e-9)


def test_eq5_round_trip() -> None:
    x, y, h = o_to_nav(3.0, 4.0, 0.7, 1.0, 0.2)
    xo, yo, ho = nav_to_o(x, y, h, 1.0, 0.2)
    assert np.allclose([xo, yo, ho], [3.0, 4.0, 0.7])
