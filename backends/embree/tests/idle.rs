//! Embree leaves no thread busy between builds: with a device per scene, once two devices had
//! been alive at the same time, a TBB worker spun at 100% of a core (`sched_yield` in a loop)
//! for as long as any scene was alive, taking the second core of every single-thread timing.
//! Scenes now share the process's device ([`coherent_embree::Device::shared`]).
//!
//! Its own test binary, with one test: the check reads the whole process's CPU time, which
//! other tests running beside it would add to. Needs the library (`python3 scripts/native.py`,
//! which `scripts/test.sh` runs).

use std::time::{Duration, Instant};

use coherent_accel::{Accel, Mesh, Scene};
use coherent_embree::{Embree, EmbreeParams};
use glam::Vec3;

/// CPU seconds of this process so far (user + system, from `/proc/self/stat`).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").expect("reading /proc/self/stat");
    // Fields after the command name in parentheses: state is field 3, utime 14, stime 15.
    let rest = &stat[stat.rfind(')').expect("a /proc stat line") + 2..];
    let f: Vec<&str> = rest.split(' ').collect();
    let ticks = |i: usize| f[i].parse::<f64>().expect("a tick count");
    // SAFETY: sysconf has no preconditions.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
    (ticks(11) + ticks(12)) / hz
}

/// Share of one core the process used while this thread slept for `ms`.
fn idle_load(ms: u64) -> f64 {
    let (c0, w0) = (cpu_seconds(), Instant::now());
    std::thread::sleep(Duration::from_millis(ms));
    (cpu_seconds() - c0) / w0.elapsed().as_secs_f64()
}

#[test]
fn no_thread_spins_while_scenes_are_alive() {
    let (mut p, mut ix) = (Vec::new(), Vec::new());
    for i in 0..5_000u32 {
        let x = i as f32;
        p.extend([
            Vec3::new(x, 0.0, 0.0),
            Vec3::new(x + 1.0, 0.0, 0.0),
            Vec3::new(x, 1.0, 0.0),
        ]);
        ix.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let scene = Scene::single(Mesh::new("strip", p, ix));
    let params = EmbreeParams::default();
    let build = || <Embree as Accel>::build(&scene, &params).unwrap_or_else(|e| panic!("{e}"));
    // As the comparison's timed builds do: each build while the previous one is alive.
    let mut last = build();
    for _ in 0..3 {
        last = build();
    }
    let both = (build(), build());
    let load = idle_load(500);
    assert!(
        load < 0.3,
        "the process used {:.0}% of a core while idle with Embree scenes alive",
        load * 100.0
    );
    assert!(last.memory_bytes() > 0 && both.0.memory_bytes() > 0);
}
