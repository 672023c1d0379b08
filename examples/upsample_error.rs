//! How well RGB reflectances survive spectral upsampling: each colour of a 41^3 grid over the
//! sRGB cube and 20,000 random ones (a fixed seed) upsampled to a smooth spectrum (Jakob and
//! Hanika 2019), lit by the display's white (D65), seen by the CIE 1931 observer and compared
//! with itself in CIELAB.
//!
//! `cargo run --release --example upsample_error`
//!
//! Prints the mean and the largest Delta E, how many colours come back beyond 1 (about a
//! just-noticeable difference), and the worst ten.

use coherent::spectrum::upsample::{round_trip, table_resolution};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

fn main() {
    const N: usize = 41;
    let grid = (0..N * N * N).map(|k| [k % N, k / N % N, k / (N * N)].map(|i| i as f32 / 40.0));
    let mut rng = StdRng::seed_from_u64(2019);
    let random: Vec<[f32; 3]> = (0..20_000)
        .map(|_| [rng.random(), rng.random(), rng.random()])
        .collect();
    let mut errors: Vec<(f64, [f32; 3], [f32; 3])> = grid
        .chain(random)
        .map(|rgb| {
            let (de, back) = round_trip(rgb);
            (de, rgb, back)
        })
        .collect();
    let n = errors.len();
    let mean = errors.iter().map(|e| e.0).sum::<f64>() / n as f64;
    errors.sort_by(|a, b| b.0.total_cmp(&a.0));
    let over = errors.iter().filter(|e| e.0 > 1.0).count();
    println!(
        "table resolution {}: {n} colours, mean Delta E {mean:.3}, largest {:.2}, {over} beyond 1",
        table_resolution(),
        errors[0].0
    );
    for (de, rgb, back) in errors.iter().take(10) {
        println!("  Delta E {de:.2}: {rgb:?} back as {back:?}");
    }
}
