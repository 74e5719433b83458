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

/// Decodes a table file as a `[A][B][C][D][E]` array (compile time).
#[allow(clippy::type_complexity)]
pub const fn decode5<
    const A: usize,
    const B: usize,
    const C: usize,
    const D: usize,
    const E: usize,
>(
    b: &[u8],
) -> [[[[[f32; E]; D]; C]; B]; A] {
    let (data, n) = layout(b);
    assert!(
        n == A * B * C * D * E,
        "table size disagrees with its declared shape"
    );
    let mut out = [[[[[0.0f32; E]; D]; C]; B]; A];
    let mut i = 0;
    while i < n {
        out[i / (B * C * D * E)][i / (C * D * E) % B][i / (D * E) % C][i / E % D][i % E] =
            f32_at(b, data, i);
        i += 1;
    }
    out
}
