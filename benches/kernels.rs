//! Criterion benches of the approximation kernels (paper section 6.1's exp/log/pow and the
//! testbed's acos/atan2) on every backend usable here:
//! `cargo bench --bench kernels`. Throughput is in values per second; compare backends
//! within one run.

use coherent::kernels::{ApproxKernel, approx_inputs};
use coherent::simd::Backend;
use coherent::simd::approx::Approx;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn kernels(c: &mut Criterion) {
    for f in Approx::ALL {
        let (a, b) = approx_inputs(f, 16 * 1024);
        let mut out = vec![0.0; a.len()];
        let mut group = c.benchmark_group(f.name());
        group.throughput(Throughput::Elements(a.len() as u64));
        for backend in Backend::available() {
            group.bench_function(backend.name(), |bench| {
                bench.iter(|| {
                    backend
                        .run(ApproxKernel {
                            f,
                            a: &a,
                            b: &b,
                            out: &mut out,
                        })
                        .expect("available backend")
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, kernels);
criterion_main!(benches);
