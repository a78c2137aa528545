//! Decisions with their uncertainty, checked against the truth on seeded noisy twins of
//! the RC unit (`NetworkMachine::rc_unit`, PT100-like noise: σ 0.05 K at 0.01 K
//! resolution, 0.05 % on the electrical channels, `SynthOptions::with_noise_level(1.0)`).
//!
//! `cargo bench --bench uncertainty` prints:
//! 1. the rating: the noise-free heat run's identified rating (class F), then over twelve
//!    noisy heat runs how often the 95 % interval holds it and the mean half-width
//!    (% of the rating), with the overload times' coverage alike;
//! 2. the prediction: six of those models predicting an unseen 12-hour schedule (a daily
//!    cycle with an hour at 115 % current) from the measured start; the share of
//!    state-instants whose band holds the true (noise-free, simulated) temperature, and
//!    the mean half-width (the derived field winding left out: the synthetic machine has
//!    no field node, its field temperature is a scale fitted to the run, not a truth);
//! 3. the monitor: the same six models beside a noisy healthy 12-hour run and beside
//!    the same run with a fouled cooler (conductances to the coolant 30 % lower from
//!    hour 4), today's fixed band against the model band: alarms on the healthy runs,
//!    and the delay from the fault to the first alarm.
//!
//! `HEATRUN_UNC_SEEDS` (default 12) sets the rating's runs; the prediction and monitor
//! take half as many. `HEATRUN_UNC_ELECTRICAL` sets the electrical channels' noise
//! (relative; default 0.0005); `HEATRUN_UNC_DEBUG` prints each model's prediction error
//! and half-width per state over four stretches of the day.

use std::path::Path;

use heatrun::model_file::{Report, ThermalModel};
use heatrun::monitor::{self, BandKind, BandRule, MonitorOptions};
use heatrun::pipeline::{replay, ReplayOptions};
use heatrun::predict::{predict, InitialState, LoadSchedule};
use heatrun::rating::{rate, InsulationClass, RatingOptions};
use heatrun::synth::{self, CoolerFault, Disturbances, Machine, NetworkMachine, SynthOptions};

/// The 12-hour schedule: (hour it starts, armature current pu, field current pu).
const DAY: [(f64, f64, f64); 7] = [
    (0.0, 0.45, 0.80),
    (1.5, 0.70, 0.90),
    (3.0, 0.95, 1.02),
    (6.0, 1.15, 1.15),
    (7.0, 0.90, 1.00),
    (9.0, 0.60, 0.85),
    (11.0, 0.40, 0.80),
];
const DAY_S: f64 = 12.0 * 3600.0;
const FAULT_AT_S: f64 = 4.0 * 3600.0;

fn heat_run(seed: u64, level: f64) -> SynthOptions {
    let o = SynthOptions {
        machine: Machine::Network(NetworkMachine::rc_unit()),
        seed,
        ..SynthOptions::default()
    }
    .with_noise_level(level);
    match std::env::var("HEATRUN_UNC_ELECTRICAL")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        Some(e) => SynthOptions {
            electrical_noise_pu: e,
            ..o
        },
        None => o,
    }
}

/// The scale of the synthetic machine's field winding temperature (it has no field
/// node: θ_f = θ_in + s·(θ_Cu − θ_in), s iterated for each run to end at the nameplate's
/// final field temperature).
fn field_scale(o: &SynthOptions) -> f64 {
    match synth::plant::simulate(o).expect("simulation").field {
        synth::plant::FieldTemperature::Scaled { scale, .. } => scale,
        synth::plant::FieldTemperature::Node(_) => f64::NAN,
    }
}

/// The nameplate's final field temperature that gives the 12-hour run the heat run's
/// field scale, so that both are one machine: F ← θ_in + s_heat·(θ_f(F) − θ_in)/s(F),
/// a few rounds of a fixed point.
fn day_final_field_c() -> f64 {
    let heat = field_scale(&heat_run(1, 0.0));
    let inlet = synth::SynthOptions::default().coolant.inlet_temp_c;
    let mut final_c = 81.0;
    for _ in 0..20 {
        let s = field_scale(&day_run_at(1, 0.0, None, final_c));
        final_c = inlet + heat * (final_c - inlet) / s;
    }
    final_c
}

fn day_run(seed: u64, level: f64, fault: Option<CoolerFault>) -> SynthOptions {
    day_run_at(seed, level, fault, day_final_field_c())
}

fn day_run_at(seed: u64, level: f64, fault: Option<CoolerFault>, final_c: f64) -> SynthOptions {
    let base = heat_run(seed, level);
    SynthOptions {
        nameplate: heatrun::recording::Nameplate {
            field_winding_final_temp_c: Some(final_c),
            ..base.nameplate.clone()
        },
        duration_s: DAY_S,
        profile: DAY
            .iter()
            .map(|&(h, i, f)| synth::OperatingPoint {
                start_fraction: h * 3600.0 / DAY_S,
                armature_current_pu: i,
                line_voltage_pu: 1.0,
                field_current_pu: f,
            })
            .collect(),
        disturbances: Disturbances {
            fault,
            ..Disturbances::default()
        },
        ..base
    }
}

