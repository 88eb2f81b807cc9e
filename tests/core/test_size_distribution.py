"""Size distributions: descriptors against closed forms, seeded draws, table sampling, bad specs, the models."""

import math

import numpy as np
import pytest
from scipy import integrate, stats

from spherejam import InputError
from spherejam.analysis.farr_groot import farr2013_lognormal, phi_rcp_bidisperse, phi_rcp_distribution, phi_rcp_points
from spherejam.analysis.psd_models import desmond_weeks, predictions, santos
from spherejam.core.seeding import poisson_packing, rng_for
from spherejam.core.size_distribution import parse, read_table, sample_descriptors


def _desc(spec):
    return parse(spec).descriptors()


@pytest.mark.parametrize("sigma", [0.0, 0.1, 0.3])
def test_lognormal_descriptors_closed_form(sigma):
    d = _desc(f"lognormal:sigma={sigma}")
    assert d.delta == pytest.approx(sigma, abs=1e-12)
    assert d.skewness == pytest.approx(3 * sigma + sigma**3, abs=1e-9)
    assert (d.m1, d.m2, d.m3) == pytest.approx((1, 1 + sigma**2, (1 + sigma**2) ** 3))


@pytest.mark.parametrize("delta", [0.1, 0.2, 0.5])
def test_gaussian_truncated_at_zero_matches_scipy(delta):
    d = _desc(f"gaussian:delta={delta}")
    mean, var, skew = stats.truncnorm(-1 / delta, np.inf, loc=1, scale=delta).stats(moments="mvs")
    assert d.delta == pytest.approx(math.sqrt(var) / mean, rel=1e-9)
    assert d.skewness == pytest.approx(float(skew), abs=1e-7)


@pytest.mark.parametrize("ratio", [1.0, 2.0, 10.0])
def test_uniform_closed_form(ratio):
    d = _desc(f"uniform:ratio={ratio}")
    assert d.delta == pytest.approx((ratio - 1) / (math.sqrt(3) * (ratio + 1)), abs=1e-12)
    assert d.skewness == pytest.approx(0, abs=1e-9)
    assert d.size_ratio == ratio


@pytest.mark.parametrize("ratio, small, by", [(1.4, 0.5, "number"), (2, 0.3, "volume"), (4, 0.3, "volume")])
def test_bidisperse_closed_form(ratio, small, by):
    d = _desc(f"bidisperse:ratio={ratio},small={small},by={by}")
    x = small if by == "number" else (small / 1) / (small / 1 + (1 - small) / ratio**3)  # number share of small
    mean = x + (1 - x) * ratio
    assert d.delta == pytest.approx(math.sqrt(x * (1 - x)) * (ratio - 1) / mean, rel=1e-12)
    assert d.skewness == pytest.approx((2 * x - 1) / math.sqrt(x * (1 - x)), abs=1e-9)
    assert d.size_ratio == pytest.approx(ratio)


@pytest.mark.parametrize("exponent, ratio", [(-3, 10), (-1, 5), (0, 3), (2.5, 2)])
def test_powerlaw_moments_by_quadrature(exponent, ratio):
    d = _desc(f"powerlaw:exponent={exponent},ratio={ratio}")
    norm = integrate.quad(lambda x: x**exponent, 1, ratio)[0]
    m = [integrate.quad(lambda x, k=k: x ** (exponent + k), 1, ratio)[0] / norm for k in (1, 2, 3)]
    assert d.m2 == pytest.approx(m[1] / m[0] ** 2, rel=1e-9)
    assert d.m3 == pytest.approx(m[2] / m[0] ** 3, rel=1e-9)
    assert d.z == pytest.approx(d.m2**2 / d.m3, rel=1e-12)


@pytest.mark.parametrize("spec", ["lognormal:sigma=0.2", "gaussian:delta=0.2", "uniform:ratio=2",
                                  "bidisperse:ratio=4,small=0.3,by=volume", "powerlaw:exponent=-3,ratio=10"])
