//! Smooth curves sent as the polyline a plot draws of them.
//!
//! A time-series view joins a series' points with straight lines. Where the series is a
//! smooth curve (a simulated temperature, a sensitivity response), most of its instants
//! lie on the line through their neighbours, and sending them costs the writer's time and
//! the file's bytes without changing a pixel: on W0 (5.8 h at 1 s) the model's three
//! temperatures and the nine sensitivity responses are 250,000 of the recording's 670,000
//! rows, and 13,000 of them draw the same lines. [`Polyline`] keeps a point only where the
//! straight line from the last kept point would pass some skipped instant farther than
//! [`CURVE_TOLERANCE`] of the curve's range from its value. Measured series and
//! residuals (noise, where every instant is data) are sent whole.

/// The largest distance, as a fraction of the curve's range (max − min of its values so
/// far), between a skipped instant's value and the straight line the plot draws through
/// it: 10⁻⁵, a hundredth of a pixel of a plot 1,000 pixels high showing the whole curve
/// (0.4 mK on a 40 K rise), still under a pixel zoomed a hundredfold.
pub const CURVE_TOLERANCE: f64 = 1e-5;

/// The points of a curve that the polyline through them draws within `relative` of the
/// curve's range from every point of the curve, pushed one at a time (in increasing time)
/// and told as they are kept.
///
/// With a the last kept point and ε = `relative` · (max v − min v) over the points seen,
/// a point p_i is skipped while the line from a to the next point p_{i+1} passes every
/// skipped p_j (a < j ≤ i) within ε:
///
/// (v_j − ε − v_a)/(t_j − t_a) ≤ (v_{i+1} − v_a)/(t_{i+1} − t_a) ≤ (v_j + ε − v_a)/(t_j − t_a),
///
/// the slopes' bounds kept as a running maximum and minimum (one pass, nothing buffered).
/// The first and last points are always kept, and every kept point is a point of the
/// curve, to the bit. ε grows with the range seen, never shrinks: a bound taken earlier
/// holds under the final ε. Non-finite values are skipped, as a plot skips them.
#[derive(Debug, Clone)]
pub struct Polyline {
    relative: f64,
    range: (f64, f64),
    /// The last kept point (the lines' start), once there is one.
    anchor: Option<(i64, f64)>,
    /// The last point pushed after the anchor, not yet kept: the line's end so far.
    last: Option<(i64, f64)>,
    /// The slopes from the anchor that pass every skipped point within ε.
    slopes: (f64, f64),
}

/// No bound on the slope yet.
const OPEN: (f64, f64) = (f64::NEG_INFINITY, f64::INFINITY);

impl Polyline {
    /// A curve with nothing pushed yet, drawn within `relative` of its range.
    pub fn new(relative: f64) -> Polyline {
        Polyline {
            relative,
            range: (f64::INFINITY, f64::NEG_INFINITY),
            anchor: None,
            last: None,
            slopes: OPEN,
        }
    }

    /// The curve's next point; the point it makes the polyline keep, if any (the first
    /// point, or an earlier one the line to `p` would pass too far from a skipped one).
    pub fn push(&mut self, p: (i64, f64)) -> Option<(i64, f64)> {
        if !p.1.is_finite() {
            return None;
        }
        self.range = (self.range.0.min(p.1), self.range.1.max(p.1));
        match self.anchor {
            None => {
                self.anchor = Some(p);
                Some(p)
            }
            Some(anchor) => self.extend(anchor, p),
        }
    }

    /// The curve's last point, where it was not kept yet: the polyline's end.
    pub fn finish(&mut self) -> Option<(i64, f64)> {
        self.last.take()
    }

