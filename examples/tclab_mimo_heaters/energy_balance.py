#!/usr/bin/env python3
"""TCLab's nonlinear energy balance (radiation) with a lag behind each thermistor, fitted by
output error on the estimation file and simulated on the validation file: the physical grey
box issue 23 cites, as a reference independent of heatrun (plain Python 3, no numpy).

    examples/tclab_mimo_heaters/energy_balance.py apm|board [DELAY_S] [START] [DATASETS_DIR]

Absolute temperatures T (K); ambient Ta = T1's first reading of each file; heater powers
α_i·Q_i (Q in %); ε = 0.9, σ = 5.67e-8 W/(m²K⁴), A = 10 cm², As = 2 cm² (the data set's
nominal values, datasets/tclab_mimo_heaters/README.md):

  apm   (APMonitor's model, sensor lags added; parameters U, Us, α1, α2, τ1, τ2, c):
        c·m·Cp·dTh1/dt = U·A·(Ta−Th1) + εσA(Ta⁴−Th1⁴) + Us·As·(Th2−Th1) + εσAs(Th2⁴−Th1⁴) + α1·Q1
        (Th2 likewise), dTs_i/dt = (Th_i − Ts_i)/τ_i, with m·Cp = 2 J/K.
  board (a third node, the board both heaters sit on; parameters α1, α2, C1, C2, Cb, G1, G2,
        Gs, Gb1, Gb2, Gba, r, τ1, τ2):
        C1·dTh1/dt = α1·Q1 − G1(Th1−Ta) − r·εσA(Th1⁴−Ta⁴) − Gs(Th1−Th2) − Gb1(Th1−Tb)
        Cb·dTb/dt  = Gb1(Th1−Tb) + Gb2(Th2−Tb) − Gba(Tb−Ta)

Each thermistor reads its lag state Ts_i plus its reading at rest (T2 reads about 1 K below
T1 at the start of both files). Parameters are fitted in logarithms (τ_i = 1 s + e^z: a lag
under a second is below the sampling) by Levenberg-Marquardt on the estimation file's
output errors, from the nominal values (START 0, the default) or from them each
multiplied by e^N(0, 0.5²) (START k > 0, Python's random seeded with k): the likelihood has
several minima, and the one to take is the least estimation cost, not the best validation; the simulation is RK4 with steps of at most 0.5 s,
heater 1's command delayed by DELAY_S (default 0). Printed: the parameters and the NRMSE fit
100 (1 − ‖y − ŷ‖/‖y − ȳ‖) of T1 and T2 on both files, the validation simulated from rest.
"""

import csv
import math
import os
import random
import sys

SIGMA, EPS, AREA, AREA_S, M_CP = 5.67e-8, 0.9, 10e-4, 2e-4, 2.0


def load(path):
    rows = list(csv.reader(open(path)))[1:]
    return [[float(x) for x in row[:5]] for row in rows]


def held(data, delay):
    """Heater 1's command at time t, held between samples and delayed by `delay` s."""
    times = [row[0] for row in data]

    def q1(t):
        t -= delay
        lo, hi = 0, len(times) - 1
        if t < times[0]:
            return data[0][1]
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if times[mid] <= t:
                lo = mid
            else:
                hi = mid - 1
        return data[lo][1]

    return q1


def derivative_apm(p, ta):
    u, us, a1, a2, tau1, tau2, c = p
    cap, rad, rad_s = c * M_CP, EPS * SIGMA * AREA, EPS * SIGMA * AREA_S

    def f(x, q1, q2):
        th1, th2, ts1, ts2 = x
        between = us * AREA_S * (th2 - th1) + rad_s * (th2**4 - th1**4)
        d1 = (u * AREA * (ta - th1) + rad * (ta**4 - th1**4) + between + a1 * q1) / cap
        d2 = (u * AREA * (ta - th2) + rad * (ta**4 - th2**4) - between + a2 * q2) / cap
        return [d1, d2, (th1 - ts1) / tau1, (th2 - ts2) / tau2]

    return f, 4


def derivative_board(p, ta):
    a1, a2, c1, c2, cb, g1, g2, gs, gb1, gb2, gba, r, tau1, tau2 = p
    rad = r * EPS * SIGMA * AREA

    def f(x, q1, q2):
        th1, th2, tb, ts1, ts2 = x
        d1 = (a1 * q1 - g1 * (th1 - ta) - rad * (th1**4 - ta**4) - gs * (th1 - th2) - gb1 * (th1 - tb)) / c1
        d2 = (a2 * q2 - g2 * (th2 - ta) - rad * (th2**4 - ta**4) + gs * (th1 - th2) - gb2 * (th2 - tb)) / c2
        db = (gb1 * (th1 - tb) + gb2 * (th2 - tb) - gba * (tb - ta)) / cb
        return [d1, d2, db, (th1 - ts1) / tau1, (th2 - ts2) / tau2]

    return f, 5


MODELS = {
    "apm": (derivative_apm, "U Us a1 a2 tau1 tau2 c".split(), [10, 10, 0.01, 0.0075, 10, 10, 1.0]),
    "board": (
        derivative_board,
        "a1 a2 C1 C2 Cb G1 G2 Gs Gb1 Gb2 Gba r tau1 tau2".split(),
        [0.01, 0.0075, 2, 2, 5, 0.005, 0.005, 0.003, 0.005, 0.005, 0.005, 1.0, 10, 10],
    ),
}


