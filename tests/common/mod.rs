//! Shared test tools: deterministic quadrature over microfacet normals,
//! chi-square statistics, and small helpers. Included by each integration
//! test with `mod common;` (not every test uses every item).
#![allow(dead_code)]

use glam::{DVec3, Vec3};
use msbsdf::Rng;
use std::f64::consts::PI;

/// Gold, copper and aluminium complex IOR (RGB at ~650, 550, 450 nm).
pub const GOLD_ETA: [f32; 3] = [0.143, 0.374, 1.442];
/// Gold extinction.
pub const GOLD_K: [f32; 3] = [3.983, 2.385, 1.603];

/// Unit direction at polar angle `theta_deg` in the x-z plane.
pub fn dir_deg(theta_deg: f64) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin() as f32, 0.0, t.cos() as f32)
}

/// Unit direction at polar angle `theta_deg` and azimuth `phi_deg` (from
/// x towards y).
pub fn dir_deg_az(theta_deg: f64, phi_deg: f64) -> Vec3 {
    let d = dir_deg(theta_deg);
    let (s, c) = (phi_deg as f32).to_radians().sin_cos();
    Vec3::new(d.x * c, d.x * s, d.z)
}

/// Maps the unit square onto microfacet normals with the anisotropic GGX
/// distribution of normals (density `D_ggx(h) h.z` per solid angle). Returns
/// the normal and that density. Used to turn integrals over normals into
/// integrals over the square that stay smooth for very low roughness.
pub fn ggx_warp(ax: f64, ay: f64, u: f64, v: f64) -> (DVec3, f64) {
    let phi = 2.0 * PI * v;
    let t = (u / (1.0 - u)).sqrt(); // tan(theta) in the stretched space
    let (sx, sy) = (ax * t * phi.cos(), ay * t * phi.sin());
    let h = DVec3::new(-sx, -sy, 1.0).normalize();
    // D_ggx(h) h.z
    let tt = (h.x / ax).powi(2) + (h.y / ay).powi(2) + h.z * h.z;
    let d = 1.0 / (PI * ax * ay * tt * tt);
    (h, d * h.z)
}

/// Inverse of [`ggx_warp`]: the square coordinates of the normal `h` (h.z > 0).
pub fn ggx_unwarp(ax: f64, ay: f64, h: DVec3) -> (f64, f64) {
    let (sx, sy) = (-h.x / h.z / ax, -h.y / h.z / ay);
    let t2 = sx * sx + sy * sy;
    let u = t2 / (1.0 + t2);
    let mut v = sy.atan2(sx) / (2.0 * PI);
    if v < 0.0 {
        v += 1.0;
    }
    (u.clamp(0.0, 1.0 - 1e-15), v.clamp(0.0, 1.0 - 1e-15))
}

/// [`ggx_warp`] composed with `u = 1 - (1 - s)^4`, which crowds the square's
/// points towards the heavy tail of large slopes (grazing views at low
/// roughness). Returns the normal and its density per unit square area.
pub fn tail_warp(ax: f64, ay: f64, s: f64, v: f64) -> (DVec3, f64) {
    let u = 1.0 - (1.0 - s).powi(4);
    let du_ds = 4.0 * (1.0 - s).powi(3);
    let (h, p) = ggx_warp(ax, ay, u, v);
    (h, p / du_ds)
}

/// Inverse of [`tail_warp`].
pub fn tail_unwarp(ax: f64, ay: f64, h: DVec3) -> (f64, f64) {
    let (u, v) = ggx_unwarp(ax, ay, h);
    let s = 1.0 - (1.0 - u).powf(0.25);
    (s.clamp(0.0, 1.0 - 1e-15), v)
}

/// Outgoing direction for normal `h` (reflection or refraction with relative
/// index `eta`) and `d omega_o / d omega_h`.
pub fn outgoing(wi: Vec3, h: Vec3, eta: f32, transmit: bool) -> Option<(Vec3, f64)> {
    let ci = wi.dot(h);
    if ci <= 0.0 {
        return None;
    }
    if !transmit {
        let wo = msbsdf::frame::reflect(wi, h);
        (wo.z > 0.0).then_some((wo, 4.0 * ci as f64))
    } else {
        let wo = msbsdf::frame::refract(wi, h, eta)?;
        if wo.z >= 0.0 {
            return None;
        }
        let co = wo.dot(h) as f64;
        let denom = ci as f64 + eta as f64 * co;
        Some((wo, denom * denom / ((eta * eta) as f64 * co.abs())))
    }
}

