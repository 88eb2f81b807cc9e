"""Particle-size distributions: the diameters of a packing, from a spec string to a seeded sample and its descriptors.

A distribution is named by a **spec** (command line ``--psd``, config ``distributions``), ``family:parameters``:

===========================================  ===================================================================
``lognormal:sigma=0.3``                      the paper's: log-normal D with relative std sigma (0 = monodisperse)
``gaussian:delta=0.2``                       normal D with mean 1 and relative std delta, truncated at D > 0
``uniform:ratio=2``                          D uniform on [d_min, ratio d_min]
``bidisperse:ratio=1.4,small=0.5,by=number`` two sizes 1 and ratio; ``small`` is the small spheres' share by
                                             ``number`` or by ``volume`` (``by`` is required)
``powerlaw:exponent=-3,ratio=10``            number density p(D) ~ D^exponent on [d_min, ratio d_min]
``table:powder.csv``                         a measured PSD (sieve or laser-diffraction export, docs/psd.md)
``list:diameters.txt``                       exact diameters, one per line (N is the number of lines)
===========================================  ===================================================================

**Normalisation.** Every distribution and every sample is scaled to **number-mean diameter 1** (M1 = <D> = 1, the
arithmetic mean over spheres), as the paper does; a drawn sample is rescaled to sample mean exactly 1. Only relative
sizes matter: a packing's length unit is fixed later (the box side, or contact).

**Descriptors** (:class:`Descriptors`), for the population (closed forms) and for a sample: the relative standard
deviation delta = std(D)/<D>, the skewness S = <(D - <D>)^3>/std^3, the size ratio d_max/d_min, the moments
M_k = <D^k> (k = 1, 2, 3, of the mean-1 distribution) and z = M2^2/(M1 M3) (1 for equal spheres).

Bad specs and files raise :class:`~spherejam.core.errors.InputError` with one line naming the field and the value.
"""

from __future__ import annotations

import csv
import hashlib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.special import ndtr, ndtri

from .errors import InputError
from .input_paths import regular_file

FAMILIES = ("lognormal", "gaussian", "uniform", "bidisperse", "powerlaw", "table", "list")
#: Largest lognormal sigma: beyond it the size ratios of a sample grow without practical bound.
MAX_SIGMA = 1.0
#: A per-bin column may miss 1 (or 100 %) by this much (instrument rounding); it is then renormalised exactly.
SUM_TOLERANCE = 0.005
#: Largest size ratio a parametric family accepts (a sample of N spheres needs a box several d_max wide).
MAX_RATIO = 1000.0


@dataclass(frozen=True)
class Descriptors:
    """Scale-free descriptors of a set of diameters (population or sample), with moments of the mean-1 scaling."""

    delta: float
    skewness: float
    size_ratio: float
    m1: float
    m2: float
    m3: float

    @property
    def z(self) -> float:
        """Santos et al.'s z = M2^2 / (M1 M3): 1 for equal spheres, towards 0 with polydispersity."""
        return self.m2 * self.m2 / (self.m1 * self.m3)

    def as_dict(self) -> dict[str, float]:
        return {"delta": self.delta, "skewness": self.skewness, "size_ratio": self.size_ratio,
                "m1": self.m1, "m2": self.m2, "m3": self.m3, "z": self.z}


def descriptors_from_moments(m1: float, m2: float, m3: float, size_ratio: float) -> Descriptors:
    """Descriptors from raw moments <D>, <D^2>, <D^3> of any scaling (they are rescaled to <D> = 1)."""
    m2n, m3n = m2 / m1**2, m3 / m1**3
    var = max(m2n - 1.0, 0.0)
    std = math.sqrt(var)
    skew = (m3n - 3.0 * m2n + 2.0) / std**3 if std > 1e-12 else 0.0
    return Descriptors(std, skew, float(size_ratio), 1.0, m2n, m3n)


def sample_descriptors(diameters) -> Descriptors:
    """Descriptors of the sample ``diameters`` (population formulas over the N values)."""
    d = np.asarray(diameters, dtype=float)
    d = d / d.mean()
    std = float(d.std())
    skew = float(np.mean((d - 1.0) ** 3) / std**3) if std > 1e-12 else 0.0
    return Descriptors(std, skew, float(d.max() / d.min()), 1.0, float(np.mean(d**2)), float(np.mean(d**3)))


