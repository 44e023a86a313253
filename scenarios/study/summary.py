"""A study's statistics: bias, RMSE, mean reported std and 95 % coverage of every parameter,
efficiency against the CRLB, the spread of every check, and their tables for the console."""

from __future__ import annotations

import numpy as np

from calibench.scenarios.study.journal import row_keys

# coverage_95 counts the trials whose |error| is at most this many reported std: the normal
# distribution's two-sided 95 % point (1.959964, to the three digits the studies have always used)
Z_95 = 1.96


def chi2_ppf(p: np.ndarray, df: int) -> np.ndarray:
    """scipy.stats.chi2.ppf by its own formula, without importing scipy.stats (a second of
    start-up the summary of a fast study would wait for).

    Parameters
    ----------
    p : ndarray, shape (k,)
        Probabilities in (0, 1).
    df : int
        Degrees of freedom.

    Returns
    -------
    ndarray, shape (k,)
        The quantiles of chi2(df) at ``p``.
    """
    from scipy.special import gammaincinv

    return 2 * gammaincinv(df / 2, p)


def binom_ppf(p: np.ndarray, n: int, prob: float) -> np.ndarray:
    """scipy.stats.binom.ppf: the least k with P(X <= k) >= p, X ~ Binomial(n, prob).

    Parameters
    ----------
    p : ndarray, shape (k,)
        Probabilities in (0, 1].
    n : int
        Number of draws.
    prob : float
        Probability of a success in one draw.

    Returns
    -------
    ndarray, shape (k,)
        The quantiles, whole numbers as floats.
    """
    from scipy.special import bdtr

    cdf = bdtr(np.arange(n + 1), n, prob)
    # a slack for a cdf rounded just below p; scipy's own search (Boost's) is not this code, so
    # the agreement is checked, not assumed: test_quantiles_equal_scipy_stats
    return np.searchsorted(cdf, np.asarray(p) * (1 - 1e-14)).astype(float)


def coverage_band(trials: int) -> tuple[float, float]:
    """Where an honest std's coverage of 95 % intervals lands 95 % of the time over ``trials``
    trials: the 2.5 % and 97.5 % quantiles of Binomial(trials, 0.95), over ``trials``. The one
    band of summary.json (``coverage_95_expected``), the console and study.png.

    Parameters
    ----------
    trials : int
        The trials a coverage counts (at least 1).

    Returns
    -------
    (float, float)
        The band's edges, each a coverage the trials can give (k / trials): a coverage on an edge
        is inside (:func:`in_band`).
    """
    n = max(int(trials), 1)
    lo, hi = binom_ppf(np.array([0.025, 0.975]), n, 0.95) / n
    return float(lo), float(hi)


def in_band(coverage: float, band) -> bool:
    """Whether ``coverage`` lies in ``band`` (lo, hi), its edges included: the one rule for the
    boundary, used wherever a coverage is judged (the summary's counts, study.png's colours)."""
    lo, hi = band
    return bool(lo <= coverage <= hi)


def summarise(scenario: str, rows: list[dict], elapsed_s: float) -> dict:
    """Bias, RMSE, mean reported std and 95 % coverage of every parameter over the good trials.

    Parameters
    ----------
    scenario : str
        The scenario's name.
    rows : list of dict
        The trials' journal rows (:func:`~calibench.scenarios.study.trials.run_trial`).
    elapsed_s : float
        The run's duration, s.

    Returns
    -------
    dict
        summary.json (docs/formats.md): ``scenario``, ``trials``, ``failed``, ``elapsed_s``,
        ``parameters`` (per parameter ``name``, ``unit``, ``n``, ``bias``, ``rmse``,
        ``mean_std``, ``coverage_95``, ``coverage_95_expected``, and with a CRLB ``crlb_std``,
        ``efficiency``, ``efficiency_ci95``), ``checks`` and the first ten distinct ``errors``.
    """
    good = [r for r in rows if r["ok"]]
    keys = row_keys(good)
    names = sorted(k[: -len(".estimate")] for k in keys if k.endswith(".estimate"))
    params = []
    for n in names:
        est, tru, sd, un, cr = (f"{n}.{x}" for x in ("estimate", "truth", "std", "unit", "crlb"))
        err = np.array([r[est] - r[tru] for r in good if est in r])
        stds = np.array([r.get(sd) for r in good if est in r], dtype=object)
        std = stds.astype(float) if all(s is not None for s in stds) else None
        unit = next((r[un] for r in good if un in r), "")
        crlb = np.array([r[cr] for r in good if cr in r])
        extra: dict[str, float | list[float]] = {}
        if len(crlb) == len(err) and len(err) > 1:
            # efficiency: the bound's variance over the estimates' own (about their mean); the
            # sample variance has (n - 1) s^2 / sigma^2 ~ chi2(n - 1), which gives its interval
            eff = float(np.mean(crlb**2) / np.var(err, ddof=1))
            lo, hi = chi2_ppf(np.array([0.025, 0.975]), len(err) - 1) / (len(err) - 1)
            extra["crlb_std"] = float(np.sqrt(np.mean(crlb**2)))
            extra["efficiency"] = eff
            extra["efficiency_ci95"] = [eff * lo, eff * hi]
        params.append(
            {
                "name": n,
                "unit": unit,
                "n": int(len(err)),
                "bias": float(np.mean(err)),
                "rmse": float(np.sqrt(np.mean(err**2))),
                "mean_std": float(np.mean(std)) if std is not None else None,
                "coverage_95": float(np.mean(np.abs(err) <= Z_95 * std))
                if std is not None
                else None,
                # where an honest coverage of 0.95 lands 95 % of the time with this many trials
                "coverage_95_expected": list(coverage_band(len(err))) if std is not None else None,
                **extra,
            }
        )
    return {
        "scenario": scenario,
        "trials": len(rows),
        "failed": len(rows) - len(good),
        "elapsed_s": round(elapsed_s, 3),
        "parameters": params,
        "checks": _check_summary(good, keys),
        "errors": sorted({r["error"] for r in rows if not r["ok"]})[:10],
    }