/// Square coordinates of the normal that maps wi to wo, and which lobe.
pub fn normal_of(wi: Vec3, wo: Vec3, eta: f32) -> Option<(DVec3, bool)> {
    if wo.z > 0.0 {
        Some(((wi + wo).normalize().as_dvec3(), false))
    } else {
        let mut h = -(wi + eta * wo).normalize();
        if h.z < 0.0 {
            h = -h;
        }
        h.is_finite().then_some((h.as_dvec3(), true))
    }
}

/// Chi-square test of `sample` against `pdf` for `wi` (upper hemisphere):
/// samples are binned by the microfacet normal that maps `wi` to them (the
/// half vector, or the generalised one for refraction with relative index
/// `transmission_eta`), in `tail_warp` coordinates of roughness (ax, ay), so
/// narrow lobes spread over many cells. Also asserts, per sample, that
/// `pdf() > 0`, that `sample`'s pdf equals `pdf()` and its weight `eval / pdf`
/// (deterministic models), and that the pdf integrates to at most 1.
pub fn chi2_sample_vs_pdf(
    m: &msbsdf::Material,
    wi: Vec3,
    ax: f32,
    ay: f32,
    transmission_eta: Option<f32>,
    n: usize,
    seed: u64,
) -> Chi2 {
    let eta = transmission_eta.unwrap_or(1.0);
    let dielectric = transmission_eta.is_some();
    let (ns, nv) = (20usize, 40usize);
    let mut rng = Rng::new(seed, 9);
    let cells = ns * nv;
    let mut observed = vec![0.0; 2 * cells];
    let mut eval_rng = Rng::new(0, 0);
    for _ in 0..n {
        let s = m.sample(wi, &mut rng);
        if s.flags == msbsdf::SAMPLE_ABSORBED {
            continue;
        }
        // The pdf sample reports is the one pdf() gives, and
        // weight = eval / pdf.
        let p = m.pdf(wi, s.wo);
        assert!(p > 0.0, "sample went where pdf is 0: {:?}", s);
        // sample() uses the sampled normal, pdf() the half vector
        // recomputed from wo in f32: near the refraction peak
        // (wi.h + eta wo.h)^2 cancels, so allow 5e-3.
        assert!((s.pdf - p).abs() <= 5e-3 * p, "pdf {} vs {p}", s.pdf);
        let f = m.eval(wi, s.wo, &mut eval_rng);
        assert!(
            (f.x / p - s.weight.x).abs() <= 5e-3 * s.weight.x.max(1e-3),
            "weight {} vs eval/pdf {}",
            s.weight.x,
            f.x / p
        );
        let (h, tr) = normal_of(wi, s.wo, eta).expect("normal");
        let (u, v) = tail_unwarp(ax as f64, ay as f64, h);
        let c =
            ((u * ns as f64) as usize).min(ns - 1) * nv + ((v * nv as f64) as usize).min(nv - 1);
        observed[c + if tr { cells } else { 0 }] += 1.0;
    }
    let mut expected = vec![0.0; 2 * cells];
    let sub0 = 6;
    let mut total = 0.0;
    for lobe in 0..2 {
        if lobe == 1 && !dielectric {
            continue;
        }
        for i in 0..ns {
            for j in 0..nv {
                // Cells cut by the horizon (wo.z = 0, where the pdf
                // jumps to 0; it may cut a sliver missed by every
                // point) or where the pdf varies steeply (the onset of
                // total internal reflection) get a 4x finer quadrature.
                let (mut acc, mut sub) = (0.0, sub0);
                for pass in 0..2 {
                    acc = 0.0;
                    let mut valid = 0usize;
                    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
                    for a in 0..sub {
                        for b in 0..sub {
                            let s = (i as f64 + (a as f64 + 0.5) / sub as f64) / ns as f64;
                            let v = (j as f64 + (b as f64 + 0.5) / sub as f64) / nv as f64;
                            let (h, ph) = tail_warp(ax as f64, ay as f64, s, v);
                            if let Some((wo, jac)) = outgoing(wi, h.as_vec3(), eta, lobe == 1) {
                                let x = m.pdf(wi, wo) as f64 * jac / ph;
                                acc += x;
                                valid += 1;
                                (lo, hi) = (lo.min(x), hi.max(x));
                            }
                        }
                    }
                    if pass == 0 && (valid < sub * sub || hi > 1.5 * lo) {
                        sub *= 4;
                    } else {
                        break;
                    }
                }
                let e = acc / (sub * sub * cells) as f64;
                total += e;
                expected[lobe * cells + i * nv + j] = e * n as f64;
            }
        }
    }
    assert!(total <= 1.0 + 2e-3, "pdf integrates to {total} > 1");
    chi2_test(&observed, &expected, 5.0)
}

