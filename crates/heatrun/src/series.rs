//! A quantity on the time grid, with the instants where it is unknown.
//!
//! The decimator and the loss calculator hand these along; a week at Ts = 1 s is
//! 604,800 instants per quantity, so the layout matters. One `f64` per instant
//! with NaN for "unknown" takes half the memory of `Vec<Option<f64>>` and loses
//! nothing: the recording stage admits only finite values, so NaN never stands
//! for a measurement.

/// Values x(k) on the grid, k = 0 … len − 1, each known or not.
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// x(k), NaN where unknown.
    values: Vec<f64>,
}

impl Series {
    /// A series of `len` unknown values.
    pub fn unknown(len: usize) -> Series {
        Series {
            values: vec![f64::NAN; len],
        }
    }

    /// Sets x(k); `None` or a non-finite value is unknown.
    ///
    /// # Panics
    /// If `k` is not below [`Series::len`].
    pub fn set(&mut self, k: usize, value: Option<f64>) {
        self.values[k] = value.unwrap_or(f64::NAN);
    }

    /// x(k), or `None` where unknown or past the end.
    pub fn get(&self, k: usize) -> Option<f64> {
        self.values.get(k).copied().filter(|v| v.is_finite())
    }

    /// Appends x(len) (`None` or a non-finite value: unknown): a series grown as a
    /// stream is read.
    pub fn push(&mut self, value: Option<f64>) {
        self.values.push(value.unwrap_or(f64::NAN));
    }

    /// Appends `other`'s values.
    pub fn extend(&mut self, other: &Series) {
        self.values.extend_from_slice(&other.values);
    }

    /// Number of instants.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// Whether there are no instants.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// x(0), x(1), … with `None` where unknown.
    pub fn iter(&self) -> impl DoubleEndedIterator<Item = Option<f64>> + ExactSizeIterator + '_ {
        self.values
            .iter()
            .map(|v| Some(*v).filter(|v| v.is_finite()))
    }
}

/// Equal where both are known with the same value or both unknown.
impl PartialEq for Series {
    fn eq(&self, other: &Series) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}

impl PartialEq<Vec<Option<f64>>> for Series {
    fn eq(&self, other: &Vec<Option<f64>>) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter().copied())
    }
}

impl FromIterator<Option<f64>> for Series {
    fn from_iter<I: IntoIterator<Item = Option<f64>>>(iter: I) -> Series {
        Series {
            values: iter
                .into_iter()
                .map(|v| v.filter(|v| v.is_finite()).unwrap_or(f64::NAN))
                .collect(),
        }
    }
}

impl From<Vec<Option<f64>>> for Series {
    fn from(values: Vec<Option<f64>>) -> Series {
        values.into_iter().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_values_read_back_as_none() {
        let s: Series = vec![Some(1.5), None, Some(f64::INFINITY), Some(-2.0)].into();
        assert_eq!(s.len(), 4);
        assert_eq!(
            s.iter().collect::<Vec<_>>(),
            vec![Some(1.5), None, None, Some(-2.0)]
        );
        assert_eq!(s.get(3), Some(-2.0));
        assert_eq!(s.get(4), None);
        assert_eq!(s, vec![Some(1.5), None, None, Some(-2.0)]);
        assert_eq!(s, Series::from(vec![Some(1.5), None, None, Some(-2.0)]));
        assert_ne!(s, vec![Some(1.5), None, Some(0.0), Some(-2.0)]);
    }

    #[test]
    fn set_marks_known_and_unknown() {
        let mut s = Series::unknown(3);
        s.set(1, Some(3.0));
        s.set(2, Some(f64::NAN));
        assert_eq!(s.iter().collect::<Vec<_>>(), vec![None, Some(3.0), None]);
        s.set(1, None);
        assert_eq!(s.get(1), None);
    }
}