    /// Takes `p` as the line's new end if the line from the anchor to it passes every
    /// skipped point within ε; else keeps the old end, which becomes the anchor, and
    /// returns it.
    fn extend(&mut self, anchor: (i64, f64), p: (i64, f64)) -> Option<(i64, f64)> {
        let slope = |v: f64| (v - anchor.1) / (p.0 - anchor.0) as f64;
        let s = slope(p.1);
        if let Some(last) = self.last {
            if !(self.slopes.0 <= s && s <= self.slopes.1) {
                // The line to p would leave a skipped point: the last point is kept, and
                // the lines start again from it (with nothing skipped, p is the end).
                self.anchor = Some(last);
                self.slopes = OPEN;
                self.last = None;
                self.extend(last, p);
                return Some(last);
            }
        }
        // p is the line's end; skipped when a later point ends the line, so it binds the
        // slopes from then on.
        let eps = self.relative * (self.range.1 - self.range.0);
        self.slopes = (
            self.slopes.0.max(slope(p.1 - eps)),
            self.slopes.1.min(slope(p.1 + eps)),
        );
        self.last = Some(p);
        None
    }
}

/// A curve's points (in increasing time) thinned to the polyline within `relative` of its
/// range ([`Polyline`]).
pub fn thinned(
    points: impl Iterator<Item = (i64, f64)>,
    relative: f64,
) -> impl Iterator<Item = (i64, f64)> {
    let mut line = Polyline::new(relative);
    let mut points = points.fuse();
    std::iter::from_fn(move || {
        for p in points.by_ref() {
            if let Some(kept) = line.push(p) {
                return Some(kept);
            }
        }
        line.finish()
    })
}

