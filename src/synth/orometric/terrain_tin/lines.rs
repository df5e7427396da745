//! The ridge and river segments of the line index: the distance and
//! elevation a cell reads from one, and whether two segments cross.

/// A ridge or river segment for the crest / channel bands, the noise fade
/// and the samples' clearance.
#[derive(Debug, Clone, Copy)]
pub(super) struct Line {
    pub(super) a: [f64; 3],
    pub(super) b: [f64; 3],
    pub(super) kind: LineKind,
    /// The tree saddle of a ridge segment's ridge (u32::MAX otherwise).
    pub(super) saddle: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum LineKind {
    /// Crest band (cells read at least the ridge).
    Ridge,
    /// Channel band (cells read at most the river).
    Channel,
}

impl Line {
    /// (distance, elevation at the projection) of (x, y).
    #[inline]
    pub(super) fn probe(&self, x: f64, y: f64) -> (f64, f64) {
        let (dx, dy) = (self.b[0] - self.a[0], self.b[1] - self.a[1]);
        let l2 = dx * dx + dy * dy;
        let t = if l2 > 0.0 {
            (((x - self.a[0]) * dx + (y - self.a[1]) * dy) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (px, py) = (self.a[0] + t * dx, self.a[1] + t * dy);
        (
            (x - px).hypot(y - py),
            self.a[2] + t * (self.b[2] - self.a[2]),
        )
    }
}

/// Whether segments p–q and a–b cross or touch.
pub(super) fn crosses(p: [f64; 2], q: [f64; 2], a: [f64; 2], b: [f64; 2]) -> bool {
    let side = |u: [f64; 2], v: [f64; 2], w: [f64; 2]| {
        ((v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0])).signum()
    };
    side(p, q, a) * side(p, q, b) <= 0.0 && side(a, b, p) * side(a, b, q) <= 0.0
}