def _check_summary(good: list[dict], keys: set[str]) -> list[dict]:
    """Each check's median, 95th percentile and worst value over the good trials (whose keys are
    ``keys``), and the fraction of trials that failed it."""
    names = sorted(
        k[len("check.") :] for k in keys if k.startswith("check.") and not k.endswith(".ok")
    )
    out = []
    for n in names:
        key = f"check.{n}"
        v = np.array([r[key] for r in good if key in r], float)
        ok_key = f"check.{n}.ok"
        ok = np.array([r[ok_key] for r in good if ok_key in r], bool)
        f = v[np.isfinite(v)]  # a value that is not a number failed its check, and is counted there
        stats = [
            float(g(f)) if len(f) else None
            for g in (np.median, lambda a: np.percentile(a, 95), np.max)
        ]
        out.append(
            {
                "name": n,
                "n": int(len(v)),
                "median": stats[0],
                "p95": stats[1],
                "max": stats[2],
                "failed_fraction": float(1 - ok.mean()),
            }
        )
    return out


def checks_table(summary: dict) -> str:
    """The checks' spread over the trials as markdown (empty when the trials report none).

    Parameters
    ----------
    summary : dict
        A study's summary (:func:`summarise`).

    Returns
    -------
    str
        A markdown table, one row per check; "" when there is none.
    """
    if not summary.get("checks"):
        return ""
    lines = ["| check | median | 95 % | worst | trials failing it |", "|---|---|---|---|---|"]
    f = lambda v: "-" if v is None else f"{v:.4g}"  # noqa: E731
    for c in summary["checks"]:
        lines.append(
            f"| {c['name']} | {f(c['median'])} | {f(c['p95'])} | {f(c['max'])} | "
            f"{c['failed_fraction']:.1%} |"
        )
    return "\n".join(lines)


def summary_table(summary: dict) -> str:
    """The coverage table as markdown; efficiency with its 95 % interval where a CRLB exists.

    Parameters
    ----------
    summary : dict
        A study's summary (:func:`summarise`).

    Returns
    -------
    str
        A markdown table, one row per parameter.
    """
    f = lambda v: "" if v is None else f"{v:.4g}"  # noqa: E731
    lines = [
        "| parameter | unit | bias | rmse | mean std | coverage 95 % | efficiency (95 % CI) |",
        "|---|---|---|---|---|---|---|",
    ]
    for p in summary["parameters"]:
        eff = (
            ""
            if p.get("efficiency") is None
            else f"{p['efficiency']:.3f} "
            f"({p['efficiency_ci95'][0]:.2f}-{p['efficiency_ci95'][1]:.2f})"
        )
        cov = "" if p["coverage_95"] is None else f"{p['coverage_95']:.3f}"
        lines.append(
            f"| {p['name']} | {p['unit']} | {f(p['bias'])} | {f(p['rmse'])} | {f(p['mean_std'])} | "
            f"{cov} | {eff} |"
        )
    lines.append(TABLE_NOTE)
    return "\n".join(lines)


# what the table's columns mean, printed under it
TABLE_NOTE = (
    "\ncoverage 95 %: the share of trials whose truth lies within 1.96 reported std of the "
    "estimate (an honest std: 0.95, within the trials' binomial scatter); efficiency: the "
    "Cramer-Rao bound's variance over the estimates' own (1: no unbiased estimator does better; "
    "its interval is the trials' sampling scatter)"
)