def test_large_sample_has_population_descriptors(spec):
    dist = parse(spec)
    x = dist.draw(400_000, rng_for(3))
    assert x.mean() == pytest.approx(1.0, abs=1e-12)
    s, p = sample_descriptors(x), dist.descriptors()
    assert s.delta == pytest.approx(p.delta, rel=0.01)
    assert s.skewness == pytest.approx(p.skewness, abs=0.03 + 0.02 * abs(p.skewness))
    assert s.m3 == pytest.approx(p.m3, rel=0.01)


def test_bidisperse_sample_has_exact_composition():
    x = parse("bidisperse:ratio=1.4,small=0.5,by=number").draw(101, rng_for(0), normalise=False)
    assert sorted(np.unique(x)) == [1.0, 1.4] and np.sum(x == 1.0) in (50, 51)
    x = parse("bidisperse:ratio=2,small=0.3,by=volume").draw(1000, rng_for(0), normalise=False)
    vol_small = np.sum(x[x == 1.0] ** 3) / np.sum(x**3)
    assert vol_small == pytest.approx(0.3, abs=0.002)


def test_bidisperse_refuses_a_sample_without_one_of_its_sizes():
    """1:10 with 30 % small spheres by volume has 0.23 % large spheres by number: 0.47 at N = 200, where a sample
    could be equal spheres. The error says from which N both sizes are present in every sample."""
    dist = parse("bidisperse:ratio=10,small=0.3,by=volume")
    with pytest.raises(InputError, match=r"at N = 200 the large spheres' number share 0.00233 gives 0.466 spheres.*"
                                         r"use N >= 430"):
        dist.draw(200, rng_for(0))
    for seed in range(20):
        assert np.sum(dist.draw(430, rng_for(seed), normalise=False) == 10.0) >= 1
    with pytest.raises(InputError, match="the small spheres' number share"):
        parse("bidisperse:ratio=2,small=0.001,by=number").draw(100, rng_for(0))


def test_lognormal_spec_is_the_sigma_path_bitwise():
    for sigma in (0.0, 0.1, 0.3):
        a = poisson_packing(200, sigma, seed=5)
        b = poisson_packing(200, seed=5, psd=f"lognormal:sigma={sigma}")
        np.testing.assert_array_equal(a.positions, b.positions)
        np.testing.assert_array_equal(a.diameters, b.diameters)
        assert a.metadata["parameters"]["sigma"] == sigma
        sample = a.metadata["size_distribution"]["sample"]
        assert sample["delta"] == pytest.approx(a.polydispersity, abs=1e-12)


def test_lognormal_draw_is_spherejam_01():
    """The diameters of spherejam 0.1 for seed 7, sigma 0.3 (one rng.lognormal call, then / mean)."""
    rng = np.random.default_rng(np.random.SeedSequence(7))
    s2 = math.log1p(0.09)
    old = rng.lognormal(mean=-s2 / 2, sigma=math.sqrt(s2), size=50)
    np.testing.assert_array_equal(parse("lognormal:sigma=0.3").draw(50, rng_for(7)), old / old.mean())


def _volume_table(tmp_path, cumulative=False):
    edges = np.geomspace(5.0, 80.0, 25)  # um, log-spaced like a laser-diffraction export
    mid = np.sqrt(edges[1:] * edges[:-1])
    q3 = np.exp(-0.5 * (np.log(mid / 25.0) / 0.4) ** 2)
    q3 /= q3.sum()
    path = tmp_path / ("cum.csv" if cumulative else "bins.csv")
    if cumulative:
        cum = np.concatenate([[0.0], np.cumsum(q3)]) * 100
        cum[-1] = 100.0
        rows = ["size (um),Q3 (%)"] + [f"{e:.6g},{c:.8f}" for e, c in zip(edges, cum)]
    else:
        rows = ["lower (um),upper (um),volume"] + [f"{a:.6g},{b:.6g},{w:.10f}" for a, b, w in zip(edges, edges[1:], q3)]
    path.write_text("\n".join(rows) + "\n")
    return path, edges, q3