/// Upper regularised incomplete gamma Q(a, x).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let gln = msbsdf::math::ln_gamma(a);
    if x < a + 1.0 {
        // Series for P.
        let mut sum = 1.0 / a;
        let mut del = sum;
        let mut ap = a;
        for _ in 0..10_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - gln).exp()
    } else {
        // Continued fraction for Q (modified Lentz).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (-x + a * x.ln() - gln).exp() * h
    }
}

/// Result of a chi-square test.
#[derive(Debug, Clone, Copy)]
pub struct Chi2 {
    /// The statistic.
    pub chi2: f64,
    /// Degrees of freedom (pooled cells minus one).
    pub dof: usize,
    /// p-value.
    pub p: f64,
}

/// Pearson chi-square of observed against expected counts, pooling cells
/// whose expectation is below `min_expected` (pbrt-v4's procedure). Cells
/// whose quadrature gave zero expectation join the pool (a cell may be
/// partly inside the support with all its quadrature points outside); tests
/// check separately that every sample has a positive pdf.
pub fn chi2_test(observed: &[f64], expected: &[f64], min_expected: f64) -> Chi2 {
    let mut idx: Vec<usize> = (0..expected.len()).collect();
    idx.sort_by(|&a, &b| expected[a].partial_cmp(&expected[b]).unwrap());
    let (mut pooled_o, mut pooled_e, mut pooled_n) = (0.0, 0.0, 0usize);
    let (mut chi2, mut cells) = (0.0, 0usize);
    for &i in &idx {
        // Low cells join the pool; so does the next cell while the pool is
        // itself still below the threshold.
        if expected[i] < min_expected || (pooled_n > 0 && pooled_e < min_expected) {
            pooled_o += observed[i];
            pooled_e += expected[i];
            pooled_n += 1;
        } else {
            let d = observed[i] - expected[i];
            chi2 += d * d / expected[i];
            cells += 1;
        }
    }
    if pooled_n > 0 {
        let d = pooled_o - pooled_e;
        chi2 += d * d / pooled_e;
        cells += 1;
    }
    let dof = cells.saturating_sub(1).max(1);
    Chi2 {
        chi2,
        dof,
        p: gamma_q(dof as f64 / 2.0, chi2 / 2.0),
    }
}

/// Significance for one of `n` tests so that the family has level `alpha`
/// (Sidak correction).
pub fn sidak(alpha: f64, n: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / n as f64)
}

/// Mean and standard error of a sequence.
pub fn mean_and_error(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut n, mut s, mut s2) = (0.0, 0.0, 0.0);
    for v in values {
        n += 1.0;
        s += v;
        s2 += v * v;
    }
    let mean = s / n;
    let var = (s2 / n - mean * mean).max(0.0) * n / (n - 1.0);
    (mean, (var / n).sqrt())
}

#[test]
fn gamma_q_known_values() {
    // Q(1, x) = exp(-x); chi2 with 2 dof at 5.991 has p = 0.05.
    assert!((gamma_q(1.0, 2.0) - (-2.0f64).exp()).abs() < 1e-12);
    assert!((gamma_q(1.0, 5.991 / 2.0) - 0.05).abs() < 1e-4);
    // chi2 with 10 dof at 18.307 has p = 0.05.
    assert!((gamma_q(5.0, 18.307 / 2.0) - 0.05).abs() < 1e-4);
}

