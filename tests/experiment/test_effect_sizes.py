"""Effect sizes against independent computations: SciPy's Friedman and Wilcoxon statistics,
a slow non-vectorised bootstrap, and seeded reproducibility."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from chameleons.experiment.stats import analyze, render_text
from chameleons.experiment.stats.effect_sizes import (
    BootstrapOptions,
    effect_sizes,
    kendall_w_batch,
    rank_biserial_batch,
)
from tests.experiment.r_wilcox import r_wilcox_paired
from tests.experiment.test_analysis import score_rows

CONDITIONS = ["natural", "copy", "still"]


def scipy_kendall_w(data: np.ndarray) -> float:
    """W = chi2 / (n (k - 1)) with SciPy's tie-corrected Friedman chi2."""
    n, k = data.shape
    if (data == data[:, :1]).all():
        return 0.0
    chi2 = stats.friedmanchisquare(*data.T).statistic
    return float(chi2 / (n * (k - 1)))


def scipy_rank_biserial(d: np.ndarray) -> float:
    """Kerby's r from SciPy's Wilcoxon T+ (zero differences dropped, 'wilcox')."""
    nonzero = d[d != 0]
    total = len(nonzero) * (len(nonzero) + 1) / 2
    t_plus = stats.wilcoxon(nonzero, alternative="greater", method="approx").statistic
    return float((t_plus - (total - t_plus)) / total)


@pytest.mark.parametrize("seed", range(40))
def test_kendall_w_matches_scipy_on_tied_counts(seed: int) -> None:
    rng = np.random.default_rng(seed)
    k = int(rng.integers(3, 6))  # SciPy's Friedman needs three or more conditions
    data = rng.integers(0, 4, size=(int(rng.integers(3, 30)), k)).astype(float)
    assert kendall_w_batch(data[None])[0] == pytest.approx(scipy_kendall_w(data), abs=1e-12)


@pytest.mark.parametrize("seed", range(40))
def test_rank_biserial_matches_scipy_wilcoxon(seed: int) -> None:
    rng = np.random.default_rng(seed)
    d = rng.integers(-3, 4, size=int(rng.integers(3, 40))).astype(float)
    if not d.any():
        d[0] = 1.0
    assert rank_biserial_batch(d[None])[0] == pytest.approx(scipy_rank_biserial(d), abs=1e-12)


def test_rank_biserial_extremes() -> None:
    assert rank_biserial_batch(np.array([[1.0, 2.0, 3.0]]))[0] == 1.0
    assert rank_biserial_batch(np.array([[-1.0, -2.0, 0.0]]))[0] == -1.0
    assert rank_biserial_batch(np.zeros((1, 5)))[0] == 0.0


def kerby_from_r_v(x: list[float], y: list[float]) -> float:
    """r from the V of the independent R reference: 2 V / (n (n + 1) / 2) - 1, n = the
    non-zero differences (the ones V ranks)."""
    v, _, _ = r_wilcox_paired(x, y)
    assert v is not None
    n = sum(1 for a, b in zip(x, y, strict=True) if a - b != 0)
    return 2 * v / (n * (n + 1) / 2) - 1


def test_rank_biserial_comes_from_the_same_differences_as_v() -> None:
    """Questionnaire means are fractions of twelve: 53/12 - 49/12 and 16/3 - 5 are both a
    third, but not the same double (0.3333333333333339 vs 0.33333333333333304), and R's
    wilcox.test ranks them apart. r must use V's ranks: here V = 6 of 10, so r = 0.2 (a
    rounded tie would give 0.1, disagreeing with the V reported beside it)."""
    x, y = [53 / 12, 5.0, 2.0, 6.0], [49 / 12, 16 / 3, 3.0, 4.5]
    pair = effect_sizes(np.array([x, y]).T.tolist(), ["a", "b"], BootstrapOptions(200)).pairs[0]
    assert pair.rank_biserial.estimate == pytest.approx(kerby_from_r_v(x, y), abs=1e-12)
    assert pair.rank_biserial.estimate == pytest.approx(0.2, abs=1e-12)
    # The bootstrap's statistic ranks the same way: on the full sample it gives r too.
    assert rank_biserial_batch((np.array(x) - np.array(y))[None])[0] == pytest.approx(0.2)


@pytest.mark.parametrize("seed", range(30))
def test_rank_biserial_equals_v_on_questionnaire_means_and_counts(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 25))
    if seed % 2:  # means of 12 items on 1..7, as exported
        x, y = (list(rng.integers(12, 85, n) / 12) for _ in range(2))
    else:  # accepted counts, many ties and zeros
        x, y = (list(rng.integers(0, 4, n).astype(float)) for _ in range(2))
    effects = effect_sizes(np.array([x, y]).T.tolist(), ["a", "b"], BootstrapOptions(100))
    pair = effects.pairs[0]
    nonzero = sum(1 for a, b in zip(x, y, strict=True) if a - b != 0)
    assert pair.n_nonzero == nonzero
    if nonzero == 0:
        assert pair.rank_biserial.estimate is None
    else:
        assert pair.rank_biserial.estimate == pytest.approx(kerby_from_r_v(x, y), abs=1e-12)