def test_table_sample_reproduces_volume_histogram(tmp_path):
    path, edges, q3 = _volume_table(tmp_path)
    dist = parse(f"table:{path}")
    n = 400_000
    d = dist.draw(n, rng_for(11), normalise=False)
    v = d**3
    which = np.clip(np.searchsorted(edges, d, side="right") - 1, 0, q3.size - 1)
    share = np.bincount(which, weights=v, minlength=q3.size) / v.sum()
    # standard error of a ratio estimator: var(v 1_bin - w v) / (n mean(v)^2)
    se = np.array([np.std(v * (which == i) - share[i] * v) for i in range(q3.size)]) / (math.sqrt(n) * v.mean())
    z = (share - q3) / np.maximum(se, 1e-12)
    assert np.all(np.abs(z) < 5), z
    assert np.sum(z**2) < q3.size + 5 * math.sqrt(2 * q3.size)  # chi-square-like total
    assert dist.provenance()["weighting"] == "volume"


def test_cumulative_table_equals_per_bin_table(tmp_path):
    a = parse(f"table:{_volume_table(tmp_path)[0]}")
    b = parse(f"table:{_volume_table(tmp_path, cumulative=True)[0]}")
    assert a.descriptors().delta == pytest.approx(b.descriptors().delta, rel=1e-6)
    assert a.descriptors().skewness == pytest.approx(b.descriptors().skewness, rel=1e-5)


def test_table_of_size_classes_by_volume(tmp_path):
    p = tmp_path / "classes.csv"
    p.write_text("size,volume %\n1,30\n2,70\n")
    dist = read_table(str(p))
    x = dist.draw(20_000, rng_for(1), normalise=False)
    assert np.sum(x[x == 1] ** 3) / np.sum(x**3) == pytest.approx(0.3, abs=0.002)
    assert dist.descriptors().delta == pytest.approx(_desc("bidisperse:ratio=2,small=0.3,by=volume").delta)


def test_list_sets_n_and_keeps_order(tmp_path):
    p = tmp_path / "d.txt"
    p.write_text("# diameters\n1.0\n2.0\n\n1.5\n1.0\n")
    pk = poisson_packing(None, seed=0, psd=f"list:{p}")
    assert pk.n == 4
    np.testing.assert_allclose(pk.nominal_diameters, np.array([1, 2, 1.5, 1]) / 1.375)
    with pytest.raises(InputError, match=r"n=5: list:.* holds 4 diameters"):
        poisson_packing(5, seed=0, psd=f"list:{p}")


BAD_SPECS = [
    ("gausian:delta=0.2", "unknown family 'gausian'"),
    ("gaussian", "must be FAMILY:PARAMETERS"),
    ("gaussian:", "gaussian.delta missing"),
    ("gaussian:delta=nan", "gaussian.delta='nan': must be a finite number"),
    ("gaussian:delta=-0.1", "delta=-0.1: must be in"),
    ("gaussian:delta=0.2,ratio=2", "unknown parameter 'ratio'"),
    ("bidisperse:ratio=2,small=0.3", "bidisperse.by missing"),
    ("bidisperse:ratio=2,small=1.2,by=number", "small=1.2"),
    ("bidisperse:ratio=2,small=0.3,by=mass", "bidisperse.by='mass': must be one of number, volume"),
    ("uniform:ratio=0.5", "ratio=0.5"),
    ("powerlaw:exponent=-3", "powerlaw.ratio missing"),
    ("lognormal:sigma=abc", "lognormal.sigma='abc'"),
    ("lognormal:sigma=2", "sigma=2.0: must be in [0, 1]"),
    ("table:", "needs a file"),
    ("table:/nonexistent/powder.csv", "not found"),
]


@pytest.mark.parametrize("spec, message", BAD_SPECS)
def test_bad_spec_one_line(spec, message):
    with pytest.raises(InputError) as err:
        parse(spec)
    text = str(err.value)
    assert message in text and "\n" not in text


