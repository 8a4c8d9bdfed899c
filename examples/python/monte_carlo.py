"""Monte Carlo over material parameters with the Python module: a batch of
cantilevers (the seed cantilever's geometry, 0.3 m, 1 cm square section) whose
Young's modulus E is lognormal and Kelvin-Voigt retardation time tau is normal,
each deflected by a static tip load and released; the damping ratio of each,
measured from its tip's free vibration, against the linear theory
zeta = tau * omega_1 / 2 (Euler-Bernoulli omega_1 of each rod's E).

    .venv/bin/python examples/python/monte_carlo.py [--rods 64] [--seed 1] [--out monte_carlo.png]

(with build/python on PYTHONPATH, or the package installed with `pip install .`).
Every rod is one slice of one batch: the step runs them all at once, and the
tip positions are read from the batch's memory without a copy.
"""

import argparse
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import manyrods  # noqa: E402

L, A, RHO, NU = 0.3, 0.01, 1000.0, 0.3
ELEMENTS = 20
TIP_LOAD = 0.05  # N, along d1 (x)


def omega1(E):
    """First bending frequency of a clamped-free Euler-Bernoulli beam, rad/s."""
    EI, m = E * A**4 / 12, RHO * A * A
    return 1.87510407**2 * np.sqrt(EI / (m * L**4))


def damping_ratio(t, x):
    """From the maxima of the deflection x(t) once below 25 % of the initial
    one (the linear regime, as the demo measures it), down to 3 %: the
    logarithmic decrement."""
    i = np.flatnonzero((x[1:-1] >= x[:-2]) & (x[1:-1] > x[2:]) & (x[1:-1] > 0)) + 1
    c2 = 0.5 * (x[i - 1] - 2 * x[i] + x[i + 1])
    c1 = 0.5 * (x[i + 1] - x[i - 1])
    peak = x[i] - c1 * c1 / (4 * c2)  # parabola through three samples
    ok = (peak < 0.25 * x[0]) & (peak > 0.03 * x[0])
    if ok.sum() < 3:
        return np.nan
    p = peak[ok]
    delta = np.log(p[0] / p[-1]) / (len(p) - 1)
    return delta / np.sqrt(4 * np.pi**2 + delta**2)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rods", type=int, default=64)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--duration", type=float, default=30.0, help="simulated seconds")
    ap.add_argument("--out", default="monte_carlo.png")
    args = ap.parse_args()

    rng = np.random.default_rng(args.seed)
    E = 1e6 * np.exp(rng.normal(0.0, 0.2, args.rods))                   # lognormal: median 1 MPa, sigma(log E) 0.2
    tau = np.clip(rng.normal(0.02, 0.004, args.rods), 0.005, None)       # s, normal, truncated at 5 ms

    rods = [manyrods.Rod.straight([0.1 * i, 0, 0], [0, 0, 1], length=L, elements=ELEMENTS, normal=[1, 0, 0],
                                  section=manyrods.Section.rectangle(A, A),
                                  material=manyrods.Material(density=RHO, youngs_modulus=e, poisson_ratio=NU),
                                  damping=manyrods.Damping.shear_extension(t, t))
            for i, (e, t) in enumerate(zip(E, tau))]
    batch = manyrods.Batch(rods, precision="double", threads=2)
    tips = np.array([batch.node_range(r).stop - 1 for r in range(args.rods)])

    # static start under the tip load, then released
    batch.node_force[0, tips] = TIP_LOAD
    assert batch.solve_static()["converged"]
    batch.node_force[0, tips] = 0.0

    dt, every = batch.dt, 8
    samples = int(args.duration / (dt * every))
    x = batch.node_position  # a view: it follows the steps
    base = x[0, [batch.node_range(r).start for r in range(args.rods)]].copy()
    record = np.empty((samples + 1, args.rods))  # tip deflections along x
    record[0] = x[0, tips] - base
    start = time.perf_counter()
    for k in range(1, samples + 1):
        batch.step(dt, every)
        record[k] = x[0, tips] - base
    wall = time.perf_counter() - start
    t = np.arange(samples + 1) * dt * every
    print(f"{args.rods} rods x {ELEMENTS} elements, {samples * every} steps of {dt:.3g} s in {wall:.1f} s wall: "
          f"{args.rods * ELEMENTS * samples * every / wall:.3g} element-steps/s")

    zeta = np.array([damping_ratio(t, record[:, r]) for r in range(args.rods)])
    theory = tau * omega1(E) / 2
    err = (zeta - theory) / theory
    m = np.isfinite(zeta)  # rods with three maxima between 25 % and 3 % of the deflection
    print(f"damping ratio over the {m.sum()} of {args.rods} rods measured (the others decay too slowly for "
          f"{args.duration:g} s): measured mean {zeta[m].mean():.4f} sd {zeta[m].std():.4f}, linear theory mean "
          f"{theory[m].mean():.4f} sd {theory[m].std():.4f}; per rod (measured - theory)/theory: mean "
          f"{err[m].mean():+.2%}, largest {np.abs(err[m]).max():.2%}")

    fig, (h, s) = plt.subplots(1, 2, figsize=(11, 4.2))
    bins = np.linspace(min(zeta[m].min(), theory[m].min()), max(zeta[m].max(), theory[m].max()), 25)
    h.hist(theory[m], bins=bins, alpha=0.5, label="linear theory  tau * omega_1 / 2")
    h.hist(zeta[m], bins=bins, histtype="step", lw=2, color="k", label="measured (free vibration)")
    h.set_xlabel("damping ratio")
    h.set_ylabel("rods")
    h.set_title(f"{m.sum()} cantilevers: E lognormal (median 1 MPa, sigma 0.2), tau ~ N(20 ms, 4 ms)", fontsize=10)
    h.legend()
    s.plot(theory[m], zeta[m], ".", ms=4)
    lim = [bins[0], bins[-1]]
    s.plot(lim, lim, "k--", lw=1, label="measured = theory")
    s.set_xlabel("linear theory  tau * omega_1 / 2")
    s.set_ylabel("measured damping ratio")
    s.set_title("each rod against its own theory")
    s.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
