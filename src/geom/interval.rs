//! Closed intervals of field values, for conservative bounds over boxes.

/// A closed interval `[lo, hi]` of real values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// Lower bound.
    pub lo: f32,
    /// Upper bound.
    pub hi: f32,
}

impl Interval {
    /// The interval holding only zero: the field far from every support.
    pub const ZERO: Interval = Interval { lo: 0.0, hi: 0.0 };

    /// An interval from its bounds.
    #[must_use]
    pub fn new(lo: f32, hi: f32) -> Self {
        Self { lo, hi }
    }

    /// The interval holding both `a` and `b`.
    #[must_use]
    pub fn hull(a: f32, b: f32) -> Self {
        Self::new(a.min(b), a.max(b))
    }

    /// True when `v` lies in the interval.
    #[must_use]
    pub fn contains(&self, v: f32) -> bool {
        self.lo <= v && v <= self.hi
    }

    /// The smallest interval holding both.
    #[must_use]
    pub fn join(self, o: Interval) -> Interval {
        Interval::new(self.lo.min(o.lo), self.hi.max(o.hi))
    }

    /// Interval of `max(a, b)`.
    #[must_use]
    pub fn max(self, o: Interval) -> Interval {
        Interval::new(self.lo.max(o.lo), self.hi.max(o.hi))
    }

    /// Interval of `min(a, b)`.
    #[must_use]
    pub fn min(self, o: Interval) -> Interval {
        Interval::new(self.lo.min(o.lo), self.hi.min(o.hi))
    }

    /// Interval of `c - a` for a constant `c`.
    #[must_use]
    pub fn subtracted_from(self, c: f32) -> Interval {
        Interval::new(c - self.hi, c - self.lo)
    }

    /// Interval of `a * s` for a scalar `s` of either sign.
    #[must_use]
    pub fn scaled(self, s: f32) -> Interval {
        Interval::hull(self.lo * s, self.hi * s)
    }
}

impl std::ops::Add for Interval {
    type Output = Interval;

    /// Interval sum.
    fn add(self, o: Interval) -> Interval {
        Interval::new(self.lo + o.lo, self.hi + o.hi)
    }
}
