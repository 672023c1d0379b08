//! The mutations: byte flips, truncations, duplicated and deleted lines, numbers swapped for
//! extremes (text numbers, and binary words where headers keep their counts), spans copied
//! and deleted, and lines spliced in from another seed of the same parser. Case `i` of a run
//! draws from its own generator seeded by (run seed, parser, `i`), so any case can be rebuilt
//! from those three numbers, without running the cases before it.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Numbers a text field is swapped for: not numbers, infinities, past `f32`, negative,
/// zero, and counts past `u32`/`i32`/`usize` or just big enough to allocate too much.
const TEXT_EXTREMES: &[&str] = &[
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e39",
    "-1e39",
    "1e400",
    "-1",
    "0",
    "-0",
    "1",
    "0.5",
    "1e-45",
    "65536",
    "16777217",
    "2147483648",
    "-2147483649",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "99999999999999999999",
    "1e308",
];

/// Words a binary field is swapped for (written as 2, 4 or 8 bytes, either byte order).
const WORD_EXTREMES: &[u64] = &[
    0,
    1,
    2,
    0xFF,
    0x7FFF,
    0x8000,
    0xFFFF,
    0x1_0000,
    0x100_0000,
    0x7FFF_FFFF,
    0x8000_0000,
    0xFFFF_FFFE,
    0xFFFF_FFFF,
    0x1_0000_0000,
    u64::MAX,
    0x7FC0_0000, // f32 NaN
    0x7F80_0000, // f32 inf
    0xFF80_0000, // f32 -inf
    0x7F7F_FFFF, // f32 MAX
    0xBF80_0000, // f32 -1
];

/// Bytes a single byte is set to: structure characters of the text formats and edges.
const BYTES: &[u8] = b"\0\x01\x7f\x80\xff\n\r\t -+.,#=[]{}\"'/\\09eE";

/// Case `i` of the run `seed` over `parser`'s seeds: the seed's index, the mutated bytes and
/// a line per mutation.
pub fn case(seeds: &[&[u8]], parser: &str, seed: u64, i: u64) -> (usize, Vec<u8>, Vec<String>) {
    let mut rng = StdRng::seed_from_u64(mix(seed, fnv(parser.as_bytes()), i));
    let which = rng.random_range(0..seeds.len());
    let mut bytes = seeds[which].to_vec();
    let mut done = Vec::new();
    // One to four mutations, fewer more often: one change at a time reaches a parser's
    // checks one by one; several reach what lies behind the first.
    let n = 1 + (rng.random_range(0..8u32)).trailing_zeros().min(3) as usize;
    for _ in 0..n {
        done.push(mutate(&mut bytes, &mut rng, seeds));
    }
    (which, bytes, done)
}

fn mix(seed: u64, parser: u64, i: u64) -> u64 {
    let mut x = seed ^ parser.rotate_left(21) ^ i.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    // splitmix64's finaliser, so that neighbouring cases share no low bits.
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// FNV-1a, 64 bits: the parser's part of a case's seed and a saved input's name.
pub fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Whether the bytes look like text (then line and number mutations are drawn more often).
fn is_text(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(512)];
    head.iter()
        .filter(|&&b| b < 0x20 && !b"\n\r\t".contains(&b))
        .count()
        == 0
}