def test_zero_width_intervals_are_flagged() -> None:
    """Accepted counts where nearly every participant's difference is 0: every resample's
    median difference is 0, a [0, 0] interval that says nothing about precision."""
    blocks = [[1.0, 1.0, 2.0]] * 11 + [[2.0, 1.0, 0.0]]
    effects = effect_sizes(blocks, CONDITIONS, BootstrapOptions(500))
    natural_copy = effects.pairs[0].median_difference
    assert (natural_copy.estimate, natural_copy.ci_low, natural_copy.ci_high) == (0.0, 0.0, 0.0)
    assert natural_copy.degenerate
    assert "zero-width" in natural_copy.note
    copy_still = effects.pairs[2].median_difference
    assert (copy_still.ci_low, copy_still.ci_high) == (-1.0, -1.0)
    assert copy_still.degenerate
    w = effects.kendall_w  # the participants do not agree: W's interval has width
    assert w.ci_low is not None
    assert w.ci_high is not None
    assert w.ci_low < w.ci_high
    assert not w.degenerate
    rows = [
        {"participant": str(p), "condition": c, "accepted": int(v)}
        for p, block in enumerate(blocks)
        for c, v in zip(CONDITIONS, block, strict=True)
    ]
    text = render_text(analyze(rows, measures=["accepted"], bootstrap=BootstrapOptions(500)))
    assert "0.00 [0.00, 0.00] (zero-width interval: not a measure of precision)" in text


def test_bootstrap_interval_equals_a_slow_independent_bootstrap() -> None:
    """Same generator, same resampled participants: SciPy's non-vectorised bootstrap of
    SciPy's Friedman-based W gives the interval the vectorised statistic gives."""
    rows = score_rows(seed=3)
    data = np.array([[r["likeability"] for r in rows if r["condition"] == c] for c in CONDITIONS]).T
    options = BootstrapOptions(resamples=300, seed=11)
    ours = effect_sizes(data.tolist(), CONDITIONS, options, key="likeability")
    import zlib

    rng = np.random.default_rng([11, zlib.crc32(b"likeability:W")])
    slow = stats.bootstrap(
        tuple(data.T),
        lambda *columns: scipy_kendall_w(np.column_stack(columns)),
        n_resamples=300,
        paired=True,
        vectorized=False,
        method="percentile",
        rng=rng,
    )
    assert ours.kendall_w.ci_low == pytest.approx(slow.confidence_interval.low, abs=1e-12)
    assert ours.kendall_w.ci_high == pytest.approx(slow.confidence_interval.high, abs=1e-12)
    assert ours.kendall_w.estimate == pytest.approx(scipy_kendall_w(data))


def test_same_seed_same_intervals_other_seed_other_intervals() -> None:
    rows = score_rows(seed=5, trust_shift=1.0)
    first = analyze(rows, bootstrap=BootstrapOptions(500, seed=1)).to_dict()
    again = analyze(rows, bootstrap=BootstrapOptions(500, seed=1)).to_dict()
    other = analyze(rows, bootstrap=BootstrapOptions(500, seed=2)).to_dict()
    assert first == again
    trust, trust_other = (
        d["measures"]["trust"]["effect_sizes"]["pairs"][0]["rank_biserial"] for d in (first, other)
    )
    assert trust["estimate"] == trust_other["estimate"]
    assert (trust["ci_low"], trust["ci_high"]) != (trust_other["ci_low"], trust_other["ci_high"])
    # A measure's intervals do not depend on which other measures were analysed.
    alone = analyze(rows, measures=["trust"], bootstrap=BootstrapOptions(500, seed=1)).to_dict()
    assert alone["measures"]["trust"]["effect_sizes"] == first["measures"]["trust"]["effect_sizes"]


def test_a_clear_effect_has_an_interval_away_from_zero() -> None:
    rows = score_rows(seed=1, trust_shift=2.0)  # copy's trust clearly above natural's
    effects = analyze(rows, bootstrap=BootstrapOptions(1000, seed=0)).measures["trust"]
    assert effects.effect_sizes is not None
    pair = next(p for p in effects.effect_sizes.pairs if (p.a, p.b) == ("natural", "copy"))
    assert pair.rank_biserial.estimate == -1.0
    assert pair.rank_biserial.ci_high is not None
    assert pair.rank_biserial.ci_high < 0
    assert pair.median_difference.ci_high is not None
    assert pair.median_difference.ci_high < 0
    w = effects.effect_sizes.kendall_w
    assert w.ci_low is not None
    assert w.ci_high is not None
    assert 0 < w.ci_low <= w.ci_high <= 1


def test_degenerate_data_is_undefined_not_zero() -> None:
    tied = [[2.0, 2.0, 2.0]] * 6
    effects = effect_sizes(tied, CONDITIONS, BootstrapOptions(200))
    assert effects.kendall_w.estimate is None
    assert "tied" in effects.kendall_w.note
    pair = effects.pairs[0]
    assert pair.rank_biserial.estimate is None
    assert pair.n_nonzero == 0
    assert (pair.median_difference.estimate, pair.median_difference.ci_low) == (0.0, 0.0)
    single = effect_sizes([[1.0, 2.0, 3.0]], CONDITIONS, BootstrapOptions(200))
    assert single.kendall_w.estimate is None


def test_json_has_effect_sizes_per_measure_and_no_nan() -> None:
    import json

    data = analyze(score_rows(), bootstrap=BootstrapOptions(200)).to_dict()
    text = json.dumps(data, allow_nan=False)  # raises on NaN or infinity
    for measure in ("accepted", "credibility", "likeability", "trust"):
        effects = json.loads(text)["measures"][measure]["effect_sizes"]
        assert effects["resamples"] == 200
        assert {(p["a"], p["b"]) for p in effects["pairs"]} == {
            ("natural", "copy"),
            ("natural", "still"),
            ("copy", "still"),
        }
    assert analyze(score_rows()).to_dict()["measures"]["trust"]["effect_sizes"] is None
