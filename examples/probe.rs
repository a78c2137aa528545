use heatrun::pipeline::{self, Method, ReplayOptions};
use heatrun::synth::{self, SynthOptions};
fn main() {
    let level: f64 = std::env::args().nth(1).unwrap().parse().unwrap();
    let elevel: f64 = std::env::args().nth(2).unwrap().parse().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.mcap");
    let mut worst = vec![0.0f64; 3];
    for seed in 1..=8 {
        let truth = synth::write(&path, &SynthOptions { temperature_noise_k: 0.05 * level, temperature_resolution_k: 0.01, electrical_noise_pu: 0.0005 * elevel, seed, ..SynthOptions::default() }).unwrap();
        let t0 = std::time::Instant::now();
        let r = pipeline::replay(&path, &ReplayOptions { method: Method::Oe, ..ReplayOptions::default() }).unwrap();
        let e: Vec<f64> = r.analysis.spectrum.time_constants_s.iter().zip(&truth.time_constants_s).map(|(t, w)| (t / w - 1.0) * 100.0).collect();
        let ss: Vec<f64> = r.analysis.steady_state.iter().zip(&truth.steady_state_rise_k).map(|(s, w)| s * 80.0 - w).collect();
        for i in 0..3 { worst[i] = worst[i].max(e[i].abs()); }
        println!("seed {seed}: T err % {:.2?} ss err K {:.3?} evals {} {:.2}s", e, ss, r.estimate.iterations, t0.elapsed().as_secs_f64());
    }
    println!("worst {worst:.2?}");
}