# --- the families --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SizeDistribution:
    """A particle-size distribution: its spec, a seeded draw, representative points and descriptors.

    Subclasses give :meth:`_draw` (raw diameters of any scale), :meth:`_raw_moments` (<D>, <D^2>, <D^3> of the same
    scale), :meth:`_bounds` and :meth:`_support`.
    """

    spec: str

    family = ""

    def draw(self, n: int, rng: np.random.Generator, normalise: bool = True) -> np.ndarray:
        """``n`` diameters from the stream ``rng``, scaled to sample mean exactly 1 (``normalise=False``: in the
        family's own unit, the file's for a table or list)."""
        self.check_n(int(n))
        d = self._draw(int(n), rng)
        # a file's sizes are held relative to its largest (any unit, 1e-200 or 1e300, gives finite moments)
        return d / d.mean() if normalise else d * float(getattr(self, "source", {}).get("largest_size", 1.0))

    def check_n(self, n: int) -> None:
        """Raise :class:`InputError` if a sample of ``n`` spheres cannot be the distribution asked for (a mixture
        that would lose one of its sizes, a list of another length). Called by every draw, and by the workflow for
        each N of a config before any job runs."""

    def descriptors(self) -> Descriptors:
        """The population's descriptors (closed forms)."""
        lo, hi = self._bounds()
        return descriptors_from_moments(*self._raw_moments(), hi / lo if lo > 0 else math.inf)

    def support(self, points: int = 20_000) -> tuple[np.ndarray, np.ndarray]:
        """Representative diameters (mean-1 scale) and their number weights (sum 1): the exact sizes of a discrete
        distribution, or ``points`` quantiles of a continuous one. Models (Farr-Groot) integrate over these."""
        d, w = self._support(points)
        w = np.asarray(w, dtype=float) / np.sum(w)
        return np.asarray(d, dtype=float) / float(np.sum(w * d)), w

    @property
    def fixed_n(self) -> int | None:
        """N the distribution prescribes (``list:``), else None."""
        return None

    def provenance(self) -> dict:
        """What a packing records about its distribution (besides the sample's descriptors)."""
        return {"spec": self.spec, "family": self.family}

    # subclass interface
    def _draw(self, n, rng):  # pragma: no cover - abstract
        raise NotImplementedError

    def _raw_moments(self):  # pragma: no cover - abstract
        raise NotImplementedError

    def _bounds(self):  # pragma: no cover - abstract
        raise NotImplementedError

    def _support(self, points):  # pragma: no cover - abstract
        raise NotImplementedError


@dataclass(frozen=True)
class LogNormal(SizeDistribution):
    """Log-normal D with <D> = 1 and relative std sigma: s^2 = ln(1 + sigma^2) = var(ln D), mu = -s^2/2.

    The paper's sigma read as the std of D itself (the project's convention, docs/algorithms.md). delta = sigma,
    S = 3 sigma + sigma^3, M_k = (1 + sigma^2)^(k(k-1)/2)."""

    sigma: float = 0.0
    family = "lognormal"

    def _draw(self, n, rng):
        if self.sigma == 0:
            return np.ones(n)
        s2 = math.log1p(self.sigma * self.sigma)
        # exactly the draw of spherejam <= 0.1 (one rng.lognormal call), so old seeds give the same diameters
        return rng.lognormal(mean=-s2 / 2, sigma=math.sqrt(s2), size=n)

    def _raw_moments(self):
        a = 1.0 + self.sigma**2
        return 1.0, a, a**3

    def _bounds(self):
        return (1.0, 1.0) if self.sigma == 0 else (0.0, math.inf)

    def _support(self, points):
        if self.sigma == 0:
            return np.ones(1), np.ones(1)
        s = math.sqrt(math.log1p(self.sigma**2))
        return np.exp(-s * s / 2 + s * ndtri((np.arange(points) + 0.5) / points)), np.ones(points)