/// How far the polyline through `drawn` passes from the curve's points at most, in units
/// of the tolerance [`CURVE_TOLERANCE`] · the curve's range (at most 1 where drawn as
/// [`Polyline`] draws); panics unless every drawn point is one of the curve's (its value
/// within `value_error`; 0: equal) and the curve's first and last are drawn.
#[cfg(test)]
pub(crate) fn departure_in_tolerances(
    curve: &[(i64, f64)],
    drawn: &[(i64, f64)],
    value_error: f64,
) -> f64 {
    let (Some(first), Some(last)) = (curve.first(), curve.last()) else {
        assert!(drawn.is_empty());
        return 0.0;
    };
    let same = |c: &(i64, f64), d: &(i64, f64)| c.0 == d.0 && (c.1 - d.1).abs() <= value_error;
    assert!(
        same(first, &drawn[0]) && same(last, &drawn[drawn.len() - 1]),
        "the curve's ends are not drawn"
    );
    let mut rest = curve.iter();
    assert!(
        drawn.iter().all(|d| rest.any(|c| same(c, d))),
        "a drawn point is not one of the curve's"
    );
    let (lo, hi) = curve
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &(_, v)| {
            (l.min(v), h.max(v))
        });
    let worst = curve
        .iter()
        .map(|&(t, v)| {
            let i = drawn.partition_point(|&(td, _)| td < t);
            let (t1, v1) = drawn[i];
            if t1 == t {
                return (v1 - v).abs();
            }
            let (t0, v0) = drawn[i - 1];
            (v0 + (v1 - v0) * (t - t0) as f64 / (t1 - t0) as f64 - v).abs()
        })
        .fold(0.0, f64::max);
    if hi > lo {
        worst / (CURVE_TOLERANCE * (hi - lo))
    } else {
        worst
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn thin(points: &[(i64, f64)], relative: f64) -> Vec<(i64, f64)> {
        thinned(points.iter().copied(), relative).collect()
    }

    /// The polyline through `kept` at time t (kept in increasing time, t within them).
    fn drawn_at(kept: &[(i64, f64)], t: i64) -> f64 {
        let i = kept.partition_point(|&(tk, _)| tk < t);
        let (t1, v1) = kept[i];
        if t1 == t {
            return v1;
        }
        let (t0, v0) = kept[i - 1];
        v0 + (v1 - v0) * (t - t0) as f64 / (t1 - t0) as f64
    }

    fn worst(points: &[(i64, f64)], kept: &[(i64, f64)]) -> f64 {
        points
            .iter()
            .map(|&(t, v)| (drawn_at(kept, t) - v).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_straight_line_is_its_two_ends() {
        let line: Vec<(i64, f64)> = (0..1000).map(|k| (k * 10, 3.0 + 0.25 * k as f64)).collect();
        assert_eq!(thin(&line, 1e-9), vec![line[0], line[999]]);
    }

    #[test]
    fn a_constant_is_its_two_ends_and_one_point_is_itself() {
        let flat: Vec<(i64, f64)> = (0..50).map(|k| (k, 7.0)).collect();
        assert_eq!(thin(&flat, 1e-5), vec![(0, 7.0), (49, 7.0)]);
        assert_eq!(thin(&[(5, 1.0)], 1e-5), vec![(5, 1.0)]);
        assert!(thin(&[], 1e-5).is_empty());
    }

    /// A corner: the two straight pieces' ends and the corner itself, nothing else.
    #[test]
    fn a_corner_keeps_the_corner() {
        let v: Vec<(i64, f64)> = (0..=200)
            .map(|k| (k, if k <= 100 { k as f64 } else { 200.0 - k as f64 }))
            .collect();
        assert_eq!(thin(&v, 1e-6), vec![(0, 0.0), (100, 100.0), (200, 0.0)]);
    }

    /// A first-order rise 1 − e^(−t/τ), worked by hand: a chord of length h where the
    /// curvature is v'' = e^(−t/τ)/τ² departs from the curve by about h²·v''/8, so within
    /// ε the chords are at most h = τ·√(8ε)·e^(t/2τ) long, and the ten time constants
    /// need about ∫ dt/h = 2(1 − e⁻⁵)/√(8ε) ≈ 222 of them at ε = 10⁻⁵ (of a range of
    /// about 1): a few hundred points of the million instants, every instant within ε.
    #[test]
    fn a_first_order_rise_is_drawn_within_the_tolerance() {
        let tau = 100_000.0;
        let rise: Vec<(i64, f64)> = (0..1_000_000)
            .map(|k| (k, 1.0 - (-(k as f64) / tau).exp()))
            .collect();
        let kept = thin(&rise, CURVE_TOLERANCE);
        let range = rise[999_999].1 - rise[0].1;
        assert!(worst(&rise, &kept) <= CURVE_TOLERANCE * range * (1.0 + 1e-9));
        assert!((200..1000).contains(&kept.len()), "{}", kept.len());
        assert_eq!((kept[0], kept[kept.len() - 1]), (rise[0], rise[999_999]));
    }

    /// Noise: every kept point is one of the series' own, in order, and every skipped
    /// instant lies within ε of the line; most of white noise's points must stay.
    #[test]
    fn noise_keeps_what_the_line_cannot_pass_within_the_tolerance() {
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let noise: Vec<(i64, f64)> = (0..20_000)
            .map(|k| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (
                    k * 1_000_000_000,
                    20.0 + (state >> 11) as f64 / (1u64 << 53) as f64,
                )
            })
            .collect();
        let kept = thin(&noise, 1e-3);
        let (lo, hi) = noise
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &(_, v)| {
                (l.min(v), h.max(v))
            });
        assert!(worst(&noise, &kept) <= 1e-3 * (hi - lo));
        assert!(kept.len() > 19_000, "{}", kept.len());
        let mut rest = noise.iter();
        assert!(kept.iter().all(|k| rest.any(|p| p == k)));
    }

    /// A gap (values not finite) is skipped as the plot skips it; the points either side
    /// are drawn joined, as they were before.
    #[test]
    fn values_that_are_not_finite_are_skipped() {
        let v = [
            (0, 0.0),
            (1, f64::NAN),
            (2, 2.0),
            (3, f64::INFINITY),
            (4, 4.0),
            (5, 9.0),
        ];
        assert_eq!(thin(&v, 1e-6), vec![(0, 0.0), (4, 4.0), (5, 9.0)]);
    }
}