fn model_of(path: &Path) -> ThermalModel {
    let r = replay(path, &ReplayOptions::default()).expect("replay");
    ThermalModel::from_report(&Report::new(&r), path).expect("model")
}

fn rating_options() -> RatingOptions {
    RatingOptions {
        class: Some(InsulationClass::F),
        limits_c: Vec::new(),
        power_factor: None,
        voltage_v: None,
        coolant_c: None,
        overloads: vec![1.5, 2.0],
    }
}

fn schedule(model: &ThermalModel) -> LoadSchedule {
    let np = model.nameplate.as_ref().expect("nameplate");
    let i_f = np.rated_field_current_a.expect("rated field current");
    LoadSchedule {
        path: "day.csv".into(),
        time_s: DAY.iter().map(|d| d.0 * 3600.0).chain([DAY_S]).collect(),
        points: DAY
            .iter()
            .chain(DAY.last())
            .map(|&(_, i, f)| heatrun::predict::OperatingPoint {
                armature_current_a: i * np.rated_current_a,
                field_current_a: f * i_f,
                line_voltage_v: np.rated_voltage_v,
                ..Default::default()
            })
            .collect(),
        apparent_power: vec![(0.0, 1.0); DAY.len() + 1],
        warnings: Vec::new(),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() {
    let seeds: u64 = std::env::var("HEATRUN_UNC_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(12);
    let dir = tempfile::tempdir().expect("temporary directory");
    let run = |name: String, o: &SynthOptions| {
        let path = dir.path().join(name);
        synth::write(&path, o).expect("synthetic run");
        path
    };
    let clean = model_of(&run("clean.mcap".into(), &heat_run(1, 0.0)));
    let truth = rate(&clean, &rating_options()).expect("rating");
    println!(
        "## rating: rc-unit, class F; the noise-free run's {:.3} MVA ({}), overloads 150 % {:?} s, 200 % {:?} s",
        truth.max_continuous_apparent_power_mva,
        truth.limiting_state,
        truth.overloads[0].time_to_limit_s,
        truth.overloads[1].time_to_limit_s
    );
    let mut models = Vec::new();
    let (mut held, mut half, mut other, mut ov_held, mut ov_n) = (0, Vec::new(), Vec::new(), 0, 0);
    for seed in 1..=seeds {
        let model = model_of(&run(format!("heat-{seed}.mcap"), &heat_run(seed, 1.0)));
        let r = rate(&model, &rating_options()).expect("rating");
        let [lo, hi] = r.max_continuous_apparent_power_mva_95.expect("an interval");
        let s = truth.max_continuous_apparent_power_mva;
        let inside = lo <= s && s <= hi;
        held += usize::from(inside);
        half.push(100.0 * 0.5 * (hi - lo) / r.max_continuous_apparent_power_mva);
        other.push(r.probability_another_part_limits.unwrap_or(f64::NAN));
        for (o, t) in r.overloads.iter().zip(&truth.overloads) {
            if let (Some([a, b]), Some(t)) = (o.time_to_limit_s_95, t.time_to_limit_s) {
                ov_n += 1;
                ov_held += usize::from(a <= t && t <= b);
            }
        }
        println!(
            "  seed {seed:>2}: {:.3} MVA, 95 % [{lo:.3}, {hi:.3}] {}",
            r.max_continuous_apparent_power_mva,
            if inside { "holds it" } else { "MISSES it" }
        );
        models.push(model);
    }
    println!(
        "  rating interval holds the noise-free rating in {held}/{seeds}; mean half-width {:.3} % \
         of the rating; median probability another part limits {:.3}; overload-time intervals \
         hold the noise-free times in {ov_held}/{ov_n}",
        half.iter().sum::<f64>() / half.len() as f64,
        median(other)
    );
    predictions(&clean, &models[..(seeds as usize).div_ceil(2)]);
    monitors(&models[..(seeds as usize).div_ceil(2)], &run);
}

/// Part 2: the band against the simulated truth of the 12-hour schedule.
fn predictions(clean: &ThermalModel, models: &[ThermalModel]) {
    let truth_run = synth::plant::simulate(&day_run(1, 0.0, None)).expect("truth");
    let base = synth::SynthOptions::default().nameplate.temperature_base_k;
    // The noise-free model's own error against the truth: what no band of the noisy
    // models' parameters can hold.
    let p = predict(clean, &schedule(clean), &InitialState::Measured).expect("prediction");
    let worst = (0..clean.state_count())
        .map(|j| {
            p.temperatures_c
                .iter()
                .enumerate()
                .map(|(k, theta)| {
                    (theta[j] - truth_run.temperature(&truth_run.states[k], j, base)).abs()
                })
                .fold(0.0, f64::max)
        })
        .collect::<Vec<_>>();
    println!(
        "  the noise-free run's model against the truth: largest error per state {worst:.4?} K"
    );
    let (mut inside, mut total, mut half_sum) = (0usize, 0usize, 0.0);
    println!("\n## prediction: 12-hour daily cycle with an hour at 115 % current, from the measured start");
    for (i, model) in models.iter().enumerate() {
        let started = std::time::Instant::now();
        let p = predict(model, &schedule(model), &InitialState::Measured).expect("prediction");
        let elapsed = started.elapsed().as_secs_f64();
        let bands = p.band_c.as_ref().expect("a band");
        let n = model.state_count();
        let (mut a, mut t, mut h) = (0usize, 0usize, 0.0);
        for (k, theta) in p.temperatures_c.iter().enumerate() {
            let x = &truth_run.states[k];
            // The states only: the band's columns after them are the derived ones.
            for (j, predicted) in theta.iter().enumerate() {
                let truth = truth_run.temperature(x, j, base);
                let w = bands.half_width_k[k][j];
                a += usize::from((predicted - truth).abs() <= w);
                t += 1;
                h += w;
            }
        }
        println!(
            "  model {}: band holds the truth at {:.1} % of {t} state-instants, mean half-width {:.3} K (prediction with band {:.2} s)",
            i + 1,
            100.0 * a as f64 / t as f64,
            h / t as f64,
            elapsed
        );
        if std::env::var("HEATRUN_UNC_DEBUG").is_ok() {
            for j in 0..n {
                for (from, to) in [
                    (0usize, 600usize),
                    (600, 7200),
                    (7200, 21600),
                    (21600, 43200),
                ] {
                    let (mut e, mut w, mut c) = (0.0, 0.0, 0);
                    for k in from..to {
                        let truth = truth_run.temperature(&truth_run.states[k], j, base);
                        e += p.temperatures_c[k][j] - truth;
                        w += bands.half_width_k[k][j];
                        c += usize::from(
                            (p.temperatures_c[k][j] - truth).abs() <= bands.half_width_k[k][j],
                        );
                    }
                    let len = (to - from) as f64;
                    println!("    state {j} {from}-{to} s: mean error {:+.4} K, mean half-width {:.4} K, inside {:.0} %", e / len, w / len, 100.0 * c as f64 / len);
                }
            }
        }
        inside += a;
        total += t;
        half_sum += h;
    }
    println!(
        "  all: {:.1} % of state-instants inside, mean half-width {:.3} K",
        100.0 * inside as f64 / total as f64,
        half_sum / total as f64
    );
}

/// Part 3: the fixed band against the model band, healthy and fouled.
fn monitors(models: &[ThermalModel], run: &dyn Fn(String, &SynthOptions) -> std::path::PathBuf) {
    println!("\n## monitor: healthy 12-hour runs and a fouled cooler (30 % lower conductance from hour 4)");
    let options = |kind| MonitorOptions {
        band: BandRule {
            kind,
            ..BandRule::default()
        },
        ..MonitorOptions::default()
    };
    for kind in [BandKind::Fixed, BandKind::Model] {
        let (mut false_alarms, mut delays, mut missed) = (0, Vec::new(), 0);
        let mut widths = Vec::new();
        for (i, model) in models.iter().enumerate() {
            let seed = 100 + i as u64;
            let healthy = run(format!("healthy-{seed}.mcap"), &day_run(seed, 1.0, None));
            let fault = CoolerFault {
                time_s: FAULT_AT_S,
                conductance_drop: 0.3,
            };
            let fouled = run(
                format!("fouled-{seed}.mcap"),
                &day_run(seed, 1.0, Some(fault)),
            );
            let h = monitor::monitor(model, &healthy, &options(kind), None).expect("monitor");
            false_alarms += h.alarms.len();
            widths.extend(h.band.half_width_k.iter().copied());
            let f = monitor::monitor(model, &fouled, &options(kind), None).expect("monitor");
            match f.alarms.iter().map(|a| a.raised_ns).min() {
                Some(raised) => delays.push(f.seconds(raised) - FAULT_AT_S),
                None => missed += 1,
            }
        }
        println!(
            "  {kind:?} band: {false_alarms} alarms on {} healthy runs (mean half-width {:.3} K); fouled cooler: \
             delay from the fault to the first alarm, median {:.0} s, per run {:?} s, {missed} missed",
            models.len(),
            widths.iter().sum::<f64>() / widths.len().max(1) as f64,
            median(delays.clone()),
            delays.iter().map(|d| d.round()).collect::<Vec<_>>()
        );
    }
}
