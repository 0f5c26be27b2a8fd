//! A deterministic pseudo-random sequence: Marsaglia's xorshift64 (shifts 13, 7, 17). It
//! gives the sweep's probe vector (docs/design.md §3.1), the eigensolver's start vectors
//! (§3.6) and test data, the same bits on every machine and run.

/// The xorshift64 state; any nonzero seed.
pub(crate) struct Xorshift(u64);

impl Xorshift {
    /// The sequence from `seed` (a zero seed would stay zero: give a nonzero one).
    pub fn new(seed: u64) -> Self {
        Xorshift(seed)
    }

    /// The next value, uniform in [−½, ½) on a grid of 2⁻⁵³: the top 53 bits of the state.
    pub fn next_centred(&mut self) -> f64 {
        let s = &mut self.0;
        *s ^= *s << 13;
        *s ^= *s >> 7;
        *s ^= *s << 17;
        (*s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}