@dataclass(frozen=True)
class Gaussian(SizeDistribution):
    """Normal D with mean 1 and std delta before truncation, **truncated at D > 0** (the normal conditioned on D > 0,
    drawn by inverse transform); the truncated law is then rescaled to mean 1. The truncation removes a fraction
    Phi(-1/delta) of the parent (3e-7 at delta = 0.2, 4e-4 at 0.3), so for delta <= 0.3 the descriptors are the
    parent's to < 0.1 %; they are computed for the truncated law exactly."""

    delta: float = 0.0
    family = "gaussian"

    def _cut(self):
        return float(ndtr(-1.0 / self.delta))  # parent mass below D = 0

    def _quantile(self, u):
        c = self._cut()
        return 1.0 + self.delta * ndtri(c + np.asarray(u) * (1.0 - c))

    def _draw(self, n, rng):
        if self.delta == 0:
            return np.ones(n)
        return self._quantile(rng.random(n))

    def _raw_moments(self):
        if self.delta == 0:
            return 1.0, 1.0, 1.0
        # moments of N(1, delta^2) restricted to D > 0: m_k = m_{k-1} + (k-1) delta^2 m_{k-2} + boundary term (k = 1)
        s = self.delta
        a = -1.0 / s
        z = 1.0 - float(ndtr(a))
        pdf_a = math.exp(-a * a / 2) / math.sqrt(2 * math.pi)
        m1 = 1.0 + s * pdf_a / z
        m2 = m1 + s * s
        m3 = m2 + 2 * s * s * m1
        return m1, m2, m3

    def _bounds(self):
        return (1.0, 1.0) if self.delta == 0 else (0.0, math.inf)

    def _support(self, points):
        if self.delta == 0:
            return np.ones(1), np.ones(1)
        return self._quantile((np.arange(points) + 0.5) / points), np.ones(points)


def _power_moment(a: float, b: float, p: float) -> float:
    """Integral of D^p over [a, b]."""
    if abs(p + 1.0) < 1e-12:
        return math.log(b / a)
    return (b ** (p + 1.0) - a ** (p + 1.0)) / (p + 1.0)


def _power_quantile(a: float, b: float, exponent: float, u):
    """Inverse CDF of the density ~ D^exponent on [a, b]."""
    u = np.asarray(u, dtype=float)
    q = exponent + 1.0
    if abs(q) < 1e-12:
        return a * (b / a) ** u
    return (a**q + u * (b**q - a**q)) ** (1.0 / q)


@dataclass(frozen=True)
class PowerLaw(SizeDistribution):
    """Number density p(D) ~ D^exponent on [1, ratio] (then scaled to mean 1); ``uniform`` is exponent 0."""

    exponent: float = 0.0
    ratio: float = 1.0
    family = "powerlaw"

    def _draw(self, n, rng):
        if self.ratio == 1:
            return np.ones(n)
        return _power_quantile(1.0, self.ratio, self.exponent, rng.random(n))

    def _raw_moments(self):
        if self.ratio == 1:
            return 1.0, 1.0, 1.0
        norm = _power_moment(1.0, self.ratio, self.exponent)
        return tuple(_power_moment(1.0, self.ratio, self.exponent + k) / norm for k in (1, 2, 3))

    def _bounds(self):
        return 1.0, self.ratio

    def _support(self, points):
        if self.ratio == 1:
            return np.ones(1), np.ones(1)
        return _power_quantile(1.0, self.ratio, self.exponent, (np.arange(points) + 0.5) / points), np.ones(points)


@dataclass(frozen=True)
class Uniform(PowerLaw):
    """D uniform on [d_min, ratio d_min]: delta = (ratio - 1)/(sqrt(3)(ratio + 1)), S = 0."""

    family = "uniform"


@dataclass(frozen=True)
class Discrete(SizeDistribution):
    """Spheres of a few exact sizes with number fractions (``bidisperse``, a ``table`` of size classes). A sample of
    N spheres has floor(N x_i) spheres of size i, and the spheres left over go one each to classes drawn by
    systematic sampling over the remainders N x_i - floor(N x_i) with one seeded offset: class i gets floor(N x_i)
    or floor(N x_i) + 1 spheres, N x_i on average, whatever the seed, the number of classes or their order (a
    deterministic rounding gave ties to the smallest classes, the same for every seed). Where every N x_i is whole,
    no random number is used and the mixture is exactly the one asked for. The classes' order in the sample is
    shuffled by the stream."""

    sizes: tuple = ()
    weights: tuple = ()  # number fractions, sum 1
    family = "discrete"

    def _counts(self, n, rng) -> np.ndarray:
        """Spheres of each size in a sample of ``n``: floor(n x_i), plus one for the classes the systematic draw
        over the remainders picks."""
        w = np.asarray(self.weights)
        exact = w * n
        counts = np.floor(exact + 1e-9).astype(int)  # a whole N x_i stays whole through round-off
        if counts.sum() > n:  # only if many classes sit just below a whole count
            counts = np.floor(exact).astype(int)
        rest = int(n - counts.sum())
        if rest > 0:
            edges = np.cumsum(np.clip(exact - counts, 0.0, None))
            edges *= rest / edges[-1]  # the remainders sum to rest; this only removes round-off
            points = rng.random() + np.arange(rest)  # one offset, spacing 1: each remainder < 1 gets at most one
            counts += np.diff(np.searchsorted(points, edges, side="left"), prepend=0)
        return counts

    def _draw(self, n, rng):
        d = np.repeat(np.asarray(self.sizes, dtype=float), self._counts(n, rng))
        return rng.permutation(d)

    def _raw_moments(self):
        d, w = np.asarray(self.sizes, dtype=float), np.asarray(self.weights)
        return tuple(float(np.sum(w * d**k)) for k in (1, 2, 3))

    def _bounds(self):
        present = [d for d, w in zip(self.sizes, self.weights) if w > 0]
        return min(present), max(present)

    def _support(self, points):
        return np.asarray(self.sizes, dtype=float), np.asarray(self.weights)


