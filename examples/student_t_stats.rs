//! Measurements behind the Student-T documentation (d'Eon 2023, section 2):
//! shape 60 versus Beckmann, gamma variates per visible-normal sample,
//! sampling cost versus GGX. Run with `cargo run --release --example student_t_stats`.

use glam::Vec3;
use msbsdf::Rng;
use msbsdf::ndf::{Ndf, NdfKind, student_t};

fn main() {
    println!(
        "shape 60 vs Beckmann: max relative error of D over theta_m <= T, of G1 = 1/(1+Lambda) over theta_v <= T"
    );
    for alpha in [0.1f32, 0.5, 1.0, 2.0, 4.0] {
        let st = Ndf::with_shape(NdfKind::StudentT, alpha, alpha, 60.0);
        let bk = Ndf::new(NdfKind::Beckmann, alpha, alpha);
        let mut line = format!("alpha {alpha:4}:");
        for tmax in [30.0f32, 45.0, 60.0, 70.0, 80.0, 89.0] {
            let (mut ed, mut el) = (0.0f64, 0.0f64);
            for i in 0..=200 {
                let t = (tmax * i as f32 / 200.0).to_radians();
                let m = Vec3::new(t.sin(), 0.0, t.cos());
                let (a, b) = (st.d(m) as f64, bk.d(m) as f64);
                if b > 0.0 {
                    ed = ed.max((a / b - 1.0).abs());
                }
                // Lambda compared through G1 = 1 / (1 + Lambda) (Lambda itself
                // is a tail quantity near the normal: its relative error there
                // is meaningless).
                let (a, b) = (st.g1(m) as f64, bk.g1(m) as f64);
                if b > 0.0 {
                    el = el.max((a / b - 1.0).abs());
                }
            }
            line += &format!("  T={tmax}: D {ed:.2e} L {el:.2e}");
        }
        println!("{line}");
    }

    println!("\ngamma variates per visible-normal sample (exact sampler)");
    let mut rng = Rng::new(1, 2);
    for g in [1.6f32, 2.0, 3.0, 4.0, 10.0] {
        let mut line = format!("gamma {g:4}:");
        for u in [0.95f32, 0.5, 0.1, -0.2, -0.6, -0.95] {
            let v = Vec3::new((1.0 - u * u).sqrt(), 0.0, u);
            let n = 100_000;
            let mut total = 0u64;
            for _ in 0..n {
                total += student_t::sample_visible_counted(1.0, 1.0, g, v, &mut rng).1 as u64;
            }
            line += &format!("  u={u}: {:.3}", total as f64 / n as f64);
        }
        println!("{line}");
    }
    // Average over down-welling directions uniform in projected solid angle
    // (u = sqrt(xi)), as in a single-scattering renderer.
    for g in [2.0f32, 3.0, 4.0] {
        let n = 200_000;
        let mut total = 0u64;
        for _ in 0..n {
            let u = rng.next_f32().sqrt().max(1e-3);
            let v = Vec3::new((1.0 - u * u).sqrt(), 0.0, u);
            total += student_t::sample_visible_counted(0.5, 0.5, g, v, &mut rng).1 as u64;
        }
        println!(
            "gamma {g}: cosine-weighted down-welling average {:.3} variates",
            total as f64 / n as f64
        );
    }

    println!("\nns per visible-normal sample (alpha 0.5)");
    let n = 400_000;
    for (name, ndf) in [
        ("GGX", Ndf::new(NdfKind::Ggx, 0.5, 0.5)),
        ("Beckmann", Ndf::new(NdfKind::Beckmann, 0.5, 0.5)),
        (
            "Student-T 2",
            Ndf::with_shape(NdfKind::StudentT, 0.5, 0.5, 2.0),
        ),
        (
            "Student-T 3",
            Ndf::with_shape(NdfKind::StudentT, 0.5, 0.5, 3.0),
        ),
    ] {
        for u in [0.7f32, -0.6] {
            let v = Vec3::new((1.0 - u * u).sqrt(), 0.0, u);
            let t0 = cpu_ns();
            let mut acc = 0.0f32;
            for _ in 0..n {
                acc += ndf.sample_visible(v, rng.next_f32(), rng.next_f32()).z;
            }
            let ns = (cpu_ns() - t0) as f64 / n as f64;
            println!("{name:12} u {u:5}: {ns:7.1} ns ({acc:.1})");
        }
    }
    for g in [2.0f32, 3.0] {
        let v = Vec3::new(0.8, 0.0, -0.6);
        let t0 = cpu_ns();
        let mut acc = 0.0f32;
        for _ in 0..n {
            acc += student_t::sample_visible_upwelling_approx(0.5, 0.5, g, v, &mut rng).z;
        }
        let ns = (cpu_ns() - t0) as f64 / n as f64;
        println!("Student-T {g} up-welling approx (eqs. 18-22) u -0.6: {ns:7.1} ns ({acc:.1})");
    }
}

/// Thread CPU time in nanoseconds (unaffected by other processes sharing the cores).
fn cpu_ns() -> u128 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec through a valid pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as u128 * 1_000_000_000 + ts.tv_nsec as u128
}