def simulate(model, p, data, delay, h_max=0.5):
    ta = data[0][3] + 273.15
    f, n = MODELS[model][0](p, ta)
    rest = [data[0][3] + 273.15 - ta, data[0][4] + 273.15 - ta]
    x = [ta] * n
    q1 = held(data, delay)
    out = [(x[-2] + rest[0] - 273.15, x[-1] + rest[1] - 273.15)]
    for k in range(len(data) - 1):
        dt = data[k + 1][0] - data[k][0]
        steps = max(1, math.ceil(dt / h_max - 1e-9))
        h = dt / steps
        for j in range(steps):
            u1, u2 = q1(data[k][0] + j * h), data[k][2]
            k1 = f(x, u1, u2)
            k2 = f([a + h / 2 * b for a, b in zip(x, k1)], u1, u2)
            k3 = f([a + h / 2 * b for a, b in zip(x, k2)], u1, u2)
            k4 = f([a + h * b for a, b in zip(x, k3)], u1, u2)
            x = [a + h / 6 * (b + 2 * c + 2 * d + e) for a, b, c, d, e in zip(x, k1, k2, k3, k4)]
        out.append((x[-2] + rest[0] - 273.15, x[-1] + rest[1] - 273.15))
    return out


def parameters(model, z):
    p = [math.exp(v) for v in z]
    names = MODELS[model][1]
    for i in (names.index("tau1"), names.index("tau2")):
        p[i] += 1.0
    return p


def residuals(model, z, data, delay):
    y = simulate(model, parameters(model, z), data, delay)
    return [r[3] - a for r, (a, _) in zip(data, y)] + [r[4] - b for r, (_, b) in zip(data, y)]


def solve(m, b):
    n = len(b)
    a = [row[:] + [b[i]] for i, row in enumerate(m)]
    for c in range(n):
        piv = max(range(c, n), key=lambda i: abs(a[i][c]))
        a[c], a[piv] = a[piv], a[c]
        for i in range(c + 1, n):
            f = a[i][c] / a[c][c]
            for j in range(c, n + 1):
                a[i][j] -= f * a[c][j]
    x = [0.0] * n
    for i in range(n - 1, -1, -1):
        x[i] = (a[i][n] - sum(a[i][j] * x[j] for j in range(i + 1, n))) / a[i][i]
    return x


def levenberg_marquardt(model, z, data, delay, iterations=60):
    lam = 1e-2
    r = residuals(model, z, data, delay)
    cost = sum(v * v for v in r)
    for _ in range(iterations):
        cols = []
        for i in range(len(z)):
            zz = list(z)
            zz[i] += 1e-5
            cols.append([(a - b) / 1e-5 for a, b in zip(residuals(model, zz, data, delay), r)])
        n = len(z)
        jtj = [[sum(a * b for a, b in zip(cols[i], cols[j])) for j in range(n)] for i in range(n)]
        jtr = [sum(a * b for a, b in zip(cols[i], r)) for i in range(n)]
        while True:
            m = [[jtj[i][j] + (lam * jtj[i][i] + 1e-12 if i == j else 0.0) for j in range(n)] for i in range(n)]
            try:
                step = solve(m, [-v for v in jtr])
                trial = [a + max(-1.0, min(1.0, d)) for a, d in zip(z, step)]
                rt = residuals(model, trial, data, delay)
                ct = sum(v * v for v in rt)
            except (ZeroDivisionError, OverflowError):
                ct = math.inf
            if ct < cost:
                gain = cost - ct
                z, r, cost = trial, rt, ct
                lam = max(lam / 3, 1e-7)
                break
            lam *= 5
            if lam > 1e8:
                return z, cost
        if gain < 1e-7 * cost:
            break
    return z, cost


def fit_percent(data, y):
    out = []
    for j in range(2):
        m = [r[3 + j] for r in data]
        mean = sum(m) / len(m)
        err = math.sqrt(sum((a - b[j]) ** 2 for a, b in zip(m, y)))
        out.append(100 * (1 - err / math.sqrt(sum((a - mean) ** 2 for a in m))))
    return out


def main():
    model = sys.argv[1] if len(sys.argv) > 1 else "apm"
    if model not in MODELS:
        sys.exit(f"energy_balance.py: unknown model `{model}`; give apm or board (usage: see the file's first lines)")
    delay = float(sys.argv[2]) if len(sys.argv) > 2 else 0.0
    here = os.path.dirname(os.path.abspath(__file__))
    start = int(sys.argv[3]) if len(sys.argv) > 3 else 0
    root = sys.argv[4] if len(sys.argv) > 4 else os.path.join(here, "..", "..", "datasets")
    folder = os.path.join(root, "tclab_mimo_heaters")
    est = load(os.path.join(folder, "tclab_mimo_data.csv"))
    val = load(os.path.join(folder, "tclab_mimo_step_data_3s.csv"))
    _, names, nominal = MODELS[model]
    z = [math.log(v - 1.0 if n.startswith("tau") else v) for n, v in zip(names, nominal)]
    if start > 0:
        rng = random.Random(start)
        z = [v + rng.gauss(0.0, 0.5) for v in z]
    z, cost = levenberg_marquardt(model, z, est, delay)
    p = parameters(model, z)
    print(f"{model}, heater 1 delayed {delay:g} s, start {start}: estimation cost {cost:.1f} K²")
    print("  " + ", ".join(f"{n} {v:.4g}" for n, v in zip(names, p)))
    fe = fit_percent(est, simulate(model, p, est, delay))
    fv = fit_percent(val, simulate(model, p, val, delay))
    print(f"  estimation fit T1 {fe[0]:.1f} %, T2 {fe[1]:.1f} %; validation T1 {fv[0]:.1f} %, T2 {fv[1]:.1f} %")


if __name__ == "__main__":
    main()
