"""The filters' backend seam: each filter (``ekf``, ``pf``, ``pf-paper``) runs a simulated log
end to end through a fake backend that offers the interface's operations only (and records
them), with the numpy reference's rows; the pure resamplers on worked examples (as FilterPy's
``filterpy.monte_carlo``); the layout: the kernel choice named in at most four files, no
backend branch in the filter modules."""

from __future__ import annotations

import ast
import re
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from lgvtool.localize import ekf as ekf_module
from lgvtool.localize import particles as particles_module
from lgvtool.localize.gaussian_backend import GaussianBackend, NumpyGaussian
from lgvtool.localize.kernel_choice import KERNELS_ENV
from lgvtool.localize.kld import KldSizing, kld_bound
from lgvtool.localize.particle_backend import NumpyParticles, PaperBlock, ParticleBackend
from lgvtool.localize.replay_driver import load_log, replay_data
from lgvtool.localize.resampling import (
    low_variance,
    multinomial,
    multinomial_resample,
    systematic_resample,
)
from lgvtool.log import LogReader

LOCALIZE = Path(__file__).resolve().parents[2] / "lgvtool" / "localize"
PACKAGE = LOCALIZE.parent


# ---------------------------------------------------------------------------- the fake backend
def interface(protocol: type) -> set[str]:
    """The operations a backend Protocol declares."""
    return {n for n in dir(protocol) if not n.startswith("_")}


class Recorded:
    """A backend that forwards the operations of ``protocol`` to ``inner`` and counts them; any
    other attribute is refused (a filter may use its backend's interface only). The blocks a
    particle backend makes are recorded alike."""

    def __init__(self, inner: object, protocol: type, calls: Counter[str]) -> None:
        self._inner = inner
        self._allowed = interface(protocol)
        self.calls = calls

    def __getattr__(self, name: str) -> Any:
        if name not in self._allowed:
            raise AttributeError(f"{name!r} is not an operation of the backend's interface")
        self.calls[name] += 1
        op = getattr(self._inner, name)
        if name != "paper_block":
            return op

        def block(*args: Any, **kwargs: Any) -> Recorded:
            return Recorded(op(*args, **kwargs), PaperBlock, self.calls)

        return block


@pytest.fixture(scope="module")
def sim_data(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, Any]:
    """A 25 s simulated paper-circle drive with the NAV200's reflector scans (as the paper's
    setup and the sample logs), loaded as the replay loads it."""
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    path = tmp_path_factory.mktemp("seam") / "drive.mcap"
    write_log(simulate("paper-circle", seed=5, duration=25.0,
                       overrides={"sim.paper_scans": True}), path)
    reader = LogReader(path)
    cfg = reader.config()
    data = load_log(reader, cfg.reflectors or None)
    assert data.has_scans and len(data.scans) > 100
    return data, cfg


#: what each filter must have asked its backend on the drive (at least)
USED = {
    "ekf": {"run"},
    "pf": {"predict", "scan_loglik", "weigh", "kld_systematic", "weighted_pose",
           "scan_tracker"},
    "pf-paper": {"pack", "paper_motions", "paper_block", "paper_scan", "paper_scans",
                 "paper_exponents", "paper_weigh", "paper_draws", "paper_redistribute", "move",
                 "weigh", "redistribute", "particles", "spread", "restart"},
}


