"""Learning-curve statistics as the field reports them: means over seeds with 95 % stratified
bootstrap confidence intervals (rliable, Agarwal et al. 2021), the last-5-epoch mean, the
first epoch a rolling mean reaches a level, and the area under the curve.

Every function takes eval success as a (seeds, epochs) array: one row per seed, one column
per epoch (20 frozen-policy episodes each). Intervals are percentile bootstrap intervals
over seeds with a fixed generator, so a report regenerates bit for bit.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import warnings

import numpy as np

REPS = 2000
"""Bootstrap replications per interval."""
CONFIDENCE = 0.95
LAST = 5
"""Epochs averaged for the final performance."""
WINDOW = 5
"""Epochs of the rolling mean that decides when a level is reached."""


EXTRA = "dev"
"""The install extra that brings rliable and arch, which the interval estimates need."""


def _needs(module: str):
    """`module` imported; ModuleNotFoundError naming the extra that installs it if it is not
    installed (the base install has neither rliable nor arch)."""
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as err:
        raise ModuleNotFoundError(
            f"{err.name} is not installed: the interval estimates need rliable and arch, "
            f"which the {EXTRA} extra installs (pip install -e '.[{EXTRA}]', or make setup)",
            name=err.name,
        ) from None


@contextlib.contextmanager
def _seeded(seed: int):
    """rliable 1.2's StratifiedBootstrap draws its indices from NumPy's global generator
    (np.random.choice) whatever `random_state` says: seed that one, and restore it after,
    so that a report regenerates bit for bit."""
    saved = np.random.get_state()  # noqa: NPY002 - rliable reads the legacy generator
    np.random.seed(seed)  # noqa: NPY002
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # arch's notice about RandomState
            yield
    finally:
        np.random.set_state(saved)  # noqa: NPY002


def _bootstrap(score_dict: dict, func, seed: int) -> tuple[dict, dict]:
    """rliable's stratified bootstrap interval estimates (`REPS`, 95 %), reproducible."""
    rly = _needs("rliable.library")
    with _seeded(seed):
        return rly.get_interval_estimates(
            score_dict,
            func,
            reps=REPS,
            confidence_interval_size=CONFIDENCE,
            random_state=np.random.RandomState(seed),
        )


