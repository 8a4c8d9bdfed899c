"""manyrods.CmaEs (the optimizer of `manyrods calibrate`, host/scene/study/cmaes.h, active CMA)
checked against Python's `cma` (N. Hansen's reference implementation, an
independent one): the strategy parameters where both follow the published
defaults, and the cost of reaching a minimum on two standard functions."""
import math
import statistics

import cma
import numpy as np
import pytest

import manyrods


@pytest.mark.parametrize("n,lam", [(2, 8), (5, 8), (10, 10), (20, 16), (3, 9)])
def test_strategy_parameters_match_cma_where_both_follow_the_tutorial(n, lam):
    # Reference: cma 4.0, its defaults (active CMA on, as in manyrods). The
    # recombination weights, mu_eff, c_c, c_1 and the damping's form
    # d_sigma - c_sigma are Hansen (2016)'s in both: equal to round-off. Two
    # differ by design, checked as such: cma's c_sigma has n + mu_eff + 3
    # below where the tutorial has + 5, and its c_mu adds 0.25 to
    # mu_eff - 2 + 1/mu_eff (cma's later tuning). The negative weights have
    # the same shape in both (the raw weights of the ranks after mu, scaled);
    # their sum is the tutorial's min(1 + c1/cmu, 1 + 2 mu_eff^-/(mu_eff + 2),
    # (1 - c1 - cmu)/(n cmu)), which cma also applies, each with its own c_mu.
    ours = manyrods.CmaEs([0.0] * n, 0.5, population=lam, seed=1).parameters
    es = cma.CMAEvolutionStrategy(np.zeros(n), 0.5, {"popsize": lam, "verbose": -9, "seed": 1})
    x = es.ask()
    es.tell(x, [float(np.sum(p ** 2)) for p in x])  # (cma sets its step-size parameters at the first tell)
    mu = es.sp.weights.mu
    w = np.asarray(es.sp.weights)[:mu]
    assert len(ours["weights"]) == len(w)
    np.testing.assert_allclose(ours["weights"], w, rtol=1e-13)
    mueff = es.sp.weights.mueff
    assert ours["mueff"] == pytest.approx(mueff, rel=1e-13)
    assert ours["cc"] == pytest.approx(es.sp.cc, rel=1e-13)
    assert ours["c1"] == pytest.approx(es.sp.c1, rel=1e-13)
    assert ours["damps"] - ours["cs"] == pytest.approx(es.adapt_sigma.damps - es.adapt_sigma.cs, rel=1e-13)
    assert es.adapt_sigma.cs == pytest.approx((mueff + 2) / (n + mueff + 3), rel=1e-13)
    assert ours["cs"] == pytest.approx((mueff + 2) / (n + mueff + 5), rel=1e-13)
    assert es.sp.cmu == pytest.approx(min(1 - es.sp.c1, 2 * (0.25 + mueff + 1 / mueff - 2) / ((n + 2) ** 2 + mueff)),
                                      rel=1e-13)
    c1, cmu = ours["c1"], ours["cmu"]
    assert cmu == pytest.approx(min(1 - c1, 2 * (mueff + 1 / mueff - 2) / ((n + 2) ** 2 + mueff)), rel=1e-13)
    neg, theirs = np.asarray(ours["negative_weights"]), np.asarray(es.sp.weights)[mu:]
    assert len(neg) == lam - mu and np.all(neg <= 0) and np.all(theirs <= 0)
    assert (neg[0] == 0) == (lam % 2 == 1)  # (the middle rank of an odd population: zero in both)
    np.testing.assert_allclose(neg / neg.sum(), theirs / theirs.sum(), rtol=1e-13)
    mueff_minus = es.sp.weights.mueffminus
    cap = min(1 + c1 / cmu, 1 + 2 * mueff_minus / (mueff + 2), (1 - c1 - cmu) / (n * cmu))
    assert -neg.sum() == pytest.approx(cap, rel=1e-13)
    theirs_cap = min(1 + c1 / es.sp.cmu, 1 + 2 * mueff_minus / (mueff + 2), (1 - c1 - es.sp.cmu) / (n * es.sp.cmu))
    assert -theirs.sum() == pytest.approx(theirs_cap, rel=1e-13)