fn mutate(bytes: &mut Vec<u8>, rng: &mut StdRng, seeds: &[&[u8]]) -> String {
    let text = is_text(bytes);
    // Weights: text favours numbers and lines, binary favours words and bytes.
    let weights: [u32; 10] = if text {
        [2, 2, 1, 3, 3, 6, 1, 2, 1, 1]
    } else {
        [3, 3, 1, 1, 1, 1, 6, 1, 1, 2]
    };
    let mut pick = rng.random_range(0..weights.iter().sum::<u32>());
    let mut kind = 0;
    while pick >= weights[kind] {
        pick -= weights[kind];
        kind += 1;
    }
    if bytes.is_empty() && kind != 8 && kind != 9 {
        kind = 9;
    }
    let len = bytes.len();
    match kind {
        0 => {
            let (at, bit) = (rng.random_range(0..len), rng.random_range(0..8));
            bytes[at] ^= 1 << bit;
            format!("flip bit {bit} of byte {at}")
        }
        1 => {
            let at = rng.random_range(0..len);
            let b = BYTES[rng.random_range(0..BYTES.len())];
            bytes[at] = b;
            format!("set byte {at} to {b:#04x}")
        }
        2 => {
            let to = rng.random_range(0..len);
            bytes.truncate(to);
            format!("truncate to {to} bytes")
        }
        3 | 4 => {
            let lines = line_spans(bytes);
            let (start, end) = lines[rng.random_range(0..lines.len())];
            if kind == 3 {
                let copy = bytes[start..end].to_vec();
                let times = if rng.random_range(0..4) == 0 { 16 } else { 1 };
                for _ in 0..times {
                    bytes.splice(end..end, copy.iter().copied());
                }
                format!("duplicate the line at byte {start} ({times}x)")
            } else {
                bytes.drain(start..end);
                format!("delete the line at byte {start}")
            }
        }
        5 => {
            let numbers = number_spans(bytes);
            if numbers.is_empty() {
                return mutate(bytes, rng, seeds);
            }
            let (start, end) = numbers[rng.random_range(0..numbers.len())];
            let x = TEXT_EXTREMES[rng.random_range(0..TEXT_EXTREMES.len())];
            let was = String::from_utf8_lossy(&bytes[start..end]).into_owned();
            bytes.splice(start..end, x.bytes());
            format!("number {was:?} at byte {start} -> {x}")
        }
        6 => {
            let size = [2usize, 4, 4, 4, 8][rng.random_range(0..5)];
            if len < size {
                return mutate(bytes, rng, seeds);
            }
            // Aligned half the time: the binary formats here keep their fields aligned.
            let mut at = rng.random_range(0..=len - size);
            if rng.random_range(0..2) == 0 {
                at -= at % size;
            }
            let w = WORD_EXTREMES[rng.random_range(0..WORD_EXTREMES.len())];
            let big = rng.random_range(0..4) == 0;
            let le = w.to_le_bytes();
            let be = w.to_be_bytes();
            if big {
                bytes[at..at + size].copy_from_slice(&be[8 - size..]);
            } else {
                bytes[at..at + size].copy_from_slice(&le[..size]);
            }
            format!(
                "word {w:#x} ({size} bytes, {}) at byte {at}",
                if big { "big-endian" } else { "little-endian" }
            )
        }
        7 => {
            let start = rng.random_range(0..len);
            let n = rng.random_range(1..=64.min(len - start));
            if rng.random_range(0..2) == 0 {
                bytes.drain(start..start + n);
                format!("delete {n} bytes at {start}")
            } else {
                let copy = bytes[start..start + n].to_vec();
                let to = rng.random_range(0..=bytes.len());
                bytes.splice(to..to, copy);
                format!("copy {n} bytes from {start} to {to}")
            }
        }
        8 => {
            // A line of another seed of the same parser, in place of one of these.
            let other = seeds[rng.random_range(0..seeds.len())];
            if other.is_empty() {
                return mutate(bytes, rng, seeds);
            }
            let theirs = line_spans(other);
            let (a, b) = theirs[rng.random_range(0..theirs.len())];
            if bytes.is_empty() {
                bytes.extend_from_slice(&other[a..b]);
                return format!("insert another seed's line ({} bytes)", b - a);
            }
            let ours = line_spans(bytes);
            let (s, e) = ours[rng.random_range(0..ours.len())];
            bytes.splice(s..e, other[a..b].iter().copied());
            format!("replace the line at byte {s} by another seed's line")
        }
        _ => {
            let at = rng.random_range(0..=len);
            let n = rng.random_range(1..=8);
            let junk: Vec<u8> = (0..n).map(|_| rng.random()).collect();
            bytes.splice(at..at, junk);
            format!("insert {n} random bytes at {at}")
        }
    }
}

/// (start, end) of every line, its newline included.
fn line_spans(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = 0;
    for (i, &b) in bytes.iter().enumerate() {
        if b == b'\n' {
            out.push((start, i + 1));
            start = i + 1;
        }
    }
    if start < bytes.len() || out.is_empty() {
        out.push((start, bytes.len()));
    }
    out
}

/// (start, end) of every number written in decimal: digits with an optional sign, point
/// and exponent, not part of a word.
fn number_spans(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let starts = bytes[i].is_ascii_digit()
            || (matches!(bytes[i], b'-' | b'+' | b'.')
                && bytes.get(i + 1).is_some_and(u8::is_ascii_digit));
        let in_word = i > 0 && (bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_');
        if starts && !in_word {
            let start = i;
            i += 1;
            while i < bytes.len()
                && (bytes[i].is_ascii_digit()
                    || bytes[i] == b'.'
                    || ((bytes[i] == b'e' || bytes[i] == b'E')
                        && bytes
                            .get(i + 1)
                            .is_some_and(|c| c.is_ascii_digit() || *c == b'-' || *c == b'+'))
                    || ((bytes[i] == b'-' || bytes[i] == b'+')
                        && matches!(bytes[i - 1], b'e' | b'E')))
            {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_found_and_words_skipped() {
        let s = b"v 1.5 -2 3e-4 x9 _7 .5";
        let n: Vec<&[u8]> = number_spans(s).iter().map(|&(a, b)| &s[a..b]).collect();
        assert_eq!(n, vec![&b"1.5"[..], b"-2", b"3e-4", b".5"]);
    }

    #[test]
    fn a_case_is_rebuilt_from_its_numbers() {
        let seeds: [&[u8]; 2] = [b"a 1\nb 2\n", b"\x00\x01\x02\x03\x04\x05\x06\x07"];
        for i in 0..50 {
            assert_eq!(case(&seeds, "p", 3, i), case(&seeds, "p", 3, i));
        }
    }
}
