use glam::Vec3;
use msbsdf::multiple::null_scattering::{NullNdf, NullNdfKind};
use msbsdf::ndf::{Ndf, NdfKind};
fn cpu_ns() -> u128 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: valid pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as u128 * 1_000_000_000 + ts.tv_nsec as u128
}
fn main() {
    for kind in [NullNdfKind::Ggx, NullNdfKind::Vmf, NullNdfKind::Exponential] {
        let n = NullNdf::new(kind, 0.5, 0.5, 2.0).unwrap();
        let t0 = cpu_ns();
        let mut acc = 0.0;
        for i in 0..20000 {
            acc += n.sigma_quadrature(-0.9 + 1.8 * (i as f64 / 20000.0));
        }
        println!(
            "{kind:?} quadrature sigma: {:.0} ns ({acc:.3})",
            (cpu_ns() - t0) as f64 / 20000.0
        );
    }
    let g = Ndf::new(NdfKind::Ggx, 0.5, 0.5);
    let t0 = cpu_ns();
    let mut acc = 0.0;
    for i in 0..200000 {
        let u = -0.9 + 1.8 * (i as f32 / 200000.0);
        acc += g.sigma(Vec3::new((1.0 - u * u).sqrt(), 0.0, u));
    }
    println!(
        "GGX closed sigma: {:.0} ns ({acc:.3})",
        (cpu_ns() - t0) as f64 / 200000.0
    );
}
