//! Which inputs leave the regression rank deficient, by name: an estimator can only say
//! that its matrix is singular (σ_min/σ_max); the cause a user mends in a spec is two
//! inputs that are one another's multiple (the same heat computed twice, `2 * I^2` beside
//! `I^2`; two constant inputs). One constant input alone is no such cause: with the rises
//! starting at zero it acts as an offset the regression resolves (and a zero one is
//! [`super::EstimationError::ZeroRegressor`]).

use super::IdentificationData;

/// Two inputs proportional over the instants where every input is known: input `b` =
/// `factor` · input `a` (a < b).
#[derive(Debug, Clone, PartialEq)]
pub struct InputDependence {
    /// The first input's column.
    pub a: usize,
    /// The second's.
    pub b: usize,
    /// u_b / u_a = (u_a · u_b) / (u_a · u_a).
    pub factor: f64,
    /// Both are constant, with these values (a heat run without load steps), where they
    /// are: then the data want a run that changes, not a spec with one input fewer.
    pub constant: Option<(f64, f64)>,
}

/// How close to 1 the cosine |u_a · u_b| / (‖u_a‖ ‖u_b‖) of two inputs must come for them
/// to count as proportional: rounding, not a measurement, separates them.
const PROPORTIONAL_COSINE: f64 = 1.0 - 1e-12;

/// The first proportional pair of inputs, over the instants where every input is known;
/// `None` where no two are (the rank deficiency then lies elsewhere: one part's rise
/// following another's).
pub fn input_dependence(data: &IdentificationData) -> Option<InputDependence> {
    let rows: Vec<usize> = (0..data.len()).filter(|&k| data.inputs_known[k]).collect();
    let column = |j: usize| rows.iter().map(move |&k| data.inputs[(k, j)]);
    let m = data.inputs.ncols();
    if rows.len() < 2 {
        return None;
    }
    for a in 0..m {
        for b in a + 1..m {
            let (ab, aa, bb) = column(a)
                .zip(column(b))
                .fold((0.0, 0.0, 0.0), |(ab, aa, bb), (x, y)| {
                    (ab + x * y, aa + x * x, bb + y * y)
                });
            if aa > 0.0 && bb > 0.0 && ab.abs() / (aa.sqrt() * bb.sqrt()) >= PROPORTIONAL_COSINE {
                let first = |j: usize| data.inputs[(rows[0], j)];
                let constant = |j: usize| column(j).all(|v| v == first(j));
                return Some(InputDependence {
                    a,
                    b,
                    factor: ab / aa,
                    constant: (constant(a) && constant(b)).then(|| (first(a), first(b))),
                });
            }
        }
    }
    None
}

impl InputDependence {
    /// The dependence in words, the inputs named by `names` (model order).
    pub fn describe(&self, names: &[String]) -> String {
        let name = |j: usize| {
            names
                .get(j)
                .map_or_else(|| format!("{}", j + 1), Clone::clone)
        };
        match self.constant {
            Some((va, vb)) => format!(
                "inputs `{}` and `{}` are both constant ({va} and {vb} at every instant)",
                name(self.a),
                name(self.b)
            ),
            None => format!(
                "inputs `{}` and `{}` are proportional (`{}` = {:.6} × `{}` at every instant)",
                name(self.a),
                name(self.b),
                name(self.b),
                self.factor,
                name(self.a)
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    fn data(inputs: DMatrix<f64>) -> IdentificationData {
        let n = inputs.nrows();
        IdentificationData::new(
            1.0,
            DMatrix::zeros(n, 1),
            inputs,
            vec![true; n],
            vec![true; n],
        )
    }

    #[test]
    fn a_proportional_pair_is_found_and_named() {
        let k = |i: usize| i as f64;
        let independent =
            DMatrix::from_fn(50, 2, |i, j| if j == 0 { k(i) } else { (k(i) * 0.3).sin() });
        assert_eq!(input_dependence(&data(independent)), None);
        // One constant input is no dependence; two are, said as constant.
        let constant = DMatrix::from_fn(50, 2, |i, j| if j == 0 { k(i) } else { 7.5 });
        assert_eq!(input_dependence(&data(constant)), None);
        let names = ["q".to_owned(), "q2".to_owned()];
        let two = DMatrix::from_fn(50, 2, |_, j| if j == 0 { 2.0 } else { 7.5 });
        let found = input_dependence(&data(two)).unwrap();
        assert_eq!((found.a, found.b, found.constant), (0, 1, Some((2.0, 7.5))));
        assert_eq!(
            found.describe(&names),
            "inputs `q` and `q2` are both constant (2 and 7.5 at every instant)"
        );
        let doubled = DMatrix::from_fn(50, 2, |i, j| (1.0 + j as f64) * (1.0 + k(i)).powi(2));
        let found = input_dependence(&data(doubled)).unwrap();
        assert_eq!((found.a, found.b, found.constant), (0, 1, None));
        assert!((found.factor - 2.0).abs() < 1e-12, "{found:?}");
        assert_eq!(
            found.describe(&names),
            "inputs `q` and `q2` are proportional (`q2` = 2.000000 × `q` at every instant)"
        );
        // Nearly proportional, as two losses of one current are with a resistance that
        // warms (1 % apart): independent.
        let noisy = DMatrix::from_fn(50, 2, |i, j| {
            let loss = (1.0 + j as f64) * (1.0 + k(i)).powi(2);
            loss * if j == 1 {
                1.0 + 0.01 * (k(i) * 1.7).sin()
            } else {
                1.0
            }
        });
        assert_eq!(input_dependence(&data(noisy)), None);
    }
}
