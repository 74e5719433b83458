//! Compact binary tables: the format of the precomputed tables under
//! `src/tables/` (loaded with `include_bytes!` and decoded at compile time
//! into `static` arrays: no file I/O, no heap, no lazy initialisation).
//!
//! Layout (little-endian): the 8-byte magic `MSBSDFT1`; a `u32` `L`, the
//! length in bytes of the header text; a `u32` `N`, the number of values;
//! `L` bytes of UTF-8 text (what the table is, its index order and shape,
//! the generating command, seeds, sample counts and commit), padded with
//! newlines so that the values start at a multiple of 4; then `N` IEEE
//! `f32` values in the table's index order.
//!
//! Some tables are decoded into 16-bit values ([`Q16`], [`decode5_q16`])
//! instead of `f32`: half the bytes in the library for an absolute
//! rounding error of at most half a step ([`Q16::STEP`]).

/// Magic bytes at the start of every table file.
pub const MAGIC: [u8; 8] = *b"MSBSDFT1";

/// `u32` at byte `o` (little-endian).
const fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

/// Byte offset of the values and their number; fails (at compile time when
/// used in a constant) on a wrong magic or a truncated file.
pub const fn layout(b: &[u8]) -> (usize, usize) {
    assert!(b.len() >= 16, "table file too short");
    let mut i = 0;
    while i < 8 {
        assert!(b[i] == MAGIC[i], "not an msbsdf table file");
        i += 1;
    }
    let text = u32_at(b, 8) as usize;
    let n = u32_at(b, 12) as usize;
    let data = 16 + text;
    assert!(data.is_multiple_of(4), "table values are not aligned");
    assert!(
        b.len() == data + 4 * n,
        "table file length disagrees with its header"
    );
    (data, n)
}

/// The header text of a table file.
pub const fn header_text(b: &[u8]) -> &str {
    let (data, _) = layout(b);
    let (head, _) = b.split_at(data);
    let (_, text) = head.split_at(16);
    match std::str::from_utf8(text) {
        Ok(s) => s,
        Err(_) => panic!("table header is not UTF-8"),
    }
}