BAD_FILES = [
    ("table", "", "empty file"),
    ("table", "size,volume\n", "no data rows"),
    ("table", "diameter,amount\n1,1\n", "needs a size column"),
    ("table", "size,volume\n1,0.5\n-2,0.5\n", "line 3: size=-2: must be > 0"),
    ("table", "size,volume\n1,0.5\n0,0.5\n", "size=0: must be > 0"),
    ("table", "size,volume\n1,0.5\n2,0.4\n", "volume sums to 0.9: must sum to 1"),
    ("table", "size,volume %\n1,50\n2,40\n", "volume sums to 90: must sum to 100"),
    ("table", "size,volume\n1,nan\n2,1\n", "line 2: volume='nan': must be a finite number"),
    ("table", "size,volume\n1,0.5\n2,abc\n", "line 3: volume='abc': must be a number"),
    ("table", "size,volume\n2,0.3\n1,0.3\n3,0.4\n", "line 4: size=3: sizes must increase or decrease throughout"),
    ("table", "lower,upper,volume\n1,2,0.5\n3,2.5,0.5\n", "line 3: upper=2.5: must be > lower"),
    ("table", "lower,upper,volume\n1,2,0.5\n1.5,3,0.5\n", "lower=1.5: bins overlap"),
    ("table", "size,Q3\n1,0\n2,0.7\n3,0.6\n", "Q3=0.6: a cumulative fraction must not decrease"),
    ("table", "size,Q3\n1,0.1\n2,1\n", "must start at 0"),
    ("table", "size,Q3\n1,0\n2,0.9\n", "q3=0.9: must end at 1"),
    ("table", "size,volume\n1,-0.5\n2,1.5\n", "volume=-0.5: must be >= 0"),
    ("list", "", "0 diameters"),
    ("list", "1.0\n-1\n", "line 2: diameter='-1': must be > 0"),
    ("list", "1.0\nx\n", "line 2: diameter='x': must be a number"),
    ("list", "1.0\ninf\n", "must be a finite number"),
]


@pytest.mark.parametrize("family, content, message", BAD_FILES)
def test_bad_file_one_line(tmp_path, family, content, message):
    p = tmp_path / "f.csv"
    p.write_text(content)
    with pytest.raises(InputError) as err:
        parse(f"{family}:{p}")
    text = str(err.value)
    assert message.lower() in text.lower() and "\n" not in text, text


# --- the models -----------------------------------------------------------------------------------------------------


def test_desmond_weeks_by_hand():
    assert desmond_weeks(0, 0) == 0.634
    assert desmond_weeks(0.2, 0) == pytest.approx(0.634 + 0.01316, abs=1e-12)
    # log-normal sigma = 0.3: S = 0.927; 0.0857 * 0.927 = 0.0794439, * 0.09 = 0.007149951; + 0.634 + 0.01974
    assert desmond_weeks(0.3, 0.927) == pytest.approx(0.660889951, abs=1e-12)


def test_santos_by_hand():
    assert santos(1.0, 0.64) == pytest.approx(0.64)
    assert santos(0.9, 0.64) == pytest.approx(0.64 / 0.964, abs=1e-12)
    # log-normal sigma = 0.3: z = 1/1.09; phi_mono 0.6405 -> 0.6405 / (0.6405 + 0.3595/1.09) = 0.660093
    z = _desc("lognormal:sigma=0.3").z
    assert z == pytest.approx(1 / 1.09)
    assert santos(z, 0.6405) == pytest.approx(0.660093, abs=1e-6)
    with pytest.raises(ValueError):
        santos(1.5, 0.64)


def test_farr_groot_any_distribution():
    # the generic path, fed a log-normal's points, reproduces Farr's 2013 formula (as the log-normal path does)
    s = math.sqrt(math.log1p(0.2**2))
    u = (np.arange(20_000) + 0.5) / 20_000
    d = np.exp(s * stats.norm.ppf(u))
    assert phi_rcp_points(d, np.ones_like(d)) == pytest.approx(float(farr2013_lognormal(s)), abs=1e-3)
    # and a bidisperse spec gives the mixture function's number
    assert phi_rcp_distribution("bidisperse:ratio=2,small=0.3,by=volume") == pytest.approx(
        phi_rcp_bidisperse(2, 0.3), abs=2e-4)
    assert phi_rcp_distribution("uniform:ratio=1") == pytest.approx(0.6435, abs=1e-4)


def test_predictions_flag_their_ranges():
    p = {x.model: x for x in predictions("powerlaw:exponent=-3,ratio=10", phi_mono=0.64)}
    assert not p["desmond_weeks"].in_range  # delta = 0.64 > 0.4
    assert p["santos"].phi == pytest.approx(santos(_desc("powerlaw:exponent=-3,ratio=10").z, 0.64))
    assert "2014" in p["desmond_weeks"].citation


