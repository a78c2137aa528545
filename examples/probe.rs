use heatrun::estimate::{Estimator, InstrumentalVariables, OutputError, iv::lagged_output_iv};
use heatrun::pipeline::{self, ReplayOptions};
use heatrun::synth::{self, SynthOptions};
use std::time::Instant;
fn main() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.mcap");
    synth::write(&path, &SynthOptions::default().with_noise_level(1.0)).unwrap();
    let t = Instant::now();
    let prepared = pipeline::prepare(&path, &ReplayOptions::default()).unwrap();
    println!("prepare {:.3}s", t.elapsed().as_secs_f64());
    let data = &prepared.data;
    let t = Instant::now(); let l = lagged_output_iv(data).unwrap(); println!("lagged iv {:.3}s", t.elapsed().as_secs_f64());
    let t = Instant::now(); let iv = InstrumentalVariables::default().refine(data, l).unwrap(); println!("iv refine {:.3}s iters {}", t.elapsed().as_secs_f64(), iv.iterations);
    let t = Instant::now(); let oe = OutputError::default().refine(data, &iv.model).unwrap(); println!("oe refine {:.3}s evals {}", t.elapsed().as_secs_f64(), oe.iterations);
    let t = Instant::now(); let _ = heatrun::model::analyse(&oe, data, 80.0, &[0.0027, 0.0024, 0.0036]).unwrap(); println!("analyse {:.3}s", t.elapsed().as_secs_f64());
}
