#!/usr/bin/env python3
"""Twelve seeds of the paper's noisy run replayed by default (issue 33's study).

    python3 scripts/twelve_seeds.py DIR [synth flags...]

Synthesizes DIR/seedN.mcap (N = 1..12, kept for reruns) with the given flags (default
`--temperature-noise 0.05`), replays each by default (its .rrd written beside it, not in
the folder the script runs from), and prints per time constant: the
bias of the seeds' mean, the spread (sample standard deviation) against the mean reported
standard error (the 95 % interval / 1.96, the Cramér–Rao estimate for white noise), how
many 95 % intervals hold the truth, and the replays' wall times. HEATRUN names the binary
(default: target/release/heatrun).
"""
import json, os, subprocess, sys, time, statistics as st

H = os.environ.get('HEATRUN', 'target/release/heatrun')
out, flags = sys.argv[1], sys.argv[2:] or ['--temperature-noise', '0.05']
os.makedirs(out, exist_ok=True)
rows = []
for seed in range(1, 13):
    f = os.path.join(out, f'seed{seed}.mcap')
    if not os.path.exists(f):
        subprocess.run([H, 'synth', f, '--seed', str(seed)] + flags, check=True, capture_output=True)
    truth = json.load(open(f + '.truth.json'))
    report = os.path.join(out, f'report{seed}.json')
    t0 = time.time()
    rrd = os.path.join(out, f'seed{seed}.rrd')
    subprocess.run([H, 'replay', f, '--report', report, '--rrd', rrd, '-q'], check=True, capture_output=True)
    wall = time.time() - t0
    r = json.load(open(report))
    rows.append((wall, r['method'], r['time_constants_s'],
                 r['uncertainty']['time_constants_ci95_s'], truth['time_constants_s']))
    print(seed, f'{wall:.2f} s', r['method'], [round(x, 2) for x in r['time_constants_s']], flush=True)
for i, name in enumerate(['T1', 'T2', 'T3']):
    truth = rows[0][4][i]
    est = [r[2][i] for r in rows]
    half = [r[3][i] for r in rows]
    se = st.mean(h / 1.96 for h in half)
    spread = st.stdev(est)
    held = sum(abs(e - truth) <= h for e, h in zip(est, half))
    print(f'{name}: truth {truth:.2f} s, mean {st.mean(est):.2f} s, '
          f'bias {100 * (st.mean(est) / truth - 1):+.2f} % '
          f'(± {100 * spread / truth / len(est) ** 0.5:.2f} % its own s.e.), '
          f'spread {spread:.3f} s / reported s.e. {se:.3f} s = {spread / se:.2f}, '
          f'95 % intervals holding the truth {held}/12')
walls = [r[0] for r in rows]
print(f'wall times: median {st.median(walls):.2f} s, max {max(walls):.2f} s; '
      f'methods {sorted(set(r[1] for r in rows))}')