#[test]
fn warp_roundtrip() {
    for &(u, v) in &[(0.1, 0.2), (0.5, 0.9), (0.99, 0.01)] {
        let (h, _) = ggx_warp(0.3, 0.7, u, v);
        let (u2, v2) = ggx_unwarp(0.3, 0.7, h);
        assert!((u - u2).abs() < 1e-9 && (v - v2).abs() < 1e-9);
    }
}

/// Relative RMS error `sqrt(sum (f - ref)^2 / sum ref^2)` of `Material::eval`
/// per suite material of `class` (`"conductor"` or `"dielectric"`) against
/// `data/reference_values.csv` (converged HEITZ walks, the speed-accuracy
/// harness's measure): `(name, description, error)` in file order. `desc_of`
/// builds a material's description from a row (`num(column)` reads a numeric
/// column) and its NDF.
pub fn suite_errors(
    class: &str,
    desc_of: impl Fn(&dyn Fn(&str) -> f32, msbsdf::NdfId) -> msbsdf::MaterialDesc,
) -> Vec<(String, msbsdf::MaterialDesc, f64)> {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/reference_values.csv"
    ))
    .expect("reference values");
    let mut header: Vec<&str> = Vec::new();
    let mut mats: Vec<(String, msbsdf::MaterialDesc, f64, f64)> = Vec::new();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        if header.is_empty() {
            header = line.split(',').collect();
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        let col = |name: &str| f[header.iter().position(|h| *h == name).expect("column")];
        let num = |name: &str| col(name).parse::<f32>().expect("number");
        if col("class") != class {
            continue;
        }
        let ndf = if col("ndf") == "ggx" {
            msbsdf::NdfId::Ggx
        } else {
            msbsdf::NdfId::Beckmann
        };
        let name = col("material").to_string();
        if mats.last().map(|m| &m.0) != Some(&name) {
            mats.push((name, desc_of(&num, ndf), 0.0, 0.0));
        }
        let m = msbsdf::Material::new(&mats.last().expect("material").1).expect("valid");
        let wi = Vec3::new(num("wi_x"), num("wi_y"), num("wi_z"));
        let wo = Vec3::new(num("wo_x"), num("wo_y"), num("wo_z"));
        let v = m.eval(wi, wo, &mut Rng::new(0, 0));
        let last = mats.last_mut().expect("material");
        for (c, r) in ["ref_r", "ref_g", "ref_b"].iter().enumerate() {
            let r = num(r) as f64;
            last.2 += (v[c] as f64 - r).powi(2);
            last.3 += r * r;
        }
    }
    mats.into_iter()
        .map(|(name, d, num, den)| (name, d, (num / den).sqrt()))
        .collect()
}

/// `Q_xy / (2 pi H_y)` of the tabulated tier's peaked part at exit node `y`
/// (`norm` the hat moment normalisation), estimated by `n` samples of the
/// single-scattering model `single` (SINGLE with F = 1) from `wi`: each sample's `f_ss1 / pdf`
/// projected onto the exit hats. Returns the mean and the variance of the
/// mean.
pub fn peak_projection(
    single: &impl msbsdf::bsdf::ScatterModel,
    wi: Vec3,
    y: usize,
    norm: f64,
    n: u64,
    rng: &mut Rng,
) -> (f64, f64) {
    use msbsdf::multiple::tabulated::{MU_N, project_exit};
    let (mut q1, mut q2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let smp = single.sample(wi, rng);
        let mut mom = [[0.0f64; 1]; MU_N];
        if smp.wo.z > 0.0 && smp.pdf > 0.0 {
            let ss1 = single.eval(wi, smp.wo, rng).x as f64;
            project_exit(smp.wo, ss1 / smp.pdf as f64, &mut mom);
        }
        let v = mom[y][0] / norm;
        q1 += v;
        q2 += v * v;
    }
    let q = q1 / n as f64;
    (q, (q2 / n as f64 - q * q) / n as f64)
}