# --- issue 49: unbiased discrete samples, specs that reproduce the draw, files in any unit and layout -------------


def _equal_number_classes(tmp_path, k=1000, ratio=2.1e4):
    sizes = np.geomspace(1.0, ratio, k)
    p = tmp_path / "classes.csv"
    p.write_text("size,number\n" + "".join(f"{float(d)!r},{1 / k!r}\n" for d in sizes))
    return parse(f"table:{p}")


def test_a_table_with_more_classes_than_n_gives_an_unbiased_sample(tmp_path):
    """1000 equal-number classes spanning 2.1e4, N = 200: each sample is a stratified one over the whole range (the
    rounding gave the 200 smallest classes, delta 0.557 and d_max/d_min 7.24 for every seed), the seeds differ, and
    the classes' mean counts over seeds are N x_i."""
    dist = _equal_number_classes(tmp_path)
    pop = dist.descriptors()
    assert pop.delta == pytest.approx(1.99, abs=0.01)
    samples = [dist.draw(200, rng_for(seed)) for seed in range(200)]
    for x in samples[:20]:
        s = sample_descriptors(x)
        assert s.delta == pytest.approx(pop.delta, rel=0.1)
        assert s.size_ratio > 0.9 * pop.size_ratio
    assert not np.array_equal(np.sort(samples[0]), np.sort(samples[1]))
    counts = np.zeros(1000)
    sizes = np.asarray(dist.sizes)  # relative to the largest, as the file's are held
    for seed in range(200):
        relative = dist.draw(200, rng_for(seed), normalise=False) / dist.source["largest_size"]
        counts += np.bincount(np.searchsorted(sizes, relative * (1 - 1e-12)), minlength=1000)
    assert counts.sum() == 200 * 200
    # every class is drawn 200 * 0.2 = 40 times on average: the smallest and largest fifths alike
    assert counts[:200].mean() == pytest.approx(40, rel=0.1) and counts[-200:].mean() == pytest.approx(40, rel=0.1)
    pooled = sample_descriptors(np.concatenate(samples))
    assert pooled.delta == pytest.approx(pop.delta, rel=0.05)


def test_whole_class_counts_are_exact_and_use_no_random_number():
    dist = parse("bidisperse:ratio=2,small=0.5,by=number")
    rng = rng_for(4)
    x = dist.draw(100, rng, normalise=False)
    assert np.sum(x == 1.0) == 50
    fresh = rng_for(4)
    assert np.array_equal(x, fresh.permutation(np.repeat([1.0, 2.0], [50, 50])))


@pytest.mark.parametrize("spec", ["gaussian:delta=0.1234567", "uniform:ratio=2.123456789",
                                  "powerlaw:exponent=-2.7182818,ratio=10.0000001",
                                  "bidisperse:ratio=1.4142135,small=0.3333333,by=volume", "lognormal:sigma=0.1234567"])
def test_the_recorded_spec_reproduces_the_draw(spec):
    dist = parse(spec)
    again = parse(dist.spec)
    assert again == dist
    np.testing.assert_array_equal(dist.draw(300, rng_for(2)), again.draw(300, rng_for(2)))
    recorded = poisson_packing(300, seed=2, psd=spec).metadata["size_distribution"]["spec"]
    np.testing.assert_array_equal(poisson_packing(300, seed=2, psd=recorded).diameters,
                                  poisson_packing(300, seed=2, psd=spec).diameters)
    assert parse("gaussian:delta=0.2").spec == "gaussian:delta=0.2"  # short where short is exact


