//! A bracketed root of a scalar function by the Illinois-modified regula falsi: the one root
//! finder of event location and of the contact laws' series solve.

/// A bracket [a, b] with g(a) ≤ 0 < g(b) (or g(b) ≥ 0), narrowed by Illinois regula falsi.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bracket {
    /// Left end (g ≤ 0).
    pub a: f64,
    /// Right end (g > 0).
    pub b: f64,
    ga: f64,
    gb: f64,
    side: i8,
}

impl Bracket {
    /// The bracket [a, b] with g(a) = `ga` ≤ 0 and g(b) = `gb` > 0.
    pub fn new(a: f64, ga: f64, b: f64, gb: f64) -> Self {
        Self { a, b, ga, gb, side: 0 }
    }

    /// The regula-falsi point of the bracket (round-off may put it on an end).
    pub fn falsi(&self) -> f64 {
        (self.a * self.gb - self.b * self.ga) / (self.gb - self.ga)
    }

    /// The next point to evaluate: the regula-falsi point, or the midpoint when that falls outside
    /// the open bracket (round-off).
    pub fn next(&self) -> f64 {
        let c = self.falsi();
        if c > self.a && c < self.b { c } else { 0.5 * (self.a + self.b) }
    }

    /// Narrows the bracket with g(c) = `gc`; halves the stale end's value when the same end moved
    /// twice (Illinois), so that convergence stays superlinear.
    pub fn update(&mut self, c: f64, gc: f64) {
        if gc > 0.0 {
            self.b = c;
            self.gb = gc;
            if self.side == 1 {
                self.ga *= 0.5;
            }
            self.side = 1;
        } else {
            self.a = c;
            self.ga = gc;
            if self.side == -1 {
                self.gb *= 0.5;
            }
            self.side = -1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Bracket;

    #[test]
    fn the_bracket_closes_on_a_root() {
        let g = |x: f64| x * x * x - 2.0;
        let mut br = Bracket::new(0.0, g(0.0), 2.0, g(2.0));
        for _ in 0..60 {
            let c = br.next();
            br.update(c, g(c));
        }
        assert!((br.b - 2f64.cbrt()).abs() < 1e-14 && br.a <= br.b, "{br:?}");
    }
}