@pytest.mark.parametrize("name", ["ekf", "pf", "pf-paper"])
def test_a_fake_backend_runs_each_filter(sim_data: tuple[Any, Any], name: str,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """The replay of the drive with a fake backend injected into the filter: the numpy
    reference's rows and clouds, bit for bit, and every operation the filter asked for was one
    of the interface's."""
    data, cfg = sim_data
    monkeypatch.setenv(KERNELS_ENV, "numpy")
    settings = {"pf.particles": 300} if name == "pf" else {}
    ref = replay_data(data, [name], config=cfg, seed=2, settings=settings)
    calls: Counter[str] = Counter()
    made: list[Recorded] = []

    def particle_backend() -> Recorded:
        made.append(Recorded(NumpyParticles(), ParticleBackend, calls))
        return made[-1]

    def gaussian_backend() -> Recorded:
        made.append(Recorded(NumpyGaussian(), GaussianBackend, calls))
        return made[-1]

    # the one place each filter takes its backend from
    monkeypatch.setattr(particles_module, "particle_backend", particle_backend)
    monkeypatch.setattr(ekf_module, "gaussian_backend", gaussian_backend)
    got = replay_data(data, [name], config=cfg, seed=2, settings=settings)
    assert len(made) == 1
    assert USED[name] <= set(calls), sorted(USED[name] - set(calls))
    a, b = ref.estimates[name], got.estimates[name]
    assert len(a.x) > 40  # (pf-paper weighs at the NAV polls: 2.2 per second)
    for col in ("t_ns", "x", "y", "heading", "covariance", "particles", "ess"):
        assert np.array_equal(getattr(a, col), getattr(b, col)), col
    ca, cb = ref.clouds.get(name, []), got.clouds.get(name, [])
    assert len(ca) == len(cb)
    for u, v in zip(ca, cb, strict=True):
        assert u[0] == v[0]
        assert all(np.array_equal(u[i], v[i]) for i in (1, 2, 3))


def test_a_backend_is_handed_in_or_chosen_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """``backend=`` is the filter's backend; without it the choice is made when the filter is
    made (the numpy reference with ``LGVTOOL_KERNELS=numpy``) and kept."""
    from lgvtool.localize.ekf import Ekf
    from lgvtool.localize.paper_pf import PaperParticleFilter
    from lgvtool.localize.particle_filter import ParticleFilter

    monkeypatch.setenv(KERNELS_ENV, "numpy")
    mine = NumpyParticles()
    assert ParticleFilter(backend=mine).backend is mine
    assert PaperParticleFilter(backend=mine).backend is mine
    g = NumpyGaussian()
    assert Ekf(backend=g).backend is g
    pf = ParticleFilter(ParticleFilter.configure(particles=20))
    assert isinstance(pf.backend, NumpyParticles)
    monkeypatch.setenv(KERNELS_ENV, "numba")  # later changes do not move a filter's choice
    assert isinstance(pf.backend, NumpyParticles)


# ---------------------------------------------------------------------------- resamplers
def test_systematic_resampling_worked_examples() -> None:
    """The positions ``(u0 + i) / n`` each select the first particle whose cumulative weight
    exceeds them."""
    w = np.array([0.1, 0.2, 0.3, 0.4])
    # positions 0.125, 0.375, 0.625, 0.875 against the cumulative 0.1, 0.3, 0.6, 1.0
    assert systematic_resample(w, 4, 0.5).tolist() == [1, 2, 3, 3]
    # positions 0.025, 0.275, 0.525, 0.775
    assert systematic_resample(w, 4, 0.1).tolist() == [0, 1, 2, 3]
    # equal weights: every particle once, whatever the offset
    for u0 in (0.1, 0.5, 0.999):
        assert systematic_resample(np.full(5, 0.2), 5, u0).tolist() == [0, 1, 2, 3, 4]
    # a particle of weight 0 is never drawn
    assert systematic_resample(np.array([0.5, 0.0, 0.5]), 4, 0.1).tolist() == [0, 0, 2, 2]
    # more draws than particles: 7 and 3 of 10
    assert systematic_resample(np.array([0.7, 0.3]), 10, 0.05).tolist() == [0] * 7 + [1] * 3
    # one draw
    assert systematic_resample(w, 1, 0.55).tolist() == [2]


def test_systematic_resampling_draws_each_particle_its_share() -> None:
    """Particle ``i`` is drawn ``floor(n w_i)`` or ``ceil(n w_i)`` times (the least spread),
    the indexes in order."""
    rng = np.random.default_rng(4)
    for m, n in ((1, 3), (10, 10), (57, 200), (300, 40)):
        w = rng.random(m) ** 3
        w /= w.sum()
        idx = systematic_resample(w, n, float(rng.random()))
        assert len(idx) == n and (np.diff(idx) >= 0).all()
        counts = np.bincount(idx, minlength=m)
        assert (counts >= np.floor(n * w) - 1e-9).all() and (counts <= np.ceil(n * w) + 1e-9).all()


def test_multinomial_resampling_worked_examples() -> None:
    """Each uniform number selects the first particle whose cumulative weight exceeds it."""
    w = np.array([0.1, 0.2, 0.3, 0.4])
    u = np.array([0.05, 0.15, 0.35, 0.65, 0.99, 0.0])
    assert multinomial_resample(w, u).tolist() == [0, 1, 2, 3, 3, 0]
    assert multinomial_resample(np.array([0.0, 1.0]), np.array([0.0, 0.5])).tolist() == [1, 1]
    assert multinomial_resample(w, np.zeros(0)).tolist() == []


def test_the_generator_resamplers_are_the_pure_ones_of_its_numbers() -> None:
    """``low_variance`` and ``multinomial`` draw ``random()`` and ``random(n)``, then resample
    with the pure functions."""
    w = np.random.default_rng(0).random(30)
    w /= w.sum()
    a, b = np.random.default_rng(9), np.random.default_rng(9)
    assert np.array_equal(low_variance(w, 50, a), systematic_resample(w, 50, b.random()))
    assert np.array_equal(multinomial(w, 50, a), multinomial_resample(w, b.random(50)))
    assert a.bit_generator.state == b.bit_generator.state


def test_kld_sizing() -> None:
    """KLD-sampling's count over draws in their order: ``n_min`` when every draw falls in one
    bin; with ``k`` bins among the draws, the first count at least the bound for ``k``
    (:func:`kld_bound`: 230.5 for 3 bins at 0.02 and 0.01); ``cap`` when the draws keep
    finding new bins; the bound per bin count made once."""
    s = KldSizing(0.02, 0.01, 10, 500, 0.25, 0.1)
    zero = np.zeros(500)
    assert s.count(zero, zero, zero) == 10
    x = zero.copy()
    x[[1, 2]] = [1.0, 2.0]  # draws 2 and 3 in bins of their own: 3 bins from the third on
    assert s.count(x, zero, zero) == 231
    assert s.count(np.arange(500.0), zero, zero) == 500
    assert np.array_equal(s.need, kld_bound(np.arange(1, 501), 0.02, 0.01))
    assert s.need is s.need


# ---------------------------------------------------------------------------- layout
#: the filter modules: they call their backend, never a kernel nor the choice
FILTERS = ("ekf.py", "deadreckoning.py", "particles.py", "particle_filter.py", "paper_pf.py",
           "pf_run.py")
#: names that would be a backend branch or a kernel used directly in a filter module
_FORBIDDEN = re.compile(r"^(_?kern|.*_kernels|compiled|Numpy(Particles|Gaussian)|"
                        r"Compiled(Particles|Gaussian)|KERNELS_ENV)$")


def _names_the_choice(path: Path) -> bool:
    """Whether a module names the kernel choice: ``LGVTOOL_KERNELS``, a call of ``compiled``,
    an import of a ``*_kernels`` module (or its name as a string, for importlib)."""
    text = path.read_text()
    if "LGVTOOL_KERNELS" in text:
        return True
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Call):
            f = node.func
            if (isinstance(f, ast.Name) and f.id == "compiled") or (
                    isinstance(f, ast.Attribute) and f.attr == "compiled"):
                return True
        elif isinstance(node, ast.ImportFrom):
            if (node.module or "").endswith("_kernels") or any(
                    a.name.endswith("_kernels") for a in node.names):
                return True
        elif isinstance(node, ast.Import):
            if any(a.name.endswith("_kernels") for a in node.names):
                return True
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and re.fullmatch(
                r"lgvtool\.localize\.\w+_kernels", node.value):
            return True
    return False


def test_the_kernel_choice_is_named_in_at_most_four_files() -> None:
    naming = sorted(str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
                    if _names_the_choice(p))
    assert {"localize/kernel_choice.py", "localize/pf_compiled.py",
            "localize/ekf_compiled.py"} <= set(naming)
    assert len(naming) <= 4, naming


@pytest.mark.parametrize("module", FILTERS)
def test_no_backend_branch_in_the_filter_modules(module: str) -> None:
    """A filter module names no kernel, no backend implementation and no kernel choice: the
    backend it holds is its one seam."""
    tree = ast.parse((LOCALIZE / module).read_text())
    for node in ast.walk(tree):
        name = node.id if isinstance(node, ast.Name) else node.attr \
            if isinstance(node, ast.Attribute) else node.arg if isinstance(node, ast.arg) \
            else None
        where = f"{module}:{getattr(node, 'lineno', '?')}"
        assert name is None or not _FORBIDDEN.match(name), f"{where}: {name}"
        if isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            assert not re.search(r"_kernels$|_compiled$", mod), f"{module} imports {mod}"
            for a in node.names:
                assert not _FORBIDDEN.match(a.name), f"{module} imports {a.name}"