@pytest.mark.parametrize("family, content, reference", [
    ("table", "size,volume\n1e300,0.5\n2e300,0.5\n", "size,volume\n1,0.5\n2,0.5\n"),
    ("table", "size,volume\n1e-300,0.5\n2e-300,0.5\n", "size,volume\n1,0.5\n2,0.5\n"),
    ("table", "lower,upper,volume\n1e-300,2e-300,0.5\n2e-300,4e-300,0.5\n", "lower,upper,volume\n1,2,0.5\n2,4,0.5\n"),
    ("table", "lower,upper,number\n1e300,2e300,0.5\n2e300,4e300,0.5\n", "lower,upper,number\n1,2,0.5\n2,4,0.5\n"),
    ("list", "1e300\n2e300\n1.5e300\n", "1\n2\n1.5\n"),
    ("list", "1e-310\n2e-310\n", "1\n2\n"),
])
def test_sizes_in_any_unit_give_the_same_distribution(tmp_path, family, content, reference):
    (tmp_path / "a.csv").write_text(content)
    (tmp_path / "b.csv").write_text(reference)
    a, b = parse(f"{family}:{tmp_path / 'a.csv'}"), parse(f"{family}:{tmp_path / 'b.csv'}")
    for x, y in zip(a.descriptors().as_dict().values(), b.descriptors().as_dict().values()):
        assert x == pytest.approx(y, rel=1e-9)
    n = a.fixed_n or 50
    np.testing.assert_allclose(a.draw(n, rng_for(1)), b.draw(n, rng_for(1)), rtol=1e-12)


@pytest.mark.parametrize("family, content, message", [
    ("table", "size,volume\n1e200,0.5\n1e300,0.5\n", "line 2: size=1e+200: the sizes span a ratio of 1e+100"),
    ("table", "lower,upper,volume\n1e-10,1,0.5\n1,2,0.5\n", "lower=1e-10: the sizes span a ratio of 2e+10"),
    ("list", "1\n1e-9\n", "line 2: diameter=1e-09: the sizes span"),
])
def test_a_span_of_sizes_without_a_packing_is_one_line(tmp_path, family, content, message):
    (tmp_path / "f.csv").write_text(content)
    with pytest.raises(InputError) as err:
        parse(f"{family}:{tmp_path / 'f.csv'}")
    assert message in str(err.value) and "\n" not in str(err.value), str(err.value)


@pytest.mark.parametrize("content", [
    "\ufefflower,upper,volume %\n1,2,50\n2,4,50\n",  # Excel's CSV UTF-8
    "lower;upper;volume %\n1;2;50\n2;4;50\n",
    "lower;upper;volume %\n1,0;2,0;50,0\n2,0;4,0;50,0\n",  # decimal commas
    "lower\tupper\tvolume %\n1\t2\t50\n2\t4\t50\n",
    "lower,upper,volume %\n2,4,50\n1,2,50\n",  # coarsest first
])
def test_spreadsheet_and_instrument_layouts_are_read(tmp_path, content):
    (tmp_path / "f.csv").write_bytes(content.encode("utf-8"))
    (tmp_path / "ref.csv").write_text("lower,upper,volume %\n1,2,50\n2,4,50\n")
    got, ref = parse(f"table:{tmp_path / 'f.csv'}").descriptors(), parse(f"table:{tmp_path / 'ref.csv'}").descriptors()
    assert got.as_dict() == pytest.approx(ref.as_dict(), rel=1e-12)


def test_descending_size_classes_and_cumulative_sieve_tables_are_read(tmp_path):
    (tmp_path / "down.csv").write_text("size (um),volume %\n3,20\n2,50\n1,30\n")
    (tmp_path / "up.csv").write_text("size (um),volume %\n1,30\n2,50\n3,20\n")
    assert parse(f"table:{tmp_path / 'down.csv'}").descriptors() == parse(f"table:{tmp_path / 'up.csv'}").descriptors()
    (tmp_path / "sieve.csv").write_text("size;Q3 (%)\n4;100\n2;60,5\n1;0\n")
    (tmp_path / "sieve_up.csv").write_text("size,Q3 (%)\n1,0\n2,60.5\n4,100\n")
    assert parse(f"table:{tmp_path / 'sieve.csv'}").descriptors().as_dict() == pytest.approx(
        parse(f"table:{tmp_path / 'sieve_up.csv'}").descriptors().as_dict(), rel=1e-12)


def test_a_table_with_an_unknown_separator_names_the_one_it_read(tmp_path):
    (tmp_path / "f.csv").write_text("size|volume\n1|0.5\n2|0.5\n")
    with pytest.raises(InputError, match=r"header='size\|volume' \(separated by commas\): needs a size column"):
        parse(f"table:{tmp_path / 'f.csv'}")
