//! Stable fallback for the `cargo fuzz` scene target (which needs nightly features): a fixed,
//! deterministic pseudo-random corpus of mutated shipped scenes (byte flips, truncations, key
//! swaps, numbers replaced by nan / inf / -1 / 1e308 / ...) through the very same check: parse
//! and validate, then build and step small accepted scenes 20 times, with no panic and every
//! position and velocity finite.

mod fuzz_support;

use fuzz_support::{check, Outcome};
use std::path::Path;

/// Inputs per run (on top of the shipped scenes themselves).
const MUTANTS: usize = 20_000;

struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        self.0 >> 33
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const KEYS: &[&str] = &[
    "dimensions",
    "dt",
    "steps",
    "gravity",
    "restitution",
    "min",
    "max",
    "walls",
    "kind",
    "cells",
    "velocity_iterations",
    "position_iterations",
    "retakes",
    "resting_speed",
    "sleep",
    "sleep_speed",
    "sleep_time",
    "point",
    "normal",
    "position",
    "velocity",
    "radius",
    "mass",
    "count",
    "speed",
    "seed",
    "arrangement",
];

const NUMBERS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "-0.0",
    "1e308",
    "-1e308",
    "1e-308",
    "5e-324",
    "1e154",
    "1e200",
    "3",
    "2",
    "1",
    "0.5",
    "9223372036854775807",
    "-9223372036854775808",
    "4294967296",
    "1e-30",
    "1e30",
    "[1e308, 1e308]",
    "[1e308, -1e308, 1e308]",
    "[0.0, 0.0]",
    "[nan, 1.0]",
];

/// Byte ranges of the numbers in `text`.
fn numbers(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let c = text[i];
        let starts =
            c.is_ascii_digit() || (c == b'-' && text.get(i + 1).is_some_and(u8::is_ascii_digit));
        if starts && (i == 0 || !text[i - 1].is_ascii_alphanumeric() && text[i - 1] != b'_') {
            let j = i
                + 1
                + text[i + 1..]
                    .iter()
                    .take_while(|b| {
                        b.is_ascii_digit() || matches!(b, b'.' | b'e' | b'E' | b'-' | b'+')
                    })
                    .count();
            out.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

fn mutate(rng: &mut Lcg, base: &[u8]) -> Vec<u8> {
    let mut s = base.to_vec();
    for _ in 0..1 + rng.below(3) {
        match rng.below(6) {
            0 if !s.is_empty() => {
                let i = rng.below(s.len());
                s[i] ^= 1 << rng.below(8);
            }
            1 => s.truncate(rng.below(s.len() + 1)),
            2 => {
                // a key renamed to another key
                let text = String::from_utf8_lossy(&s).into_owned();
                let (a, b) = (KEYS[rng.below(KEYS.len())], KEYS[rng.below(KEYS.len())]);
                s = text
                    .replacen(&format!("{a} ="), &format!("{b} ="), 1)
                    .into_bytes();
            }
            3 | 4 => {
                let spans = numbers(&s);
                if !spans.is_empty() {
                    let (i, j) = spans[rng.below(spans.len())];
                    let with = NUMBERS[rng.below(NUMBERS.len())].as_bytes();
                    s.splice(i..j, with.iter().copied());
                }
            }
            _ => {
                // a line duplicated or dropped
                let text = String::from_utf8_lossy(&s).into_owned();
                let mut lines: Vec<&str> = text.lines().collect();
                if !lines.is_empty() {
                    let i = rng.below(lines.len());
                    if rng.below(2) == 0 {
                        lines.insert(i, lines[i]);
                    } else {
                        lines.remove(i);
                    }
                }
                s = lines.join("\n").into_bytes();
            }
        }
    }
    s
}

/// `text` with at most `keep` `[[particles]]` tables (the rest dropped).
fn keep_particles(text: &str, keep: usize) -> Vec<String> {
    let (mut seen, mut dropping) = (0, false);
    let mut out = Vec::new();
    for line in text.lines() {
        let header = line.trim_start();
        if header.starts_with('[') {
            seen += (header == "[[particles]]") as usize;
            dropping = header == "[[particles]]" && seen > keep;
        }
        if !dropping {
            out.push(line.to_string());
        }
    }
    out
}

/// Shipped scenes, with big fills and long particle lists cut to at most 60 particles so that
/// mutants get stepped.
fn seeds() -> Vec<(String, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            let small: Vec<String> = keep_particles(&text, 60)
                .into_iter()
                .map(|l| match l.trim_start().strip_prefix("count = ") {
                    Some(n) if n.trim().parse::<u64>().is_ok_and(|n| n > 60) => {
                        "count = 60".to_string()
                    }
                    _ => l,
                })
                .collect();
            (p.display().to_string(), small.join("\n").into_bytes())
        })
        .collect();
    out.sort();
    out
}

#[test]
fn mutated_scenes_never_panic_or_go_non_finite() {
    let seeds = seeds();
    assert!(seeds.len() >= 10, "shipped scenes found: {}", seeds.len());
    let mut tally = std::collections::BTreeMap::<String, usize>::new();
    for (name, bytes) in &seeds {
        assert_eq!(check(bytes), Outcome::Stepped, "{name} (count cut to 60)");
    }
    let mut rng = Lcg(0x00c0_ffee);
    for n in 0..MUTANTS {
        let (name, base) = &seeds[rng.below(seeds.len())];
        let input = mutate(&mut rng, base);
        let outcome = std::panic::catch_unwind(|| check(&input)).unwrap_or_else(|_| {
            panic!(
                "mutant {n} of {name} panicked; input:\n{}",
                String::from_utf8_lossy(&input)
            )
        });
        *tally.entry(format!("{outcome:?}")).or_default() += 1;
    }
    eprintln!("fuzz corpus: {MUTANTS} mutants: {tally:?}");
    assert!(
        tally.get("Stepped").copied().unwrap_or(0) > MUTANTS / 10,
        "{tally:?}"
    );
}