/// Value `i` of a table file whose values start at byte `data`.
pub const fn f32_at(b: &[u8], data: usize, i: usize) -> f32 {
    let o = data + 4 * i;
    f32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

/// Decodes a table file of exactly `N` values (compile time).
pub const fn decode<const N: usize>(b: &[u8]) -> [f32; N] {
    let (data, n) = layout(b);
    assert!(n == N, "table size disagrees with its declared shape");
    let mut out = [0.0f32; N];
    let mut i = 0;
    while i < N {
        out[i] = f32_at(b, data, i);
        i += 1;
    }
    out
}

/// Encodes `values` with the header `text` (for the table generators).
pub fn encode(text: &str, values: &[f32]) -> Vec<u8> {
    let mut text = text.as_bytes().to_vec();
    while !(16 + text.len()).is_multiple_of(4) {
        text.push(b'\n');
    }
    let mut out = Vec::with_capacity(16 + text.len() + 4 * values.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(&(values.len() as u32).to_le_bytes());
    out.extend_from_slice(&text);
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// Decodes a table file as a `[A][B]` array (compile time).
pub const fn decode2<const A: usize, const B: usize>(b: &[u8]) -> [[f32; B]; A] {
    let (data, n) = layout(b);
    assert!(n == A * B, "table size disagrees with its declared shape");
    let mut out = [[0.0f32; B]; A];
    let mut i = 0;
    while i < n {
        out[i / B][i % B] = f32_at(b, data, i);
        i += 1;
    }
    out
}

/// Decodes a table file as a `[A][B][C]` array (compile time).
pub const fn decode3<const A: usize, const B: usize, const C: usize>(
    b: &[u8],
) -> [[[f32; C]; B]; A] {
    let (data, n) = layout(b);
    assert!(
        n == A * B * C,
        "table size disagrees with its declared shape"
    );
    let mut out = [[[0.0f32; C]; B]; A];
    let mut i = 0;
    while i < n {
        out[i / (B * C)][i / C % B][i % C] = f32_at(b, data, i);
        i += 1;
    }
    out
}

/// Decodes a table file as a `[A][B][C][D]` array (compile time).
pub const fn decode4<const A: usize, const B: usize, const C: usize, const D: usize>(
    b: &[u8],
) -> [[[[f32; D]; C]; B]; A] {
    let (data, n) = layout(b);
    assert!(
        n == A * B * C * D,
        "table size disagrees with its declared shape"
    );
    let mut out = [[[[0.0f32; D]; C]; B]; A];
    let mut i = 0;
    while i < n {
        out[i / (B * C * D)][i / (C * D) % B][i / D % C][i % D] = f32_at(b, data, i);
        i += 1;
    }
    out
}

/// Full scale of the tables stored as [`Q16`]: the stored `u16` 65535 is
/// this value. The albedo tables held so are at most 1 in exact arithmetic
/// but their quadrature overshoots 1 slightly (largest values 1.000422 in
/// `CONDUCTOR_E_ANISO`, 1.000039 in `DIELECTRIC_E`); 1.01 covers that with
/// a margin of 24 times the overshoot, so no shipped value is clamped.
pub const Q16_SCALE: f32 = 1.01;

/// A table value in `[0, Q16_SCALE]` stored in 16 bits: the `u16` `v`
/// stands for `v * Q16_SCALE / 65535` ([`Q16::get`], the one decode rule).
/// The step is [`Q16::STEP`] (1.54e-5), so a value is stored with an
/// absolute rounding error of at most half of it, 7.71e-6, plus the f32
/// rounding of the decoding multiply (below 6.1e-8 of the value): at most
/// 7.8e-6 over `[0, Q16_SCALE]` (measured 7.75e-6 on the shipped tables).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(transparent)]
pub struct Q16(u16);

impl Q16 {
    /// Value of one unit of the stored `u16`: `Q16_SCALE / 65535`.
    pub const STEP: f32 = Q16_SCALE / 65535.0;

    /// The nearest stored value of `v`: `round(v / STEP)`, clamped to
    /// `[0, 65535]` (NaN to 0). Rounded in f64 against the f32 step
    /// [`Q16::get`] multiplies by, so `|get(quantize(v)) - v| <= STEP / 2`
    /// (plus the f32 rounding of the product) for `v` in range.
    pub const fn quantize(v: f32) -> Q16 {
        let x = v as f64 / Self::STEP as f64;
        // NaN fails both comparisons and goes to 0.
        let x = if x > 0.0 { x } else { 0.0 };
        let x = if x < 65535.0 { x } else { 65535.0 };
        // x + 0.5 is exact in f64 and x >= 0: truncation rounds half up.
        Q16((x + 0.5) as u16)
    }

    /// The stored `u16`.
    pub const fn raw(self) -> u16 {
        self.0
    }

    /// The value: the stored `u16` times [`Q16::STEP`] (one multiply).
    #[inline]
    pub const fn get(self) -> f32 {
        Self::from_units(self.units())
    }

    /// The stored `u16` as an f32, in units of [`Q16::STEP`]: what an
    /// interpolation (linear in the values) combines before one
    /// [`Q16::from_units`] of its result (exact: every `u16` is an f32).
    #[inline]
    pub const fn units(self) -> f32 {
        self.0 as f32
    }

    /// A value in units of [`Q16::STEP`] (a stored `u16`, or a linear
    /// interpolation of some) as the table value: times the step.
    #[inline]
    pub const fn from_units(u: f32) -> f32 {
        u * Self::STEP
    }
}

/// Decodes a table file of exactly `N` values in `[0, unit Q16_SCALE]` as
/// [`Q16`] of `value / unit` (compile time): the value is `unit` times
/// [`Q16::get`], to an absolute error of `unit` times half a step.
pub const fn decode_q16<const N: usize>(b: &[u8], unit: f32) -> [Q16; N] {
    let (data, n) = layout(b);
    assert!(n == N, "table size disagrees with its declared shape");
    let mut out = [Q16(0); N];
    let mut i = 0;
    while i < N {
        out[i] = Q16::quantize(f32_at(b, data, i) / unit);
        i += 1;
    }
    out
}

/// Decodes a table file as a `[A][B][C][D]` array of [`Q16`] (compile
/// time): each f32 value rounded to the nearest step ([`Q16::quantize`]).
pub const fn decode4_q16<const A: usize, const B: usize, const C: usize, const D: usize>(
    b: &[u8],
) -> [[[[Q16; D]; C]; B]; A] {
    let (data, n) = layout(b);
    assert!(
        n == A * B * C * D,
        "table size disagrees with its declared shape"
    );
    let mut out = [[[[Q16(0); D]; C]; B]; A];
    let mut i = 0;
    while i < n {
        out[i / (B * C * D)][i / (C * D) % B][i / D % C][i % D] = Q16::quantize(f32_at(b, data, i));
        i += 1;
    }
    out
}

/// Decodes a table file as a `[A][B][C][D][E]` array of [`Q16`] (compile
/// time): each f32 value rounded to the nearest step ([`Q16::quantize`]).
#[allow(clippy::type_complexity)]
pub const fn decode5_q16<
    const A: usize,
    const B: usize,
    const C: usize,
    const D: usize,
    const E: usize,
>(
    b: &[u8],
) -> [[[[[Q16; E]; D]; C]; B]; A] {
    let (data, n) = layout(b);
    assert!(
        n == A * B * C * D * E,
        "table size disagrees with its declared shape"
    );
    let mut out = [[[[[Q16(0); E]; D]; C]; B]; A];
    let mut i = 0;
    while i < n {
        out[i / (B * C * D * E)][i / (C * D * E) % B][i / (D * E) % C][i / E % D][i % E] =
            Q16::quantize(f32_at(b, data, i));
        i += 1;
    }
    out
}

/// Test helper: the worst `|unit q.get() - v|` over a table file's values
/// `v` and their [`Q16`] copies `q` (as [`decode_q16`] stores them with
/// `unit`), after checking the count and that every value is within the
/// stored range `[0, unit Q16_SCALE]` (none clamped).
#[cfg(test)]
pub(crate) fn q16_file_error(name: &str, file: &[u8], q: &[Q16], unit: f32) -> f64 {
    let (data, n) = layout(file);
    assert_eq!(n, q.len(), "{name}");
    let mut worst = 0.0f64;
    for (i, q) in q.iter().enumerate() {
        let v = f32_at(file, data, i) as f64;
        assert!(
            (0.0..=(unit * Q16_SCALE) as f64).contains(&v),
            "{name}[{i}] = {v}"
        );
        worst = worst.max((q.get() as f64 * unit as f64 - v).abs());
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multiple::compensation_aniso_tables as an;
    use crate::multiple::compensation_tables as t;

    #[test]
    fn q16_rounds_to_the_nearest_step_and_clamps() {
        assert_eq!(Q16::quantize(0.0).raw(), 0);
        assert_eq!(Q16::quantize(-0.5).raw(), 0);
        assert_eq!(Q16::quantize(f32::NAN).raw(), 0);
        assert_eq!(Q16::quantize(Q16_SCALE).raw(), 65535);
        assert_eq!(Q16::quantize(2.0).raw(), 65535);
        assert_eq!(Q16::quantize(0.49 * Q16::STEP).raw(), 0);
        assert_eq!(Q16::quantize(0.51 * Q16::STEP).raw(), 1);
        for i in 0..=10_000 {
            let v = Q16_SCALE * i as f32 / 10_000.0;
            let d = (Q16::quantize(v).get() - v).abs();
            assert!(d <= 0.5 * Q16::STEP + 1e-7, "{v}: error {d}");
        }
    }

    /// Every value of the tables stored as [`Q16`] is its file's f32 to
    /// half a step (so none was clamped).
    #[test]
    fn q16_tables_hold_their_files_to_half_a_step() {
        let check = |name: &str, file: &[u8], q: &[Q16]| {
            let worst = q16_file_error(name, file, q, 1.0);
            println!("{name}: worst |stored - file| = {worst:.2e}");
            assert!(worst <= 0.5 * Q16::STEP as f64 + 1e-7, "{name}: {worst}");
        };
        check(
            "CONDUCTOR_E_ANISO",
            include_bytes!("../tables/conductor_e_aniso.bin"),
            an::CONDUCTOR_E_ANISO
                .as_flattened()
                .as_flattened()
                .as_flattened()
                .as_flattened(),
        );
        check(
            "CONDUCTOR_MS_TINT",
            include_bytes!("../tables/conductor_ms_tint.bin"),
            crate::multiple::compensation_ms_tables::CONDUCTOR_MS_TINT
                .as_flattened()
                .as_flattened()
                .as_flattened(),
        );
        check(
            "DIELECTRIC_E",
            include_bytes!("../tables/dielectric_e.bin"),
            t::DIELECTRIC_E
                .as_flattened()
                .as_flattened()
                .as_flattened()
                .as_flattened(),
        );
    }
}