def performance_profile(
    scores: dict[str, np.ndarray], taus: np.ndarray, seed: int = 0
) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Score distributions (Agarwal et al. 2021's performance profiles): for each method's
    scores (runs, tasks), the share of runs x tasks scoring above each tau, with its 95 %
    stratified bootstrap interval -> {method: (profile (len(taus),), low, high)}."""
    rly = _needs("rliable.library")
    with _seeded(seed):
        profiles, cis = rly.create_performance_profile(
            {k: np.asarray(v, np.float64) for k, v in scores.items()}, taus, reps=REPS
        )
    return {k: (profiles[k], cis[k][0], cis[k][1]) for k in scores}


def interval(values: np.ndarray, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-column mean over rows and its 95 % bootstrap interval.

    values: (runs, k) -> (mean (k,), low (k,), high (k,)). Rows are resampled within each
    column (rliable's stratified bootstrap). One run gives an interval of zero width."""
    values = np.asarray(values, dtype=np.float64)
    mean = values.mean(axis=0)
    if values.shape[0] < 2:
        return mean, mean.copy(), mean.copy()
    _, ci = _bootstrap({"x": values}, lambda s: s.mean(axis=0), seed)
    low, high = ci["x"]
    return mean, np.minimum(low, mean), np.maximum(high, mean)


def iqm_interval(values: np.ndarray, seed: int = 0) -> tuple[float, float, float]:
    """Interquartile mean over runs (rliable's `aggregate_iqm`: the mean of the middle 50 %,
    the estimate Agarwal et al. 2021 recommend for few runs) with its 95 % stratified
    bootstrap interval: values (runs,) or (runs, tasks) -> (iqm, low, high)."""
    metrics = _needs("rliable.metrics")
    values = np.asarray(values, dtype=np.float64).reshape(len(values), -1)
    point = float(metrics.aggregate_iqm(values))
    if values.shape[0] < 2:
        return point, point, point
    _, ci = _bootstrap({"x": values}, lambda s: np.array([metrics.aggregate_iqm(s)]), seed)
    return point, float(min(ci["x"][0, 0], point)), float(max(ci["x"][1, 0], point))


def improvement(x: np.ndarray, y: np.ndarray, seed: int = 0) -> tuple[float, float, float]:
    """P(X > Y): the probability that a run of X scores above a run of Y (ties count half;
    rliable's `probability_of_improvement`, Mann-Whitney's U over runs), with its 95 %
    stratified bootstrap interval: x (runs_x,), y (runs_y,) -> (p, low, high). 0.5: no
    difference; Agarwal et al. call an improvement meaningful when the interval's lower end
    is above 0.5."""
    metrics = _needs("rliable.metrics")
    x = np.asarray(x, dtype=np.float64).reshape(len(x), -1)
    y = np.asarray(y, dtype=np.float64).reshape(len(y), -1)
    point = float(metrics.probability_of_improvement(x, y))
    pair = lambda a, b: np.array([metrics.probability_of_improvement(a, b)])  # noqa: E731
    _, ci = _bootstrap({"x,y": (x, y)}, pair, seed)
    return point, float(min(ci["x,y"][0, 0], point)), float(max(ci["x,y"][1, 0], point))


def first_reaching(curve: np.ndarray, level: float = 0.9, window: int = WINDOW) -> int | None:
    """First epoch (1-based) whose `window`-epoch rolling mean of `curve` (the seeds' mean
    per epoch) is >= level; None if never. Epochs before the first full window do not count."""
    hits = np.nonzero(rolling_mean(curve, window) >= level - 1e-9)[0]
    return int(hits[0]) + window if len(hits) else None


def rolling_mean(curve: np.ndarray, window: int = WINDOW) -> np.ndarray:
    """The `window`-epoch rolling mean of `curve` (epochs,): entry i ends at epoch i + window
    (1-based); empty for a curve shorter than `window`."""
    curve = np.asarray(curve, dtype=np.float64)
    if len(curve) < window:
        return np.zeros(0)
    return np.convolve(curve, np.ones(window) / window, mode="valid")


def reach_interval(
    scores: np.ndarray, level: float = 0.9, window: int = WINDOW, seed: int = 0
) -> tuple[int | None, int | None]:
    """95 % percentile bootstrap interval of `first_reaching` over seeds: scores (seeds,
    epochs) -> (low, high) epochs. Whole seeds' curves are resampled with replacement (arch's
    IIDBootstrap; a curve's epochs stay together, unlike the per-epoch intervals above); a
    resample that never reaches the level counts as after the last epoch, and a bound
    there is None (never)."""
    bootstrap = _needs("arch.bootstrap")
    scores = np.asarray(scores, dtype=np.float64)
    never = scores.shape[1] + 1

    def epoch(x: np.ndarray) -> float:
        hit = first_reaching(x.mean(axis=0), level, window)
        return float(never if hit is None else hit)

    boot = bootstrap.IIDBootstrap(scores, seed=np.random.default_rng(seed))
    low, high = boot.conf_int(epoch, reps=REPS, method="percentile", size=CONFIDENCE)[:, 0]
    bound = lambda x: None if round(x) >= never else round(x)  # noqa: E731
    return bound(low), bound(high)


@dataclasses.dataclass(frozen=True)
class Summary:
    """One cell's learning curve in numbers."""

    seeds: int
    epochs: int
    curve: np.ndarray
    """(epochs,) mean over seeds."""
    curve_low: np.ndarray
    curve_high: np.ndarray
    last: tuple[float, float, float]
    """Mean over seeds of each seed's last-5-epoch mean, with its interval."""
    auc: tuple[float, float, float]
    """Mean success over all epochs (area under the curve / epochs), with its interval."""
    reach_90: int | None
    """First epoch at which the 5-epoch rolling mean of the seeds' mean reaches 0.9."""
    reach_50: int | None
    wall_s: float = 0.0
    """Wall time of the run (s), when known."""


def summarize(scores: np.ndarray, wall_s: float = 0.0) -> Summary:
    """scores: (seeds, epochs) eval success -> Summary."""
    scores = np.asarray(scores, dtype=np.float64)
    curve, low, high = interval(scores)
    per_seed = np.stack([scores[:, -LAST:].mean(axis=1), scores.mean(axis=1)], axis=1)
    point, lo, hi = interval(per_seed)
    return Summary(
        seeds=scores.shape[0],
        epochs=scores.shape[1],
        curve=curve,
        curve_low=low,
        curve_high=high,
        last=(point[0], lo[0], hi[0]),
        auc=(point[1], lo[1], hi[1]),
        reach_90=first_reaching(curve, 0.9),
        reach_50=first_reaching(curve, 0.5),
        wall_s=wall_s,
    )


def scores_from_rows(rows: list[dict], key: str = "eval_success") -> np.ndarray:
    """metrics.jsonl rows (one per epoch per seed) -> (seeds, epochs) array of `key`.
    Raises ValueError when a seed lacks an epoch."""
    seeds = sorted({r["seed"] for r in rows})
    epochs = sorted({r["epoch"] for r in rows})
    out = np.full((len(seeds), len(epochs)), np.nan)
    for r in rows:
        out[seeds.index(r["seed"]), epochs.index(r["epoch"])] = r[key]
    if np.isnan(out).any():
        raise ValueError("incomplete metrics: some seed lacks some epoch")
    return out