@dataclass(frozen=True)
class Bidisperse(Discrete):
    """Small spheres (D = 1) and large ones (D = ratio); ``small`` is the small spheres' share by number or by
    volume (``by``); a volume share x_v is a number share x_v / (x_v + (1 - x_v)/ratio^3)."""

    family = "bidisperse"

    def check_n(self, n):
        # a mixture asked for must not become equal spheres for some seeds (a table's rare classes may get none)
        for label, share in zip(("small", "large"), self.weights):
            if math.floor(n * share + 1e-9) == 0:
                raise InputError(f"{self.spec}: at N = {n} the {label} spheres' number share {share:.3g} gives "
                                 f"{n * share:.3g} spheres, so a sample may hold none and be monodisperse; use "
                                 f"N >= {math.ceil(1 / share - 1e-9)}")


@dataclass(frozen=True)
class Binned(SizeDistribution):
    """A measured PSD in bins [lower_i, upper_i] with number fractions n_i (from volume fractions already converted).

    **How a bin is sampled.** Within a bin the weight is spread uniformly in ln D, as the log-spaced bins of laser
    diffraction and sieve series mean it: a volume-weighted bin has number density ~ D^-4 inside it (volume per
    ln D constant), a number-weighted bin ~ D^-1. A sphere first picks its bin with probability n_i, then its size
    by inverse transform inside the bin. Discrete sizes (a ``size`` column without edges) are sampled exactly."""

    lower: tuple = ()
    upper: tuple = ()
    weights: tuple = ()  # number fractions of the bins, sum 1
    exponent: float = -1.0  # number density ~ D^exponent inside a bin: -4 (volume-weighted table) or -1 (number)
    source: dict = field(default_factory=dict, compare=False)
    family = "table"

    def _draw(self, n, rng):
        w = np.asarray(self.weights)
        lo, hi = np.asarray(self.lower), np.asarray(self.upper)
        k = np.minimum(np.searchsorted(np.cumsum(w), rng.random(n) * w.sum(), side="right"), w.size - 1)
        u = rng.random(n)
        return _power_quantile(lo[k], hi[k], self.exponent, u)

    def _bin_moments(self, k):
        out = 0.0
        for a, b, w in zip(self.lower, self.upper, self.weights):
            if w > 0:
                out += w * _power_moment(a, b, self.exponent + k) / _power_moment(a, b, self.exponent)
        return out

    def _raw_moments(self):
        return tuple(self._bin_moments(k) for k in (1, 2, 3))

    def _bounds(self):
        present = [i for i, w in enumerate(self.weights) if w > 0]
        return self.lower[present[0]], self.upper[present[-1]]

    def _support(self, points):
        per = max(points // max(len(self.weights), 1), 4)
        u = (np.arange(per) + 0.5) / per
        d = np.concatenate([_power_quantile(a, b, self.exponent, u) for a, b in zip(self.lower, self.upper)])
        w = np.repeat(np.asarray(self.weights) / per, per)
        return d, w

    def provenance(self):
        return {**super().provenance(), **self.source}


@dataclass(frozen=True)
class Table(Discrete):
    """A measured PSD of discrete size classes (a ``size`` column): each class is sampled at exactly its size."""

    source: dict = field(default_factory=dict, compare=False)
    family = "table"

    def provenance(self):
        return {**super().provenance(), **self.source}


@dataclass(frozen=True)
class DiameterList(SizeDistribution):
    """Exact diameters from a text file, one per line; a sample is the list itself (in file order), scaled to mean 1.
    N is the number of diameters."""

    diameters: tuple = ()
    source: dict = field(default_factory=dict, compare=False)
    family = "list"

    @property
    def fixed_n(self):
        return len(self.diameters)

    def check_n(self, n):
        if n != len(self.diameters):
            raise InputError(f"n={n}: {self.spec} holds {len(self.diameters)} diameters (N is taken from the file)")

    def _draw(self, n, rng):
        return np.asarray(self.diameters, dtype=float)

    def _raw_moments(self):
        d = np.asarray(self.diameters, dtype=float)
        return tuple(float(np.mean(d**k)) for k in (1, 2, 3))

    def _bounds(self):
        return min(self.diameters), max(self.diameters)

    def _support(self, points):
        d = np.asarray(self.diameters, dtype=float)
        return d, np.ones(d.size)

    def provenance(self):
        return {**super().provenance(), **self.source}


# --- spec strings --------------------------------------------------------------------------------------------------

#: Parameters of each parametric family: name -> (kind, required). Kinds: "number" or a tuple of allowed words.
_PARAMETERS = {
    "lognormal": {"sigma": "number"},
    "gaussian": {"delta": "number"},
    "uniform": {"ratio": "number"},
    "bidisperse": {"ratio": "number", "small": "number", "by": ("number", "volume")},
    "powerlaw": {"exponent": "number", "ratio": "number"},
}


def lognormal_spec(sigma: float) -> str:
    """The spec of the paper's log-normal with relative std sigma (``--sigma``, config ``sigmas``)."""
    return f"lognormal:sigma={spec_number(sigma)}"


def spec_number(value: float) -> str:
    """A parameter as a spec records it: short (``0.3``, ``10``) where that is the same float, else its repr, so
    that parsing the recorded spec gives the same parameters and hence the same draw."""
    short = f"{float(value):g}"
    return short if float(short) == float(value) else repr(float(value))


def parse(spec: str, field: str = "psd") -> SizeDistribution:
    """The distribution a spec names; ``field`` is what the spec is called where it came from (``--psd``,
    ``distributions.powder``), for the one-line error."""
    if isinstance(spec, SizeDistribution):
        return spec
    if not isinstance(spec, str) or ":" not in spec:
        raise InputError(f"{field}={spec!r}: must be FAMILY:PARAMETERS, e.g. gaussian:delta=0.2 "
                         f"(families: {', '.join(FAMILIES)})")
    family, _, rest = spec.strip().partition(":")
    family = family.strip().lower()
    if family not in FAMILIES:
        raise InputError(f"{field}={spec!r}: unknown family {family!r} (one of {', '.join(FAMILIES)})")
    if family in ("table", "list"):
        path = rest.strip()
        if not path:
            raise InputError(f"{field}={spec!r}: needs a file, e.g. {family}:powder.csv")
        return read_table(path, spec) if family == "table" else read_list(path, spec)
    values = _parameters(family, rest, spec, field)
    where = f"{field}={spec!r}: {family}."
    if family == "lognormal":
        sigma = values["sigma"]
        _check(0 <= sigma <= MAX_SIGMA, where, "sigma", sigma, f"must be in [0, {MAX_SIGMA:g}]")
        return LogNormal(lognormal_spec(sigma), sigma)
    if family == "gaussian":
        delta = values["delta"]
        _check(0 <= delta <= 1, where, "delta", delta, "must be in [0, 1]")
        return Gaussian(f"gaussian:delta={spec_number(delta)}", delta)
    ratio = values["ratio"]
    _check(1 <= ratio <= MAX_RATIO, where, "ratio", ratio, f"must be in [1, {MAX_RATIO:g}] (d_max/d_min)")
    if family == "uniform":
        return Uniform(f"uniform:ratio={spec_number(ratio)}", 0.0, ratio)
    if family == "powerlaw":
        exponent = values["exponent"]
        _check(-20 <= exponent <= 20, where, "exponent", exponent, "must be in [-20, 20]")
        return PowerLaw(f"powerlaw:exponent={spec_number(exponent)},ratio={spec_number(ratio)}", exponent, ratio)
    small, by = values["small"], values["by"]
    _check(0 < small < 1, where, "small", small, "must be in (0, 1), the small spheres' share")
    x_n = small if by == "number" else small / (small + (1 - small) / ratio**3)
    return Bidisperse(f"bidisperse:ratio={spec_number(ratio)},small={spec_number(small)},by={by}", (1.0, ratio),
                      (x_n, 1.0 - x_n))


def _check(ok: bool, where: str, name: str, value, rule: str) -> None:
    if not ok:
        raise InputError(f"{where}{name}={value!r}: {rule}")


def _parameters(family: str, text: str, spec: str, field: str) -> dict:
    allowed = _PARAMETERS[family]
    usage = f"{family}:" + ",".join(f"{k}=..." for k in allowed)
    values: dict = {}
    for item in filter(None, (p.strip() for p in text.split(","))):
        key, eq, value = item.partition("=")
        key, value = key.strip().lower(), value.strip()
        if not eq or not value:
            raise InputError(f"{field}={spec!r}: {item!r} must be NAME=VALUE ({usage})")
        if key not in allowed:
            raise InputError(f"{field}={spec!r}: unknown parameter {key!r} ({usage})")
        if key in values:
            raise InputError(f"{field}={spec!r}: parameter {key!r} given twice")
        kind = allowed[key]
        if kind == "number":
            try:
                number = float(value)
            except ValueError:
                number = math.nan
            if not math.isfinite(number):
                raise InputError(f"{field}={spec!r}: {family}.{key}={value!r}: must be a finite number")
            values[key] = number
        else:
            if value.lower() not in kind:
                raise InputError(f"{field}={spec!r}: {family}.{key}={value!r}: must be one of {', '.join(kind)}")
            values[key] = value.lower()
    for key in allowed:
        if key not in values:
            raise InputError(f"{field}={spec!r}: {family}.{key} missing ({usage})")
    return values


# --- files ---------------------------------------------------------------------------------------------------------


def _file_source(path: Path) -> dict:
    data = path.read_bytes()
    return {"file": str(path), "sha256": hashlib.sha256(data).hexdigest()}


#: Largest ratio of the largest to the smallest size in a table or list file. Sizes are in any unit and are used
#: relative to the file's largest, so 1e-200 um or 1e300 nm work alike. A wider span makes no packing: its box is
#: several d_max wide, so the smallest spheres would be points, and D^3 of a span of 1e100 leaves double precision.
MAX_FILE_RATIO = 1e6


def _open(path: str, spec: str) -> tuple[Path, list[str]]:
    p = Path(path)
    if not p.exists():
        raise InputError(f"{spec}: file {path!r} not found")
    try:
        regular_file(p, "PSD file", error=InputError)
        # utf-8-sig: Excel's "CSV UTF-8" starts with a byte-order mark, which would stick to the first header
        text = p.read_bytes().decode("utf-8-sig")
    except InputError as exc:
        raise InputError(f"{spec}: {exc}") from None
    except OSError as exc:
        raise InputError(f"{spec}: cannot read {path!r} ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{spec}: {path!r} is not UTF-8 text (byte {exc.start}); save it as CSV UTF-8") from None
    return p, text.splitlines()


def _relative(values: np.ndarray, lines: list[int], spec: str, name: str) -> tuple[np.ndarray, float]:
    """``values`` (sizes > 0, in the file's unit) divided by the largest, and that largest; a span wider than
    :data:`MAX_FILE_RATIO` is refused, naming the line of the smallest."""
    largest = float(np.max(values))
    k = int(np.argmin(values))
    if largest / values[k] > MAX_FILE_RATIO:
        raise InputError(f"{spec} line {lines[k]}: {name}={values[k]:g}: the sizes span a ratio of "
                         f"{largest / values[k]:.3g} (largest {largest:g}); at most {MAX_FILE_RATIO:g}")
    return values / largest, largest


def _number(text: str, where: str, decimal_comma: bool = False) -> float:
    if decimal_comma:
        text = text.replace(",", ".")
    try:
        x = float(text)
    except ValueError:
        raise InputError(f"{where}={text.strip()!r}: must be a number") from None
    if not math.isfinite(x):
        raise InputError(f"{where}={text.strip()!r}: must be a finite number")
    return x


def read_list(path: str, spec: str | None = None) -> DiameterList:
    """``list:FILE``: one diameter per line; blank lines and ``#`` comments are skipped."""
    spec = spec or f"list:{path}"
    p, lines = _open(path, spec)
    diameters, lines_no = [], []
    for i, line in enumerate(lines, 1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        d = _number(text, f"{spec} line {i}: diameter")
        if d <= 0:
            raise InputError(f"{spec} line {i}: diameter={text!r}: must be > 0")
        diameters.append(d)
        lines_no.append(i)
    if len(diameters) < 2:
        raise InputError(f"{spec}: {len(diameters)} diameters: a packing needs at least 2")
    relative, largest = _relative(np.array(diameters), lines_no, spec, "diameter")
    return DiameterList(spec, tuple(map(float, relative)), {**_file_source(p), "largest_size": largest})


#: Column separators a table may use: a comma (then a decimal point), or, as spreadsheets in many locales write them,
#: a semicolon or a tab (then a decimal comma is read too).
_SEPARATORS = {",": "commas", ";": "semicolons", "\t": "tabs"}


def _delimiter(lines: list[str]) -> str:
    """The separator of a table: the one its header line (the first line that is not blank or a comment) holds, a
    tab before a semicolon before a comma."""
    header = next((ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")), "")
    return next((d for d in ("\t", ";") if d in header), ",")


#: Fraction columns a table may have: header name -> (weighting, cumulative).
_FRACTION_COLUMNS = {"number": ("number", False), "volume": ("volume", False), "mass": ("volume", False),
                     "cumulative_number": ("number", True), "cumulative_volume": ("volume", True),
                     "cumulative_mass": ("volume", True), "q0": ("number", True), "q3": ("volume", True)}


def _column_name(header: str) -> tuple[str, bool]:
    """A header cell's name without units (``size (um)`` -> ``size``) and whether it is in percent."""
    percent = "%" in header or "percent" in header.lower()
    name = re.sub(r"[\(\[].*?[\)\]]", "", header).replace("%", "").lower().strip()
    name = re.sub(r"\bpercent\b", "", name).strip()
    return re.sub(r"[\s\-]+", "_", name).strip("_"), percent


def read_table(path: str, spec: str | None = None) -> SizeDistribution:
    """``table:FILE``: a measured PSD as a CSV with a header row (docs/psd.md):

    * sizes: a ``size`` column (size classes, or with a cumulative column the sizes at which it is given), or
      ``lower`` and ``upper`` columns (bin edges); any unit, in parentheses (``size (um)``);
    * one fraction column: ``number`` or ``volume`` (``mass``) per class/bin, or ``cumulative_number`` /
      ``cumulative_volume`` (``Q0``/``Q3``), the share finer than each size; fractions of 1, or percent when the
      header says so (``volume %``, ``Q3 (%)``).

    A cumulative column defines bins between consecutive sizes; it must rise from 0 to 1 (100 %). Per-bin columns
    must sum to 1 (100 %) within 0.5 % and are renormalised. Volume fractions become number fractions by dividing by
    the mean D^3 of the bin (:class:`Binned`) or by D^3 of the class."""
    spec = spec or f"table:{path}"
    p, lines = _open(path, spec)
    delimiter = _delimiter(lines)
    rows = [(i, r) for i, r in enumerate(csv.reader(lines, delimiter=delimiter), 1)
            if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not rows:
        raise InputError(f"{spec}: empty file (needs a header row and data rows)")
    header_line, header = rows[0]
    names = [_column_name(h) for h in header]
    index = {name: k for k, (name, _) in enumerate(names)}
    fractions = [n for n, _ in names if n in _FRACTION_COLUMNS]
    has_bins = "lower" in index and "upper" in index
    if len(fractions) != 1 or not (has_bins or "size" in index):
        raise InputError(f"{spec} line {header_line}: header={delimiter.join(header)!r} (separated by "
                         f"{_SEPARATORS[delimiter]}): needs a size column (size, or lower and upper) and one fraction "
                         f"column ({', '.join(_FRACTION_COLUMNS)})")
    frac_name = fractions[0]
    weighting, cumulative = _FRACTION_COLUMNS[frac_name]
    scale = 100.0 if names[index[frac_name]][1] else 1.0
    data = rows[1:]
    if not data:
        raise InputError(f"{spec}: no data rows below the header")

    def column(name):
        k = index[name]
        out = []
        for i, r in data:
            if k >= len(r):
                raise InputError(f"{spec} line {i}: {name} missing")
            out.append(_number(r[k], f"{spec} line {i}: {name}", decimal_comma=delimiter != ","))
        return np.array(out)

    lines_no = [i for i, _ in data]
    frac = column(frac_name) / scale
    for i, x in zip(lines_no, frac):
        if x < 0:
            raise InputError(f"{spec} line {i}: {frac_name}={x * scale:g}: must be >= 0")
    if has_bins:
        lo, hi = column("lower"), column("upper")
        edges_ok = [(i, a, b) for i, a, b in zip(lines_no, lo, hi)]
        for i, a, b in edges_ok:
            if a <= 0:
                raise InputError(f"{spec} line {i}: lower={a:g}: must be > 0")
            if b <= a:
                raise InputError(f"{spec} line {i}: upper={b:g}: must be > lower ({a:g})")
        order = np.argsort(lo, kind="stable")
        lo, hi, frac, lines_no = lo[order], hi[order], frac[order], [lines_no[k] for k in order]
        for k in range(1, lo.size):
            if lo[k] < hi[k - 1] * (1 - 1e-12):
                raise InputError(f"{spec} line {lines_no[k]}: lower={lo[k]:g}: bins overlap (previous upper "
                                 f"{hi[k - 1]:g})")
        if cumulative:
            raise InputError(f"{spec}: column {frac_name} is cumulative: give it with a size column, not bins")
        largest = float(hi.max())
        _relative(np.append(lo, largest), [*lines_no, lines_no[int(np.argmax(hi))]], spec, "lower")
        lo, hi = lo / largest, hi / largest
    else:
        size = column("size")
        for i, d in zip(lines_no, size):
            if d <= 0:
                raise InputError(f"{spec} line {i}: size={d:g}: must be > 0")
        descending = size.size > 1 and size[1] < size[0]  # sieve tables list the coarsest first
        for k in range(1, size.size):
            if (size[k] >= size[k - 1]) if descending else (size[k] <= size[k - 1]):
                raise InputError(f"{spec} line {lines_no[k]}: size={size[k]:g}: sizes must increase or decrease "
                                 f"throughout (previous {size[k - 1]:g})")
        if descending:  # read upwards
            size, frac, lines_no = size[::-1], frac[::-1], lines_no[::-1]
        size, largest = _relative(size, lines_no, spec, "size")
        if cumulative:
            if size.size < 2:
                raise InputError(f"{spec}: a cumulative column needs at least 2 sizes")
            for k in range(1, frac.size):
                if frac[k] < frac[k - 1]:
                    raise InputError(f"{spec} line {lines_no[k]}: {frac_name}={frac[k] * scale:g}: a cumulative "
                                     f"fraction must not decrease (previous {frac[k - 1] * scale:g})")
            if frac[0] > SUM_TOLERANCE:
                raise InputError(f"{spec} line {lines_no[0]}: {frac_name}={frac[0] * scale:g}: must start at 0 "
                                 "(nothing finer than the smallest size)")
            if abs(frac[-1] - 1) > SUM_TOLERANCE:
                raise InputError(f"{spec} line {lines_no[-1]}: {frac_name}={frac[-1] * scale:g}: must end at "
                                 f"{scale:g}")
            lo, hi, frac = size[:-1], size[1:], np.diff(frac)
            has_bins = True
    total = frac.sum()
    if not cumulative and abs(total - 1) > SUM_TOLERANCE:
        raise InputError(f"{spec}: {frac_name} sums to {total * scale:g}: must sum to {scale:g}")
    if total <= 0:
        raise InputError(f"{spec}: {frac_name} is all zero")
    frac = frac / total
    source = {**_file_source(p), "weighting": weighting, "cumulative": cumulative,
              "bins": "edges" if has_bins else "sizes", "largest_size": largest}
    if has_bins:
        exponent = -4.0 if weighting == "volume" else -1.0
        if weighting == "volume":  # number share = volume share / mean D^3 of the bin (volume uniform in ln D)
            per_volume = np.array([_power_moment(a, b, exponent) / _power_moment(a, b, exponent + 3)
                                   for a, b in zip(lo, hi)])
            frac = frac * per_volume
            frac = frac / frac.sum()
        return Binned(spec, tuple(map(float, lo)), tuple(map(float, hi)), tuple(map(float, frac)), exponent, source)
    if weighting == "volume":
        frac = frac / size**3
        frac = frac / frac.sum()
    keep = frac > 0
    return Table(spec, tuple(map(float, size[keep])), tuple(map(float, frac[keep])), source)
