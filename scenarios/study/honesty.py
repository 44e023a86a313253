"""A Monte-Carlo study's honesty in a few numbers, read from its summary (summary.json's
``parameters``): the pooled 95 % coverage, how many parameters' own coverage leaves its binomial
band, the worst bias in reported std, and how much a change of the twin grew the reported std.
What the README's study tables print; the summary itself is :func:`montecarlo.summarise`'s."""

from __future__ import annotations


def covered(summary: dict) -> list[dict]:
    """The summary's parameters that report a std (a coverage), in its order."""
    return [p for p in summary["parameters"] if p["coverage_95"] is not None]


def pooled_coverage(summary: dict) -> float:
    """The mean of the parameters' 95 % coverages (each over the same trials)."""
    ps = covered(summary)
    return sum(p["coverage_95"] for p in ps) / len(ps)


def outside_band(summary: dict) -> int:
    """How many parameters' coverage lies outside the band where an honest std's coverage lands
    95 % of the time with this many trials (``coverage_95_expected``)."""
    from calibench.scenarios.study.summary import in_band

    return sum(not in_band(p["coverage_95"], p["coverage_95_expected"]) for p in covered(summary))


def worst_bias(summary: dict) -> tuple[str, float]:
    """The parameter whose mean error is largest against its mean reported std, and that ratio
    (|bias| / mean std)."""
    worst = max(covered(summary), key=lambda p: abs(p["bias"]) / p["mean_std"])
    return worst["name"], abs(worst["bias"]) / worst["mean_std"]


def median_std_ratio(before: dict, after: dict) -> float:
    """The median over ``before``'s parameters with a std of after's mean reported std over
    before's (the upper median for an even count): how a change grew the reported std."""
    s0 = {p["name"]: p["mean_std"] for p in covered(before)}
    s1 = {p["name"]: p["mean_std"] for p in covered(after)}
    return sorted(s1[n] / s0[n] for n in s0)[len(s0) // 2]