def ellipsoid(x):  # condition 1e6, minimum 0 at (1, ..., 1)
    n = len(x)
    return sum(1e3 ** (2 * i / (n - 1)) * (x[i] - 1) ** 2 for i in range(n))


def rosenbrock(x):  # minimum 0 at (1, ..., 1)
    return sum(100 * (x[i + 1] - x[i] ** 2) ** 2 + (1 - x[i]) ** 2 for i in range(len(x) - 1))


def evaluations(ask, tell, f, budget=20000, target=1e-10):
    used = 0
    while used < budget:
        x = ask()
        v = [f(p) for p in x]
        used += len(x)
        if min(v) < target:
            return used
        tell(x, v)
    return math.inf


@pytest.mark.parametrize("f,n", [(ellipsoid, 5), (rosenbrock, 4)])
def test_reaches_a_minimum_for_as_many_evaluations_as_cma(f, n):
    # The evaluations to f < 1e-10 from the origin with step 0.5 and 8
    # candidates, over 11 seeds each: manyrods' median must be within 1.2
    # times cma's (its defaults: active CMA, as in manyrods). Each count
    # scatters by about 6 % between seeds, so either median is known to
    # about 2.5 % and their ratio to about 3.5 %: 1.2 is over 5 of those.
    # Measured 1.04 (ellipsoid) and 1.00 (Rosenbrock); without the active
    # update manyrods needed about 1.4 and 1.2 times cma's evaluations (1.03
    # and 1.02 times those of cma with active CMA off).
    seeds = range(1, 12)
    ours = []
    for s in seeds:
        es = manyrods.CmaEs([0.0] * n, 0.5, population=8, seed=s)
        ours.append(evaluations(es.ask, es.tell, f))
    theirs = []
    for s in seeds:
        es = cma.CMAEvolutionStrategy([0.0] * n, 0.5, {"popsize": 8, "verbose": -9, "seed": s,
                                                       "tolfun": 0, "tolx": 0, "tolfunhist": 0, "tolstagnation": 10**9,
                                                       "maxfevals": 20000})
        theirs.append(evaluations(es.ask, es.tell, f))
    a, b = statistics.median(ours), statistics.median(theirs)
    print(f"{f.__name__} ({n} dims): manyrods {a}, cma {b} evaluations (medians of 11), ratio {a / b:.3f}")
    assert all(math.isfinite(v) for v in ours)
    assert a <= 1.2 * b


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="sigma"):
        manyrods.CmaEs([0.0], 0.0)
    with pytest.raises(ValueError, match="mean"):
        manyrods.CmaEs([], 0.5)
    es = manyrods.CmaEs([0.0, 0.0], 0.5, population=4)
    x = es.ask()
    with pytest.raises(ValueError, match="candidates of the last ask"):
        es.tell(x[:3], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="coordinates"):
        es.tell([[0.0]] * 4, [1.0] * 4)
    with pytest.raises(ValueError, match="not finite"):
        es.tell([[0.0, math.nan]] + x[1:], [1.0] * 4)
    # a tell without its ask takes the points given; NaN values rank last
    fresh = manyrods.CmaEs([0.0, 0.0], 0.5, population=4, seed=3)
    fresh.tell([[1.0, 0.0], [0.5, 0.0], [0.0, 1.0], [0.0, 0.5]], [math.nan, 1.0, math.nan, 2.0])
    assert all(math.isfinite(v) for v in fresh.mean)
    assert fresh.mean[0] > 0.25 and fresh.mean[1] < 0.25  # (towards the best, (0.5, 0), not the NaN ones)
