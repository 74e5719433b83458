//! MSBSDF_MODEL_TABULATED with dielectric facets: white furnace from both
//! sides (eval quadrature and sample weights), sample against pdf
//! (chi-square), reflection reciprocity and the eta-weighted transmission
//! reciprocity, accuracy on the project suite, re-estimation of random table
//! cells with the library's walk, refusals, and a stability sweep.

mod common;
use common::*;
use glam::Vec3;
use msbsdf::facet::Facet;
use msbsdf::multiple::compensation::glass_albedo;
use msbsdf::multiple::heitz::Heitz;
use msbsdf::multiple::tabulated::{MU_N, grid_mu, hat_moment, project_exit};
use msbsdf::multiple::tabulated_dielectric::{
    self, PEAK, R_DENSE, R_THIN, T_THIN, dcorr_grid_eta, grid_alpha, grid_eta, lobe_index,
    lobe_norm, lobe_value,
};
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::single::{G2Form, Single};
use msbsdf::{Error, FacetKind, Material, MaterialDesc, Model, NdfId, Rng};
use std::f64::consts::PI;

const NDFS: [NdfId; 2] = [NdfId::Beckmann, NdfId::Ggx];

fn desc(model: Model, ndf: NdfId, ax: f32, ay: f32, eta: f32) -> MaterialDesc {
    MaterialDesc {
        model,
        ndf,
        facet: FacetKind::Dielectric,
        alpha_x: ax,
        alpha_y: ay,
        eta: Vec3::splat(eta),
        ..MaterialDesc::default()
    }
}

fn tab(ndf: NdfId, ax: f32, ay: f32, eta: f32) -> Material {
    Material::new(&desc(Model::Tabulated, ndf, ax, ay, eta)).expect("valid")
}

/// `wi` at `theta` degrees on the outside (`side = 1`) or inside (`-1`).
fn incident(theta: f64, side: f32) -> Vec3 {
    let d = dir_deg(theta);
    Vec3::new(d.x, 0.0, side * d.z)
}

/// Directional albedo (reflection + transmission) of TABULATED `t` by
/// deterministic quadrature (`compensation::glass_albedo`: SINGLE `s`'s
/// albedo over microfacet normals, 400 x 400 for roughness up to 1, 800 x
/// 800 above; the rest's reflection over those normals and a direction
/// grid split by node density, `compensation::broad_reflection_nodes`; the
/// rest's transmission over a grid of the lower hemisphere).
fn albedo_quadrature(t: &Material, s: &Material, wi: Vec3, ax: f32, ay: f32, eta: f32) -> f64 {
    glass_albedo(
        |a, b| t.eval(a, b, &mut Rng::new(0, 0)).x,
        |a, b| s.eval(a, b, &mut Rng::new(0, 0)).x,
        wi,
        ax,
        ay,
        eta,
    )
}

/// `wi` at `theta` degrees on the outside (`side = 1`) or inside (`-1`),
/// at azimuth `phi` degrees.
fn incident_az(theta: f64, side: f32, phi: f32) -> Vec3 {
    let d = incident(theta, side);
    let (sn, c) = phi.to_radians().sin_cos();
    Vec3::new(d.x * c, d.x * sn, d.z)
}

/// `albedo - 1` of TABULATED glass `(ndf, ax, ay, eta)` from each of
/// `dirs` ([`albedo_quadrature`] against SINGLE), each with its report row.
fn furnace_rows(ndf: NdfId, ax: f32, ay: f32, eta: f32, dirs: &[Vec3]) -> Vec<(f64, String)> {
    let t = tab(ndf, ax, ay, eta);
    let s = Material::new(&desc(Model::Single, ndf, ax, ay, eta)).expect("valid");
    dirs.iter()
        .map(|&wi| {
            let d = albedo_quadrature(&t, &s, wi, ax, ay, eta) - 1.0;
            let (x, y, z) = (wi.x, wi.y, wi.z);
            let row =
                format!("{ndf:?} ({ax},{ay}) eta {eta:.4} wi ({x:.3},{y:.3},{z:.3}): {d:+.4}");
            (d, row)
        })
        .collect()
}

/// The furnace of isotropic glass at incidence angles `thetas` (degrees)
/// from both sides, both NDFs, roughness `alphas` and relative indices
/// `etas` (eval quadrature): the report (printed with the worst) and the
/// worst `|albedo - 1|`.
fn isotropic_furnace(thetas: &[f64], alphas: &[f32], etas: &[f32]) -> (String, f64) {
    let dirs: Vec<Vec3> = [-1.0f32, 1.0]
        .into_iter()
        .flat_map(|side| thetas.iter().map(move |&theta| incident(theta, side)))
        .collect();
    let mut rows = Vec::new();
    for ndf in NDFS {
        for &a in alphas {
            for &e in etas {
                rows.extend(furnace_rows(ndf, a, a, e, &dirs));
            }
        }
    }
    let (report, worst) = furnace_report(&rows);
    println!("{report}worst |albedo - 1| = {worst:.4}");
    (report, worst)
}

/// The report (one row per line) and the worst `|albedo - 1|` of rows.
fn furnace_report(rows: &[(f64, String)]) -> (String, f64) {
    let report = rows.iter().map(|r| format!("{}\n", r.1)).collect();
    (report, rows.iter().map(|r| r.0.abs()).fold(0.0, f64::max))
}

/// White furnace to 89 degrees from both sides: a lossless dielectric
/// keeps all the energy (reflected plus transmitted albedo 1). Alpha 0.1,
/// 0.5, 1 and 1.9: the quadrature of eval is within 0.5% of 1 (measured
/// worst 0.34% to alpha 1, 0.46% at alpha 1.9, GGX glass from inside at 89
/// degrees; to alpha 1: 0.14% with scale table version 4, 0.498% with
/// the lobe table's version 5, whose normalised lobes moved GGX 0.1 glass
/// 1.5 from inside at 85 degrees from +0.05% to +0.50%, between roughness
/// nodes; 0.19% since session 28's fitted scale nodes), and the mean of
/// 100,000 sample weights within 0.5% plus 3
/// standard errors. The sample weights are heavier than the conductor's
/// (relative standard deviation up to 1.2 for rough glass at grazing
/// angles): the standard error is asserted below 4e-3 to alpha 1, so the
/// sample half detects a 1.6% loss (4 of them) and the quadrature carries
/// the 0.5%; at alpha 1.9 below 1e-2 (a 4% loss at 4 of them; measured
/// 8e-3). Alpha 1.9 was 1.8% off (Beckmann glass from inside at 80
/// degrees) until the scale generator took GGX's visible normals as its
/// reflection proposal for Beckmann too.
#[test]
fn white_furnace_both_sides_eval_and_sample() {
    let mut report = String::new();
    // (quadrature, sample mean - 3 se, standard error) worst, per regime.
    let mut worst = [[0.0f64; 3]; 2];
    let mut cases = 0;
    for ndf in NDFS {
        for alpha in [0.1f32, 0.5, 1.0, 1.9] {
            let rough = (alpha > 1.0) as usize;
            for (eta, side) in [(1.5f32, 1.0f32), (1.5, -1.0), (1.33, 1.0), (2.42, -1.0)] {
                let t = tab(ndf, alpha, alpha, eta);
                let s = Material::new(&desc(Model::Single, ndf, alpha, alpha, eta)).expect("valid");
                for (k, theta) in [0.0, 30.0, 60.0, 80.0, 85.0, 89.0].into_iter().enumerate() {
                    let wi = incident(theta, side);
                    let q = albedo_quadrature(&t, &s, wi, alpha, alpha, eta);
                    let mut rng = Rng::new(1601, cases * 8 + k as u64);
                    let (mean, se) = mean_and_error(
                        (0..100_000).map(|_| t.sample(wi, &mut rng).weight.x as f64),
                    );
                    report += &format!(
                        "{ndf:?} {alpha} eta {eta} side {side} {theta}: quad {q:.4} sample {mean:.4} +- {se:.1e}\n"
                    );
                    let w = &mut worst[rough];
                    w[0] = w[0].max((q - 1.0).abs());
                    w[1] = w[1].max((mean - 1.0).abs() - 3.0 * se);
                    w[2] = w[2].max(se);
                }
                cases += 1;
            }
        }
    }
    println!(
        "{report}alpha <= 1: worst |quadrature - 1| = {:.2e}; worst |sample mean - 1| - 3 se = {:.2e}; worst standard error {:.2e}\nalpha 1.9: {:.2e}, {:.2e}, {:.2e}",
        worst[0][0], worst[0][1], worst[0][2], worst[1][0], worst[1][1], worst[1][2]
    );
    assert!(worst[0][2] < 4e-3, "{report}");
    assert!(worst[0][0] < 5e-3, "{report}");
    assert!(worst[0][1] < 5e-3, "{report}");
    assert!(worst[1][2] < 1e-2, "{report}");
    assert!(worst[1][0] < 5e-3, "{report}");
    assert!(worst[1][1] < 5e-3, "{report}");
}

/// White furnace of glass 1.05 seen from inside near grazing incidence
/// (80-89 degrees), where the inside reflection's multiply scattered lobe
/// is largest, at the scale table's roughness nodes 0.28 and 1.84 and at
/// 0.8, 1.2 and 1.9 between nodes. Until session 23 the scale generator's
/// quadrature (2 x 48 x 48 reflection, 48 x 96 transmission) put the
/// unscaled albedo from 89 degrees at roughness 2 at 1.211 where finer
/// ones converge to 1.29: GGX 1.9 was +6.4% at 89 degrees (the sample
/// mean agreed), +6.2% at the node 1.84. The table is now generated over
/// the tests' own quadrature (`--broad 400`). Measured: worst 0.56%
/// (Beckmann 0.8 at 89 degrees, between roughness nodes; GGX 1.9 +0.17%)
/// with scale table version 3, 0.45% with version 4 (4 scale nodes per
/// lobe interval), 0.47% with the lobe table's version 5 (normalised
/// lobes), 0.36% with the fitted scale nodes (session 28); bounded at
/// 0.5% (0.7% until then).
#[test]
fn furnace_of_glass_1_05_from_inside_near_grazing() {
    let dirs = [80.0, 85.0, 88.0, 89.0].map(|theta| incident(theta, -1.0));
    let rows: Vec<_> = NDFS
        .into_iter()
        .flat_map(|ndf| {
            [0.28125f32, 0.8, 1.2, 1.84, 1.9]
                .into_iter()
                .flat_map(move |a| furnace_rows(ndf, a, a, 1.05, &dirs))
        })
        .collect();
    let (report, worst) = furnace_report(&rows);
    println!("{report}worst |albedo - 1| = {worst:.4}");
    assert!(worst < 0.005, "{report}");
}

/// White furnace of isotropic glass between the scale table's lowest
/// index nodes, near grazing from both sides: the indices at the midpoints
/// of the split intervals' thirds and halves (1.059, 1.078, 1.097 between
/// 1.05 and 1.107; 1.122 and 1.151 between 1.107 and 1.166) and the two
/// new nodes between 1.05 and 1.107 (1.069, 1.088), roughness 0.2, 0.3
/// and 0.45, 80 to 89 degrees. There the exact furnace scales are far
/// from linear in `ln E`; with the plain index grid (scale table version
/// 4, no index between 1.05 and 1.2 in any test) Beckmann 0.45 glass
/// 1.078 from outside at 89 degrees was +4.1%. With version 5 (the two
/// intervals split in 3 and 2): 1.62% at the midpoints and 2.63% at the
/// new node 1.069 (Beckmann 0.3 from inside at 85 degrees: the lobe
/// table's crease crossed that index between the scale nodes 0.281 and
/// 0.330). Measured since version 6 (the low-index block, whose roughness
/// nodes follow the crease): 0.92% (Beckmann 0.3 glass 1.059 from outside
/// at 89 degrees, between the index nodes 1.05 and 1.069: the scales'
/// curvature in `ln E` next to 1.05), 0.22% at 1.069; with the fitted
/// scale nodes (session 28) 1.05% when fitted along roughness alone and
/// **0.56%** with the low-index block fitted over its index intervals'
/// midpoints too (Beckmann 0.45 glass 1.069 from outside at 89 degrees,
/// -0.56%: an index node, whose scales are fitted, not exact; 0.57%
/// with the block refitted for scale table version 11, +0.51% at 1.059
/// beside it). With exact nodes the furnace there is 0.21% at 1.069 but
/// 0.90% at 1.059: the bend in `ln E` is about 1% deep, and a fit of
/// nodes interpolated linearly leaves about half of it at the nodes and
/// the midpoints (20 Lawson steps instead of 3: 0.52%, but 0.59% at
/// roughness 0.03 elsewhere, so not taken). Scale table version 12
/// (session 35) puts the first interval's inner nodes at 1.061 and 1.079
/// (`SCALE_LOW_KNOTS`, fractions 0.2 and 0.52 instead of thirds: the
/// bend is sharpest next to 1.05); the test reads the new nodes and
/// their parts' midpoints (1.0555, 1.0700, 1.0927) too. Measured 0.39%
/// (Beckmann 0.45 glass 1.061 from outside at 89 degrees, -0.39%; 0.57%
/// on version 11). Bounded at the 0.5% (0.7% until version 12,
/// 1.1% until session 28, 2.9% until version 6).
#[test]
fn furnace_between_the_lowest_index_nodes() {
    let (report, worst) = isotropic_furnace(
        &[80.0, 85.0, 89.0],
        &[0.2, 0.3, 0.45],
        &[
            1.0555, 1.0592, 1.0611, 1.0688, 1.0700, 1.0779, 1.0791, 1.0880, 1.0927, 1.0969, 1.1216,
            1.1508,
        ],
    );
    assert!(worst < 0.005, "{report}");
}

/// White furnace of isotropic glass across the range near grazing
/// incidence, at random cases (fixed seed): NDF, roughness log-uniform in
/// [0.002, 1.9], relative index `E` log-uniform in [1.05, 3] seen from
/// either side, `theta` uniform in [80, 89] degrees (eval quadrature).
/// The other furnace tests sit at chosen points; this one finds what lies
/// between the tables' nodes. The 0.5% is not met: the worst are
/// glass of low index seen from inside, between the scale table's
/// roughness nodes (where the interpolated lobe's albedo and `1 - E_ss`
/// part fastest, Beckmann 0.3 glass 1.05 from inside at 89 degrees
/// +2.6%, +1.98% since scale table version 4, +1.0% since the lobe
/// table's version 5 normalised the lobes) and at the crease of the lobe
/// table's interpolation triangles in `(roughness, index)` (GGX 0.889
/// glass 1.126 from inside at 88 degrees +1.9%, 0.41% since scale table
/// version 4). Measured: worst 0.64% (1.15% with scale table version 3,
/// 1.26% with version 4 and the walk's lobes), 90th percentile 0.14%
/// (0.23%, 0.16%), 1 of 240 cases over 0.5%; with the fitted scale nodes
/// (session 28) worst 0.30%, 90th percentile 0.10%, none over 0.5%;
/// bounded at 0.45% and 0.15% (0.8% and 0.2% until session 28, 1.3% and
/// 0.3% until version 5).
#[test]
fn isotropic_furnace_at_random_cases_near_grazing() {
    let mut rng = Rng::new(1128, 5);
    let mut rows: Vec<(f64, String)> = Vec::new();
    for _ in 0..240 {
        let mut u = || rng.next_f32();
        let ndf = NDFS[(u() < 0.5) as usize];
        let alpha = (0.002f32.ln() + u() * (1.9f32.ln() - 0.002f32.ln())).exp();
        let e = (1.05f32.ln() + u() * (3.0f32.ln() - 1.05f32.ln())).exp();
        let eta = if u() < 0.5 { e } else { 1.0 / e };
        let side = if u() < 0.5 { 1.0 } else { -1.0 };
        let theta = 80.0 + 9.0 * u() as f64;
        rows.extend(furnace_rows(
            ndf,
            alpha,
            alpha,
            eta,
            &[incident(theta, side)],
        ));
    }
    rows.sort_by(|a, b| b.0.abs().total_cmp(&a.0.abs()));
    let n = rows.len();
    let (worst, p90) = (rows[0].0.abs(), rows[n / 10].0.abs());
    let over = rows.iter().filter(|r| r.0.abs() > 0.005).count();
    let (report, _) = furnace_report(&rows[..12]);
    println!("{report}worst {worst:.4}, 90th percentile {p90:.4}, over 0.5%: {over} of {n}");
    assert!(worst < 0.0045, "worst {worst:.4}\n{report}");
    assert!(p90 < 0.0015, "90th percentile {p90:.4}\n{report}");
}

/// White furnace below the roughness 0.05 at grazing incidence (80-89
/// degrees, glass 1.5 from both sides, eval quadrature), where `E_ss`
/// nears 1 and the furnace scales change fastest with the roughness.
/// Measured: worst 0.22% (Beckmann 0.0055 from inside at 89 degrees;
/// 0.21% with scale table version 4, 0.20% with the lobe table's
/// version 5, 0.15% with the fitted scale nodes of session 28), bounded
/// at 0.25% (0.3% until session 28). Until session 22 the scale solve's lower clamp (0.25)
/// left the lobe a quarter of its energy where `E_ss` is 1: Beckmann
/// 0.0055 from inside at 88.5 degrees was +4.0%. Until session 23 the
/// scale table had no roughness node between 0.0035 and 0.0139: GGX 0.01
/// from inside at 89 degrees was -2.3% (scale table version 3 splits the
/// intervals below 0.031 in three; version 4 has 12 intervals there).
#[test]
fn furnace_at_low_roughness_near_grazing() {
    let thetas = [80.0, 85.0, 87.0, 88.0, 88.5, 89.0];
    let dirs: Vec<Vec3> = [1.0f32, -1.0]
        .into_iter()
        .flat_map(|side| thetas.map(|theta| incident(theta, side)))
        .collect();
    let rows: Vec<_> = NDFS
        .into_iter()
        .flat_map(|ndf| {
            [0.002f32, 0.0055, 0.0075, 0.01, 0.02]
                .into_iter()
                .flat_map(|a| furnace_rows(ndf, a, a, 1.5, &dirs))
                .collect::<Vec<_>>()
        })
        .collect();
    let (report, worst) = furnace_report(&rows);
    println!("{report}worst |albedo - 1| = {worst:.4}");
    assert!(worst < 0.0025, "{report}");
}

/// White furnace near the normal (4 to 24 degrees) of rough glass of low
/// index, from the dense side (where the exact furnace scales change
/// fastest there) and from the thin side: both NDFs, roughness 0.7, 1.3
/// and 1.9, `E` 1.05, 1.08, 1.125, 1.2 and 1.3 (eval quadrature). Until
/// the scale table's version 7 its last cosine interval spanned 20.5 to
/// 0 degrees; the scales of Beckmann 1.9 glass 1.125 from inside rose
/// from 0.95 to 1.49 across it and the furnace was +2.90% at 14 degrees
/// (version 6, fitted nodes; no other test looked between 0 and 30
/// degrees). Measured with version 7 (that interval split in 3): worst
/// 0.98%, Beckmann 1.9 glass 1.2 from inside at 24 degrees, in the next
/// interval (29.4 to 20.5 degrees, unchanged: 0.99% with version 6);
/// within the split interval at most 0.53% (Beckmann 1.9 glass 1.08
/// from inside at 8 degrees). With version 9 (session 31: quadratic
/// elements that end at the lobe table's cosine nodes, two in its last
/// interval, 26.2 degrees to the normal): 0.48%, bounded at 0.6% (it was
/// 1.1%). With version 12 (session 35: an index node at 1.079, whose
/// exact scales bend between the last cosine nodes, Beckmann 1.9 from
/// inside at 8 degrees 0.52%; the fit keeps them exact there,
/// `--hold-mu-from 32`, it would have put them at 0.64%): 0.50%. With
/// the low-index block's nodes near the normal refitted over its sheet
/// (session 36, `furnace_near_the_normal_between_low_index_nodes`):
/// 0.37%, and 0.32% with the main block's refitted too (`E` 1.2 and
/// 1.3), bounded at the 0.5% (it was 0.6%).
#[test]
fn furnace_near_the_normal_at_low_index() {
    let (report, worst) = isotropic_furnace(
        &[4.0, 8.0, 11.0, 14.0, 17.0, 24.0],
        &[0.7, 1.3, 1.9],
        &[1.05, 1.08, 1.125, 1.2, 1.3],
    );
    assert!(worst < 0.005, "{report}");
}

/// White furnace near the normal (0 to 20 degrees) of rough glass of low
/// index between the scale table's nodes, from both sides: both NDFs,
/// roughness 1.45, 1.7 and 1.938 (the midpoint in `sqrt(alpha)` of the
/// low-index block's last roughness interval, 1.877 to 2), `E` 1.055,
/// 1.066, 1.093 (the midpoint in `ln E` of the index nodes 1.079 and
/// 1.107), 1.1 and 1.136 (eval quadrature). Eval interpolates the scales
/// quadratically in the cosine and linearly in roughness and index, and
/// near the normal the exact scales of rough glass of low index seen from
/// its dense side bend in all three: with the fitted nodes of scale table
/// version 12 the furnace at the centres of the block's last triangles was
/// 0.78% (Beckmann, by the generator's quadrature; the sweeps had seen
/// 0.53% at nodes). `gen_tabulated -- --dielectric-scale-top --low-only
/// --sheet` (session 36) refits the cosine nodes from 22.7 degrees to the
/// normal over the nodes and the midpoints between them. Measured here:
/// 0.54% with version 12's nodes, 0.50% refitted (Beckmann 1.938 glass
/// 1.093 from inside at the normal, the centre of a triangle: the fit's
/// `E_ss` by a 128 x 128 quadrature put it at 0.41%); bounded at the
/// issue's 0.5%.
#[test]
fn furnace_near_the_normal_between_low_index_nodes() {
    let (report, worst) = isotropic_furnace(
        &[0.0, 3.0, 6.0, 10.0, 16.0, 20.0],
        &[1.45, 1.7, 1.938],
        &[1.055, 1.066, 1.093, 1.1, 1.136],
    );
    assert!(worst < 0.005, "{report}");
}

/// White furnace near the normal (0 to 10 degrees) of very rough glass of
/// index 1.2 to 1.3, from both sides: both NDFs, roughness 1.3, 1.7 and
/// 1.9, `E` 1.2, 1.25 and 1.3 (eval quadrature). A near-normal sweep of
/// the main block's indices (session 36) found Beckmann 1.7 glass 1.2
/// from inside at the normal at -0.62% (version 12's fitted nodes); no
/// test read roughness 1.7 there. `gen_tabulated -- --dielectric-scale-top
/// --main-only --sheet` refits the main block's cosine nodes from 22.7
/// degrees to the normal over its nodes and the midpoints between them
/// (roughness 1.03 to 2, index 1.166 to 1.6). Measured here: 0.62%
/// before, 0.25% refitted; bounded at the 0.5%.
#[test]
fn furnace_near_the_normal_of_very_rough_glass() {
    let (report, worst) = isotropic_furnace(&[0.0, 6.0, 10.0], &[1.3, 1.7, 1.9], &[1.2, 1.25, 1.3]);
    assert!(worst < 0.005, "{report}");
}

/// White furnace of rough glass of low index at the lobe table's cosine
/// nodes 4, 7, 17 and 18 (87.46, 82.20, 36.82 and 26.17 degrees), from
/// both sides: both NDFs, roughness 1.3 and 1.9, `E` 1.05, 1.125 and 1.2
/// (eval quadrature). Eval interpolates the lobe linearly between those
/// nodes, so the exact furnace scale has a kink at each, and the scale
/// table's cosine nodes (`p / 31` in `sqrt(mu)`, version 7) fall between
/// them: no test or sweep had looked at these angles. Measured worst
/// 1.33% (GGX 1.9 glass 1.05 from inside at 26.17 degrees; GGX 1.3 at
/// 87.46 degrees 1.25%). A scale grid on the lobe's nodes (version 8,
/// tried in session 30, `docs/tabulated_dielectric.md`) gave 0.21% here
/// but more elsewhere. With version 9 (session 31: the scales quadratic
/// on elements that end at the lobe's nodes): 0.23%, bounded at the
/// issue's 0.5% (it was 1.4%).
#[test]
fn furnace_at_the_lobe_nodes() {
    let (report, worst) = isotropic_furnace(
        &[26.17, 36.82, 82.20, 87.46],
        &[1.3, 1.9],
        &[1.05, 1.125, 1.2],
    );
    assert!(worst < 0.005, "{report}");
}

/// White furnace of isotropic glass just below roughness 0.125 (a node
/// of the lobe table, which eval interpolates linearly in roughness)
/// near grazing, from both sides: both NDFs, roughness 0.107 to 0.117,
/// glass 1.5, 1.55 and 1.577 (the last on the lobe table's crease at
/// 0.117), 80 to 89 degrees (eval quadrature). Just below that node the
/// exact furnace scale bends most within one scale interval (0.0957 to
/// 0.125 until scale table version 9): with version 9's fitted nodes GGX
/// 0.11 glass 1.55 from inside at 84.3 degrees was +0.60%, the worst of
/// every isotropic sweep (`gen_tabulated_aniso -- --dielectric-sweep
/// --isotropic`: 0.54% at 0.11, none over 0.5% elsewhere). Version 10
/// halves the interval (node 0.1099); measured 0.46%, bounded at the
/// issue's 0.5%.
#[test]
fn furnace_below_roughness_0_125_near_grazing() {
    let (report, worst) = isotropic_furnace(
        &[80.0, 84.3, 85.0, 87.0, 89.0],
        &[0.107, 0.11, 0.114, 0.1173],
        &[1.5, 1.55, 1.577],
    );
    assert!(worst < 0.005, "{report}");
}

/// White furnace of isotropic glass of low index just below roughness
/// 0.125 near grazing, from both sides: both NDFs, roughness 0.107 to
/// 0.1173, `E` 1.107, 1.122, 1.14 and 1.151 (the scale table's low-index
/// block: an index node, the midpoints of its intervals around 1.136 and
/// the worst random case's index), 80 to 89 degrees (eval quadrature).
/// The exact scale bends there as above
/// (`furnace_below_roughness_0_125_near_grazing`), and the low-index
/// block had no node at 0.11 until scale table version 11: GGX 0.111
/// glass 1.14 from inside at 85.6 degrees was +0.56% with version 10,
/// the worst of 1,000 random cases near grazing. Measured: 0.57% with
/// version 10 (GGX 0.111 glass 1.107 from inside at 85.6 degrees),
/// 0.23% with version 11; bounded at the 0.5%.
#[test]
fn furnace_below_roughness_0_125_near_grazing_at_low_index() {
    let (report, worst) = isotropic_furnace(
        &[80.0, 83.0, 85.6, 87.0, 89.0],
        &[0.107, 0.111, 0.114, 0.1173],
        &[1.107, 1.122, 1.14, 1.151],
    );
    assert!(worst < 0.005, "{report}");
}

/// White furnace of rough isotropic glass near the normal halfway
/// between the scale table's index nodes (in `ln E`) above 1.166, from
/// both sides: both NDFs, roughness 0.7 to 1.9, `E` 1.197, 1.262, 1.401,
/// 1.557 and 1.920, 0 and 10 degrees (eval quadrature). There the exact
/// furnace scales bend in the index (Beckmann 1.3 glass 1.2 from inside
/// at the normal: 0.60% off with exact scale nodes, 0.12% with the
/// roughness interpolated alone); until scale table version 10 the fit
/// of the main block's nodes looked along roughness only: Beckmann 1
/// glass 1.401 from inside at the normal -0.54%, Beckmann 1.3 glass 1.2
/// -0.57%. Version 10 fits the main block over its index midpoints too;
/// measured 0.38%, bounded at the 0.5%.
#[test]
fn furnace_at_the_normal_between_index_nodes() {
    let (report, worst) = isotropic_furnace(
        &[0.0, 10.0],
        &[0.7, 1.0, 1.3, 1.9],
        &[1.1972, 1.2618, 1.4014, 1.5566, 1.9202],
    );
    assert!(worst < 0.005, "{report}");
}

/// Anisotropic glass with a roughness below the correction's node 1
/// (0.031) against a rough axis, near grazing from both sides (glass
/// 1.05: the dense side's grazing reflection is where the uncorrected
/// lobe is furthest off). Until session 22 such a roughness read node 0's
/// corners, the uncorrected lobe (factor 1): Beckmann (0.003, 1.9) from
/// inside at 85 degrees, azimuth 11.25, had the albedo 2.53 (3.48
/// uncorrected; now 1.039). It reads node 1 now. Measured worst 0.1540,
/// 0.1512 since scale table version 4, 0.1371 since the lobe table's version 5
/// (Beckmann (0.003, 1.9) from inside at 89 degrees on the smooth axis,
/// albedo 0.846; 0.830 with the scale table's version 2: the
/// single-scattering albedo along the smooth axis changes fast with
/// `alpha_x` there, and node 1's factors, -0.3% for its own material
/// (0.031, 1.9), do not follow it; 0.1358 with scale table version 9 and
/// the correction regenerated on it, 0.1230 with the correction's version
/// 12, session 32), bounded at 0.16: the 0.5% is not met here.
#[test]
fn anisotropic_furnace_below_roughness_node_1() {
    let mut dirs = Vec::new();
    for side in [1.0f32, -1.0] {
        for theta in [85.0, 89.0] {
            for phi in [0.0f32, 11.25, 22.5, 45.0] {
                dirs.push(incident_az(theta, side, phi));
            }
        }
    }
    let rows: Vec<_> = NDFS
        .into_iter()
        .flat_map(|ndf| {
            [(0.003f32, 1.9f32), (0.012, 1.9)]
                .into_iter()
                .flat_map(|(ax, ay)| furnace_rows(ndf, ax, ay, 1.05, &dirs))
                .collect::<Vec<_>>()
        })
        .collect();
    let (report, worst) = furnace_report(&rows);
    println!("{report}worst |albedo - 1| = {worst:.4}");
    assert!(worst < 0.16, "{report}");
}

/// The furnace of anisotropic glass `eta` for the roughness pairs `pairs`,
/// both NDFs and sides, 0, 60 and 85 degrees along x and y (eval
/// quadrature): the report and the worst `|albedo - 1|`.
fn aniso_furnace(pairs: &[(f32, f32)], eta: f32) -> (String, f64) {
    aniso_furnace_at(pairs, eta, &[0.0, 60.0, 85.0])
}

/// [`aniso_furnace`] at the incident angles `thetas` (degrees).
fn aniso_furnace_at(pairs: &[(f32, f32)], eta: f32, thetas: &[f64]) -> (String, f64) {
    let mut dirs = Vec::new();
    for side in [1.0f32, -1.0] {
        for &theta in thetas {
            for phi in [0.0f32, 90.0] {
                dirs.push(incident_az(theta, side, phi));
            }
        }
    }
    let rows: Vec<_> = NDFS
        .into_iter()
        .flat_map(|ndf| {
            pairs
                .iter()
                .flat_map(|&(ax, ay)| furnace_rows(ndf, ax, ay, eta, &dirs))
                .collect::<Vec<_>>()
        })
        .collect();
    furnace_report(&rows)
}

/// Anisotropic roughness reads the table at an effective roughness and
/// scales it by the anisotropic correction; its furnace error is measured
/// (printed) and bounded apart from the isotropic 0.5% (see
/// [`ANISO_FURNACE`]).
#[test]
fn white_furnace_anisotropic() {
    let (report, worst) = aniso_furnace(&[(0.1, 0.6), (0.3, 1.0)], 1.5);
    println!("{report}worst |albedo - 1| = {worst:.4}");
    assert!(worst < ANISO_FURNACE, "{report}");
}

/// The anisotropic furnace near the normal: 10, 17 and 24 degrees along
/// both axes from both sides, Beckmann and GGX (0.3, 1.9), (0.3, 1) and
/// (1, 1.9), glass 1.2 and 1.5. Until version 11 the correction's cosine
/// grid had one interval from 29.3 degrees to the normal, and the
/// factors bend within it: the near-normal sweep of
/// `docs/tabulated_dielectric.md` had 5.53% (Beckmann (0.3, 1.9) glass
/// 1.2 from inside at 17 degrees along the rough axis; 170 of 756
/// directions over 0.5%). Version 12 has a cosine node at 14.6 degrees
/// (`tabulated::dcorr_grid_mu`). Measured here: 0.0553 with version 11,
/// 0.0223 with version 12 (Beckmann (1, 1.9) glass 1.2 from inside at 24
/// degrees along the rough axis, between the nodes at 29.3 and 14.6
/// degrees); bounded at 0.025.
#[test]
fn anisotropic_furnace_near_the_normal() {
    let mut failed = String::new();
    let mut worst_all: f64 = 0.0;
    for eta in [1.2f32, 1.5] {
        let (report, worst) = aniso_furnace_at(
            &[(0.3, 1.9), (0.3, 1.0), (1.0, 1.9)],
            eta,
            &[10.0, 17.0, 24.0],
        );
        println!("{report}eta {eta}: worst |albedo - 1| = {worst:.4}");
        worst_all = worst_all.max(worst);
        if worst >= ANISO_NEAR_NORMAL {
            failed += &report;
        }
    }
    println!("worst |albedo - 1| near the normal = {worst_all:.4}");
    assert!(failed.is_empty(), "{failed}");
}

/// Bound of [`anisotropic_furnace_near_the_normal`].
const ANISO_NEAR_NORMAL: f64 = 0.025;

/// The anisotropic furnace at roughness and index nodes of the correction
/// table (`data/tabulated_aniso_dielectric.bin`: lobe roughness nodes 3
/// and 6, 2 and 4, index node 2, `eta` 1.598), the same directions as
/// `white_furnace_anisotropic` (0 degrees is a cosine node, 60 and 85 lie
/// between nodes; both azimuths are nodes). The generator solves the
/// scaling at the nodes in its own quadrature (160 x 160 normals), so what
/// is left here is that quadrature and the cosine interpolation: measured
/// worst 0.0034 (GGX (0.28, 1.125) from inside at 60 degrees along y),
/// bounded at 0.5%. Between index nodes see
/// `anisotropic_furnace_between_index_nodes`.
#[test]
fn anisotropic_furnace_at_correction_nodes() {
    let (a3, a6, a2, a4) = (grid_alpha(3), grid_alpha(6), grid_alpha(2), grid_alpha(4));
    let (report, worst) = aniso_furnace(&[(a3, a6), (a2, a4)], grid_eta(2));
    println!("{report}worst |albedo - 1| at the nodes = {worst:.4}");
    assert!(worst < 0.005, "{report}");
}

/// The anisotropic furnace at the roughness nodes of
/// `anisotropic_furnace_at_correction_nodes` and indices halfway in `ln E`
/// between the correction's index nodes (`tabulated_dielectric::dcorr_grid_eta`:
/// 13, the lobe table's 6, the midpoints of its intervals, the first
/// quarter point of the lowest, 1.107, and its first eighth point,
/// 1.078; 14 with the third quarter point 1.229 until session 31), the
/// same directions: what the linear
/// interpolation in `ln E` leaves, where it is largest. With 7 index nodes (the lobe table's 6 and the midpoint
/// 1.166 of the lowest interval; until session 13) the worst at 1.15, 1.5,
/// 1.8 and 2.7 was 0.0170, 0.0220, 0.0092 and 0.0057 (all Beckmann or GGX
/// (0.28, 1.125), 1.5 from inside at 60 degrees along x); with 11, at the
/// same indices, 0.0170, 0.0078, 0.0030 and 0.0029, and halfway between
/// 1.05 and 1.166 (1.107) 0.0400, as with 7 (the old test's 1.15 sat
/// next to the node 1.166). With 12 (session 13; halfway 1.078, 1.136,
/// 1.229, 1.516, 1.870 and 2.563): 0.0323, 0.0095, 0.0169, 0.0078,
/// 0.0059, 0.0037 (the factors move fastest with the index near 1.05).
/// Measured here with 14 (session 14; halfway 1.064, 1.092, 1.136,
/// 1.197, 1.262, 1.516, 1.870 and 2.563): 0.0136, 0.0102, 0.0095, 0.0088,
/// 0.0171, 0.0078, 0.0059, 0.0037. The worst, Beckmann (0.125, 0.5) from
/// inside at 85 degrees along y at 1.262, is +0.13% at the node 1.229,
/// +1.0% at 1.241, +1.7% at 1.263 and +0.03% at the node 1.297: the
/// parabola of a linear interpolation (within 0.1 points of `4 t (1 - t)`
/// times 1.7%), four times deeper than between 1.166 and 1.229 (0.4%).
/// Scale table version 4 (session 24): 0.0135, 0.0099, 0.0089, 0.0079,
/// 0.0180, 0.0080, 0.0058, 0.0035. The lobe table's version 5 (session
/// 25, normalised lobes, scales and correction regenerated on them):
/// 0.0151, 0.0104, 0.0127, 0.0062, 0.0059, 0.0090, 0.0058, 0.0035, the
/// worst 0.0180 -> 0.0151 but two intervals worse; their bounds went from
/// 0.015 and 0.011 to 0.016 and 0.014, the one at 1.262 from 0.019 to
/// 0.008 (the isotropic furnace is what version 5 was made for). The
/// scale table's version 5 (session 26, the two lowest index intervals
/// split, correction regenerated): 0.0109, 0.0105, 0.0102, 0.0062,
/// 0.0059, 0.0090, 0.0058, 0.0035; the bounds at 1.064 and 1.136 back
/// down to 0.012. Version 6 (session 27, the low-index block, correction
/// regenerated): 0.0111, 0.0105, 0.0105, 0.0061, 0.0059, 0.0090, 0.0058,
/// 0.0035 (bounds unchanged). Fitted scale nodes (session 28, correction
/// regenerated): 0.0110, 0.0107, 0.0105, 0.0062, 0.0060, 0.0091, 0.0056,
/// 0.0035 (bounds unchanged). Version 11 of the correction (session 31,
/// 13 index nodes: 1.229 left out for the library's size budget) with
/// version 7's scales: 0.0110, 0.0109, 0.0107, then halfway between
/// 1.166 and 1.295 (1.229) 0.0164 where 1.197 and 1.262 had 0.0073 and
/// 0.0058 with version 10, 0.0089, 0.0056, 0.0035; with the scale
/// table's version 9 (the correction still solved on version 6's
/// scales): 0.0111, 0.0111, 0.0112, 0.0168, 0.0095, 0.0056, 0.0034;
/// regenerated on version 9 (session 32): 0.0105, 0.0101, 0.0101,
/// 0.0157, 0.0086, 0.0056, 0.0035; the correction's version 12 (a
/// cosine node at 14.6 degrees, the same session): 0.0104, 0.0101,
/// 0.0103, 0.0141, 0.0086, 0.0056, 0.0035. The bound at 1.229 is 0.017
/// (0.02 in session 31; those at 1.197 and 1.262 were 0.01 and 0.008).
#[test]
fn anisotropic_furnace_between_index_nodes() {
    let (a3, a6, a2, a4) = (grid_alpha(3), grid_alpha(6), grid_alpha(2), grid_alpha(4));
    let mut failed = String::new();
    // Halfway between nodes 0-1 to 3-4 (the lowest lobe interval), 5-6,
    // 7-8 and 10-11 (version 11's nodes: 1.229 is not one).
    let mid = |e: usize| (dcorr_grid_eta(e) * dcorr_grid_eta(e + 1)).sqrt();
    for (eta, bound) in [
        (mid(0), 0.012f64),
        (mid(1), 0.012),
        (mid(2), 0.012),
        (mid(3), 0.017),
        (mid(5), 0.01),
        (mid(7), 0.007),
        (mid(10), 0.005),
    ] {
        let (report, worst) = aniso_furnace(&[(a3, a6), (a2, a4)], eta);
        println!("eta {eta:.4}: worst |albedo - 1| = {worst:.4}");
        if worst >= bound {
            failed += &report;
        }
    }
    assert!(failed.is_empty(), "{failed}");
}

/// The anisotropic furnace halfway in azimuth between the correction's
/// azimuth nodes (`tabulated_dielectric::DCORR_PHI`, uniform in
/// `tabulated::dcorr_phi` of the block's stretched diamond angle), at the
/// node materials of `anisotropic_furnace_at_correction_nodes` (lobe
/// roughness nodes 3 and 6, 2 and 4; index node 2, `eta` 1.598), both
/// NDFs, both sides, at the cosine nodes 63.3 and 85.4 degrees (so that
/// only the azimuth is interpolated): the other furnace tests look along
/// the axes, which are azimuth nodes. With the albedo table's 7 azimuths
/// (versions 1-9) the worst was 0.0335 (GGX (0.28, 1.125) from inside at
/// 85.4 degrees, azimuth 43.2; 12 of the 96 directions over 1%, 22 over
/// 0.5%). With 10 (version 10, session 18): 0.0170 (the same material
/// and direction, azimuth 45.7; 2 of 144 over 1%, 17 over 0.5%); 0.0171
/// with version 12 (session 32, the same cosines), bounded
/// at [`ANISO_BETWEEN_AZIMUTHS`].
#[test]
fn anisotropic_furnace_between_azimuth_nodes() {
    use msbsdf::multiple::compensation_aniso_tables::AN_MU;
    use msbsdf::multiple::tabulated::dcorr_node_dir;
    use msbsdf::multiple::tabulated_dielectric::{DCORR_PHI, dcorr_stretch};
    let eta = grid_eta(2);
    let mut report = String::new();
    let mut worst: f64 = 0.0;
    for ndf in NDFS {
        for (jx, jy) in [(3, 6), (2, 4)] {
            let (ax, ay) = (grid_alpha(jx), grid_alpha(jy));
            let t = tab(ndf, ax, ay, eta);
            let s = Material::new(&desc(Model::Single, ndf, ax, ay, eta)).expect("valid");
            let rho = dcorr_stretch(jx, jy);
            // Cosine nodes 9 (63.3 degrees) and 3 (85.4 degrees; 10
            // and 4 until version 12, which left out ENERGY_COMPENSATED's
            // node 1).
            for i in [9, 3] {
                for k in 0..DCORR_PHI - 1 {
                    let (a, b) = (
                        dcorr_node_dir(k * AN_MU + i, rho),
                        dcorr_node_dir((k + 1) * AN_MU + i, rho),
                    );
                    let phi = 0.5 * (a.y.atan2(a.x) + b.y.atan2(b.x));
                    let sxy = (1.0 - a.z * a.z).max(0.0).sqrt();
                    for side in [1.0f32, -1.0] {
                        let wi = Vec3::new(sxy * phi.cos(), sxy * phi.sin(), side * a.z);
                        let q = albedo_quadrature(&t, &s, wi, ax, ay, eta);
                        report += &format!(
                            "{ndf:?} ({ax},{ay}) side {side} theta {:.1} phi {:.1}: {q:.4}\n",
                            a.z.acos().to_degrees(),
                            phi.to_degrees()
                        );
                        worst = worst.max((q - 1.0).abs());
                    }
                }
            }
        }
    }
    println!("{report}worst |albedo - 1| between azimuth nodes = {worst:.4}");
    assert!(worst < ANISO_BETWEEN_AZIMUTHS, "{report}");
}

/// Bound of `anisotropic_furnace_between_azimuth_nodes`: measured 0.0170
/// with 10 azimuth nodes; version 9's 7 fail it (0.0335).
const ANISO_BETWEEN_AZIMUTHS: f64 = 0.02;

/// The furnace at the corners of the anisotropic range (one axis near the
/// smoothest node, the other at 1.9-2; index 1.05 from both sides, where
/// total internal reflection makes the dense side's lobe hardest to
/// correct), grazing (80 and 89 degrees) along both axes and between them.
/// The correction of version 3 (generator quadrature over the normals only,
/// which misses most of a broad lobe when the roughness is this
/// anisotropic) had albedo 20.4 here (Beckmann (0.03125, 2) from the dense
/// side at 89 degrees along y), sample weights up to 26,774. Version 4
/// (the split quadrature) was within 0.22 here but at 89 degrees and
/// azimuth 11.25 from the dense side (1.71-2.20; worst GGX (0.03125, 2)),
/// between the correction's first two azimuth nodes, where the solved
/// factor fell from 1.6-2.5 to 0.07. Measured (version 6: azimuth nodes
/// per block uniform in the diamond angle stretched by `(alpha_y /
/// alpha_x)^(1/4)`, `tabulated_dielectric::dcorr_stretch`): worst 0.1233 (GGX (0.05,
/// 1.9) from the dense side at 89 degrees, azimuth 45), that band 0.0868.
/// Version 10 (10 azimuth nodes instead of 7, session 18): 0.0803, the
/// same direction; 0.0747 with scale table version 9 and version 11 of
/// the correction regenerated on it, 0.0809 with its version 12 (GGX
/// (0.05, 1.9) from the dense side at 89 degrees, azimuth 45: version 12
/// left out the cosine node at 89.2 degrees for one near the normal;
/// session 32). Bounded at 0.1 everywhere (0.15 until version 10; it
/// was 0.25, and 1.25 in that band, before).
#[test]
fn anisotropic_furnace_at_the_range_corners() {
    let mut report = String::new();
    let mut worst: f64 = 0.0;
    for ndf in NDFS {
        for (ax, ay) in [(0.05f32, 1.9f32), (0.03125, 2.0)] {
            for eta in [1.0 / 1.05f32, 1.05] {
                let t = tab(ndf, ax, ay, eta);
                let s = Material::new(&desc(Model::Single, ndf, ax, ay, eta)).expect("valid");
                for theta in [80.0, 89.0] {
                    for phi in [0.0, 11.25, 45.0, 90.0] {
                        let wi = dir_deg_az(theta, phi);
                        let q = albedo_quadrature(&t, &s, wi, ax, ay, eta);
                        report +=
                            &format!("{ndf:?} ({ax},{ay}) eta {eta:.4} {theta} {phi}: {q:.4}\n");
                        worst = worst.max((q - 1.0).abs());
                    }
                }
            }
        }
    }
    println!("{report}worst |albedo - 1| = {worst:.4}");
    assert!(worst < 0.1, "{report}");
}

/// Bound on the anisotropic furnace error (see `white_furnace_anisotropic`):
/// the multiply scattered part is read at an effective roughness with the
/// furnace scales of that roughness (which normalise the isotropic table
/// only) and scaled by the anisotropic correction
/// `data/tabulated_aniso_dielectric.bin`, exact at its nodes (9 roughness
/// nodes per axis, 12 indices) in the generator's quadrature; measured
/// worst 0.0204, 0.0203 with version 4 of the table, 0.0204 with
/// version 6 (Beckmann (0.3, 1)
/// from inside at 60 degrees along x, an
/// index-interpolation error: 0.0086 with 11 index nodes; 0.0262 at the
/// session's start, Beckmann (0.3, 1) from outside at 85 degrees along y,
/// then 0.0185, which is the interpolation in roughness: its roughness
/// nodes (0.28, 0.78) and (0.28, 1.125) are within 0.0004 there; 0.152
/// without the correction). With 11 or 12 index nodes (session 13) that
/// roughness interpolation is the worst: 0.0195 (0.0194 in session 27,
/// 0.0203 with the fitted scale nodes of session 28, Beckmann (0.1, 0.6)
/// from inside at 85 degrees along x; 0.0210 with scale table version 9
/// under the old correction, 0.0206 with the correction regenerated on
/// it, session 32, GGX (0.1, 0.6) from inside at 85 degrees along x;
/// 0.0233 with scale table version 10 and the correction regenerated on
/// it, session 33, Beckmann (0.1, 0.6) from inside at 85 degrees along x,
/// GGX there -0.0224: the isotropic scales now bend near roughness 0.11
/// (version 10's node at 0.1099), and the correction, linear between
/// its roughness nodes 0.031 and 0.125, does not follow them; 1,000
/// random anisotropic cases are unchanged, worst / 90th percentile 2.13 /
/// 0.46%, 3.29 / 0.56%, 4.29 / 0.63% by `E` class against 2.13 / 0.46,
/// 3.30 / 0.58, 4.28 / 0.63); bounded at 0.024 (0.021 in session 32,
/// 0.022 before; raised for that trade: two isotropic leftovers over the
/// issue's 0.5% are now under it).
const ANISO_FURNACE: f64 = 0.024;

/// Chi-square of sampled directions against `pdf`, binned directly in
/// direction (the cosine lobes of the mixture reach transmitted directions
/// no refraction reaches, so the normal-space binning of the common helper
/// does not apply): per hemisphere 24 bands uniform in `|z|` (equal solid
/// angle) by 48 in azimuth; expected counts by a 6 x 6 midpoint rule per
/// cell, refined to 24 x 24 where the pdf varies by more than 1.5x across
/// the cell. Also asserts per sample that `pdf() > 0`, that sample's pdf is
/// `pdf()` and its weight `eval / pdf`. Sidak-corrected 1% level.
fn chi2_directions(m: &Material, wi: Vec3, n: usize, seed: u64) -> Chi2 {
    let (nz, np) = (24usize, 48usize);
    let cells = nz * np;
    let index = |w: Vec3| {
        let a = ((w.z.abs() as f64 * nz as f64) as usize).min(nz - 1);
        let phi = (w.y as f64).atan2(w.x as f64).rem_euclid(2.0 * PI);
        let b = ((phi / (2.0 * PI) * np as f64) as usize).min(np - 1);
        (if w.z > 0.0 { 0 } else { cells }) + a * np + b
    };
    let mut observed = vec![0.0; 2 * cells];
    let mut rng = Rng::new(seed, 3);
    let mut zero = Rng::new(0, 0);
    for _ in 0..n {
        let s = m.sample(wi, &mut rng);
        if s.flags == msbsdf::SAMPLE_ABSORBED {
            continue;
        }
        let p = m.pdf(wi, s.wo);
        assert!(p > 0.0, "sample went where pdf is 0: {s:?}");
        // As in the common helper: pdf() recomputes the refraction half
        // vector from the f32 `wo` the material returns, and
        // (wi.h + eta wo.h)^2 cancels near the refraction peak: 5e-3.
        assert!((s.pdf - p).abs() <= 5e-3 * p, "pdf {} vs {p}", s.pdf);
        let f = m.eval(wi, s.wo, &mut zero);
        assert!(
            (f.x / p - s.weight.x).abs() <= 5e-3 * s.weight.x.max(1e-3),
            "weight {} vs eval/pdf {}",
            s.weight.x,
            f.x / p
        );
        observed[index(s.wo)] += 1.0;
    }
    let mut expected = vec![0.0; 2 * cells];
    let mut total = 0.0;
    for (h, sign) in [(0usize, 1.0f64), (1, -1.0)] {
        for a in 0..nz {
            for b in 0..np {
                let mut sub = 6usize;
                let mut acc = 0.0;
                for pass in 0..2 {
                    acc = 0.0;
                    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
                    for x in 0..sub {
                        for y in 0..sub {
                            let z = (a as f64 + (x as f64 + 0.5) / sub as f64) / nz as f64;
                            let phi =
                                2.0 * PI * (b as f64 + (y as f64 + 0.5) / sub as f64) / np as f64;
                            let r = (1.0 - z * z).max(0.0).sqrt();
                            let wo = Vec3::new(
                                (r * phi.cos()) as f32,
                                (r * phi.sin()) as f32,
                                (sign * z) as f32,
                            );
                            let v = m.pdf(wi, wo) as f64;
                            acc += v;
                            (lo, hi) = (lo.min(v), hi.max(v));
                        }
                    }
                    if pass == 0 && hi > 1.5 * lo {
                        sub = 24;
                    } else {
                        break;
                    }
                }
                // Cell solid angle: (1 / nz) * (2 pi / np).
                let e = acc / (sub * sub) as f64 * (2.0 * PI / (nz * np) as f64);
                total += e;
                expected[h * cells + a * np + b] = e * n as f64;
            }
        }
    }
    assert!(total <= 1.0 + 5e-3, "pdf integrates to {total} > 1");
    chi2_test(&observed, &expected, 5.0)
}

#[test]
fn chi_square_sample_against_pdf() {
    let cases: Vec<(NdfId, f32, f32, f32, f64, f32)> = NDFS
        .iter()
        .flat_map(|&n| {
            [
                (0.3f32, 0.3f32, 1.5f32),
                (0.7, 0.7, 1.33),
                (1.0, 1.0, 2.42),
                (0.2, 0.6, 1.5),
            ]
            .into_iter()
            .flat_map(move |(ax, ay, eta)| {
                [
                    (0.0, 1.0f32),
                    (50.0, 1.0),
                    (85.0, 1.0),
                    (50.0, -1.0),
                    (85.0, -1.0),
                ]
                .map(|(t, side)| (n, ax, ay, eta, t, side))
            })
        })
        .collect();
    let level = sidak(0.01, cases.len());
    let mut report = String::new();
    for (idx, &(ndf, ax, ay, eta, theta, side)) in cases.iter().enumerate() {
        let m = tab(ndf, ax, ay, eta);
        let r = chi2_directions(&m, incident(theta, side), 200_000, 700 + idx as u64);
        report += &format!(
            "{ndf:?} ({ax},{ay}) eta {eta} theta {theta} side {side}: chi2 {:.1} dof {} p {:.3}\n",
            r.chi2, r.dof, r.p
        );
        assert!(r.p > level, "{report}");
    }
    println!("{report}");
}

/// Reflection: `f(wi, wo) = f(wo, wi)`; transmission: the flux-conserving
/// rule `f(wi, wo) / eta_o^2 = f(wo, wi) / eta_i^2` (`eta_x` the absolute
/// index on the side of `x`; `f = eval / |wo.z|`). The reflection lobes are
/// symmetric tables read the same way both ways, and dense-side
/// transmission is derived from the thin side's by the rule, so only f32
/// rounding remains (SINGLE's term is reciprocal to ~1e-6): bounded at
/// 1e-4 relative, for materials with `eta` above and below 1.
#[test]
fn reciprocity_reflection_and_eta_weighted_transmission() {
    let mut rng = Rng::new(5, 7);
    let (mut worst_r, mut worst_t): (f32, f32) = (0.0, 0.0);
    let mut counts = [0usize; 2];
    for ndf in NDFS {
        for (ax, ay) in [(0.05f32, 0.05f32), (0.3, 0.3), (1.0, 1.0), (0.1, 0.6)] {
            for eta in [1.5f32, 2.42, 1.0 / 1.33] {
                let m = tab(ndf, ax, ay, eta);
                for _ in 0..2000 {
                    let d = |rng: &mut Rng| {
                        let mu = rng.next_f32().max(1e-3);
                        let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
                        let s = (1.0 - mu * mu).sqrt();
                        let z = if rng.next_f32() < 0.5 { mu } else { -mu };
                        Vec3::new(s * phi.cos(), s * phi.sin(), z)
                    };
                    let (wi, wo) = (d(&mut rng), d(&mut rng));
                    let a = m.eval(wi, wo, &mut rng).x / wo.z.abs();
                    let b = m.eval(wo, wi, &mut rng).x / wi.z.abs();
                    let index = |w: Vec3| if w.z > 0.0 { 1.0 } else { eta };
                    let (ni, no) = (index(wi), index(wo));
                    let (x, y) = (a / (no * no), b / (ni * ni));
                    let e = (x - y).abs() / x.abs().max(y.abs()).max(1e-3);
                    let transmission = (wi.z > 0.0) != (wo.z > 0.0);
                    counts[transmission as usize] += 1;
                    if transmission {
                        worst_t = worst_t.max(e);
                    } else {
                        worst_r = worst_r.max(e);
                    }
                    assert!(
                        e < 1e-4,
                        "{ndf:?} ({ax},{ay}) eta {eta} {wi} {wo}: {x} vs {y}"
                    );
                }
            }
        }
    }
    println!(
        "worst relative reciprocity error: reflection {worst_r:.2e} ({} pairs), transmission {worst_t:.2e} ({} pairs)",
        counts[0], counts[1]
    );
    assert!(counts[0] > 10_000 && counts[1] > 10_000);
}

/// The project suite's glass (`data/reference_values.csv`, converged HEITZ
/// walks, class dielectric: GGX glass 1.5 at alpha 0.1, 0.5, 1): relative
/// RMS error `sqrt(sum (f - ref)^2 / sum ref^2)` per material, class error
/// (RMS over the isotropic materials) at most 0.025 (the target);
/// the reference's own relative standard error is ~1e-3. The anisotropic
/// glass, added to the suite in session 9 for AUTO's rows, is bounded
/// apart, each at its measurement plus a tenth so that a change that makes
/// it worse fails: (0.1, 0.6) 0.0385 (SINGLE 0.0483; the lobe is the
/// isotropic one at an effective roughness, `docs/tabulated_dielectric.md`),
/// (0.5, 0.55) 0.0079, (0.3, 0.6) 0.0255.
#[test]
fn suite_error_against_reference_values() {
    let mats = suite_errors("dielectric", |num, ndf| {
        desc(
            Model::Tabulated,
            ndf,
            num("alpha_x"),
            num("alpha_y"),
            num("eta_r"),
        )
    });
    let (iso, aniso): (Vec<_>, Vec<_>) = mats.iter().partition(|(_, d, _)| d.alpha_x == d.alpha_y);
    assert_eq!(iso.len(), 3, "isotropic dielectric materials of the suite");
    assert_eq!(
        aniso.len(),
        3,
        "anisotropic dielectric materials of the suite"
    );
    let mut report = String::new();
    let mut class = 0.0;
    for (name, _, e) in &iso {
        class += e * e;
        report += &format!("{name}: {e:.4}\n");
    }
    let class = (class / iso.len() as f64).sqrt();
    println!("{report}class relative RMS error {class:.4}");
    assert!(class <= 0.025, "{report}class {class}");
    for (name, _, e) in aniso {
        let bound = match name.as_str() {
            "ggx_glass_0.1x0.6" => 0.042,
            "ggx_glass_0.5x0.55" => 0.0087,
            "ggx_glass_0.3x0.6" => 0.028,
            other => panic!("no bound for {other}"),
        };
        println!("{name}: {e:.4} (bound {bound})");
        assert!(*e <= bound, "{name}: {e}");
    }
}

/// Random table cells re-estimated with the library's walk (other seeds
/// than the generator's). A reflection cell's hat-weighted azimuth average
/// from `wi = mu_i` is `c_0 + B Q_ij / (2 pi H_j)` with
/// `Q_ij = int hat_j f_ss1 mu dw` (here from 50,000 SINGLE samples with
/// F = 1); the table keeps the count-weighted mean of `(i, j)` and `(j, i)`,
/// compared with the mean of fresh projections from both sides. A
/// transmission cell `c_0(i, j)` (thin `mu_i`, dense `mu_o`) is compared
/// with fresh projections from the thin side at `i` and, by the
/// eta-weighted reciprocity, `E^2` times those from the dense side at `j`.
/// Within 4 combined standard errors (fresh walks, the table's walks scaled
/// from the fresh variance, the Q samples) plus 3% for the generator's
/// furnace scaling `s_i s_j` (it moves cells by the albedo's Monte Carlo
/// noise and the hat smoothing).
/// Term `k` of the walk's lobe cell `(i, j)`: the stored value divided by
/// the node's normalisation factors of its two cosines (`lobe_norm`; a
/// transmission cell's `i` is on the thin side, `j` on the dense side).
fn walk_cell(nd: usize, a: usize, e: usize, lobe: usize, i: usize, j: usize, k: usize) -> f64 {
    let (si, sj) = match lobe {
        R_THIN => (0, 0),
        R_DENSE => (1, 1),
        _ => (0, 1),
    };
    let n = lobe_norm(nd, a, e, si, i) * lobe_norm(nd, a, e, sj, j);
    lobe_value(lobe_index(nd, a, e, lobe, i, j) + k) as f64 / n as f64
}

#[test]
fn table_cells_reestimated_with_the_library_walk() {
    let header = tabulated_dielectric::header();
    assert!(header.starts_with("MSBSDF-TABULATED-DIELECTRIC-v5"));
    let walks_table: f64 = header
        .lines()
        .find_map(|l| l.strip_prefix("walks: "))
        .and_then(|l| l.split(" per ").next())
        .and_then(|l| l.rsplit(' ').next())
        .and_then(|n| n.parse().ok())
        .expect("walk count in the header");
    let n = 60_000u64;
    let nq = 50_000u64;
    let mut pick = Rng::new(4711, 2);
    let mut report = String::new();
    // Nine cells whose stored value is not 0 (a transmission cell the
    // refracted lobe does not reach is 0 in the table and in every walk).
    let mut compared = 0;
    for cell in 0..60u64 {
        if compared == 9 {
            break;
        }
        let nd = (pick.next_u32() % 2) as usize;
        let a = 3 + (pick.next_u32() % 6) as usize;
        let e = (pick.next_u32() % tabulated_dielectric::ETA_N as u32) as usize;
        let lobe = [R_THIN, R_DENSE, T_THIN][(cell % 3) as usize];
        let i = 4 + (pick.next_u32() % (MU_N as u32 - 5)) as usize;
        let j = 4 + (pick.next_u32() % (MU_N as u32 - 5)) as usize;
        if lobe_value(lobe_index(nd, a, e, lobe, i, j)) <= 0.0 {
            continue;
        }
        compared += 1;
        let kind = [NdfKind::Beckmann, NdfKind::Ggx][nd];
        let (alpha, eta) = (grid_alpha(a), grid_eta(e));
        let ndf = Ndf::new(kind, alpha, alpha);
        let walk = Heitz::new(ndf, Facet::Dielectric { eta }, 0);
        let white = Facet::Conductor {
            eta: Vec3::ZERO,
            k: Vec3::ONE,
        };
        let single1 = Single::new(ndf, white, G2Form::HeightCorrelated);
        let two_pi = 2.0 * PI;
        // (dense side, incident node, exit node, weight, reflection?)
        let legs: Vec<(bool, usize, usize, f64, bool)> = match lobe {
            R_THIN => vec![(false, i, j, 0.5, true), (false, j, i, 0.5, true)],
            R_DENSE => vec![(true, i, j, 0.5, true), (true, j, i, 0.5, true)],
            _ => vec![
                (false, i, j, 0.5, false),
                (true, j, i, 0.5 * (eta as f64).powi(2), false),
            ],
        };
        let (mut fresh, mut var, mut stored, mut var_q) = (0.0, 0.0, 0.0, 0.0);
        for (leg, &(dense, x, y, wgt, refl)) in legs.iter().enumerate() {
            let mu = grid_mu(x);
            let up = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let wi = if dense { Vec3::new(up.x, 0.0, -mu) } else { up };
            let stream = cell * 2 + leg as u64;
            let norm = hat_moment(y) * two_pi;
            let mut rng = Rng::new(8080, stream);
            let (mut s1, mut s2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let (smp, b) = walk.sample_with_bounces(wi, &mut rng);
                let mut mom = [[0.0f64; 1]; MU_N];
                let same = (smp.wo.z > 0.0) == (wi.z > 0.0);
                if b >= 2 && smp.wo.z != 0.0 && same == refl {
                    let out = Vec3::new(smp.wo.x, smp.wo.y, smp.wo.z.abs());
                    project_exit(out, smp.weight.x as f64, &mut mom);
                }
                let v = wgt * mom[y][0] / norm;
                s1 += v;
                s2 += v * v;
            }
            let mean = s1 / n as f64;
            fresh += mean;
            var += s2 / n as f64 - mean * mean;
            if refl {
                // Q_xy / (2 pi H_y) by SINGLE's (F = 1) samples.
                let (q, q_var) =
                    peak_projection(&single1, up, y, norm, nq, &mut Rng::new(8081, stream));
                let (c0, peak) = (
                    walk_cell(nd, a, e, lobe, x, y, 0),
                    walk_cell(nd, a, e, lobe, x, y, PEAK),
                );
                stored += wgt * (c0 + peak * q);
                var_q += (wgt * peak).powi(2) * q_var;
            }
        }
        if lobe == T_THIN {
            stored = walk_cell(nd, a, e, T_THIN, i, j, 0);
        }
        let se = (var / n as f64 + var / walks_table + var_q).sqrt();
        report += &format!(
            "ndf {nd} alpha {alpha:.3} eta {eta:.3} lobe {lobe} mu ({:.3}, {:.3}): table {stored:.5}, fresh {fresh:.5} +- {se:.1e}\n",
            grid_mu(i),
            grid_mu(j)
        );
        assert!(
            (stored - fresh).abs() <= 4.0 * se + 0.03 * fresh,
            "{report}"
        );
    }
    println!("{report}");
    assert_eq!(compared, 9, "{report}");
}

/// TABULATED refuses dielectrics outside the tabulated index range
/// (`E = max(eta, 1 / eta)` in [1.05, 3]) and Student-T.
#[test]
fn refusals() {
    for eta in [1.0f32, 1.02, 1.0 / 1.02, 3.2, 0.3] {
        assert_eq!(
            Material::new(&desc(Model::Tabulated, NdfId::Ggx, 0.5, 0.5, eta)).err(),
            Some(Error::Unsupported),
            "eta {eta}"
        );
    }
    for eta in [1.05f32, 3.0, 1.0 / 1.05, 1.0 / 3.0] {
        assert!(Material::new(&desc(Model::Tabulated, NdfId::Ggx, 0.5, 0.5, eta)).is_ok());
    }
    assert_eq!(
        Material::new(&desc(Model::Tabulated, NdfId::StudentT, 0.5, 0.5, 1.5)).err(),
        Some(Error::Unsupported)
    );
}

/// Stability sweep: grazing angles to 89.99 degrees, roughness from 1e-3
/// to 2, both NDFs, indices at both ends of the table and below 1, both
/// sides: eval, pdf and sample weights finite and non-negative.
#[test]
fn stability_sweep() {
    let mut rng = Rng::new(99, 3);
    for ndf in NDFS {
        for alpha in [1e-3f32, 0.01, 0.1, 0.5, 1.0, 2.0] {
            for (ax, ay) in [(alpha, alpha), (alpha, (alpha * 3.0).min(2.0))] {
                for eta in [1.05f32, 1.5, 3.0, 1.0 / 1.5, 1.0 / 3.0] {
                    let m = tab(ndf, ax, ay, eta);
                    for theta in [0.0, 30.0, 70.0, 89.0, 89.9, 89.99] {
                        for side in [1.0f32, -1.0] {
                            let d = dir_deg(theta);
                            let wi = Vec3::new(d.x, 0.3 * d.x, side * d.z).normalize();
                            for _ in 0..100 {
                                let s = m.sample(wi, &mut rng);
                                assert!(s.weight.is_finite() && s.weight.min_element() >= 0.0);
                                assert!(s.pdf.is_finite() && s.pdf >= 0.0);
                                let wo = Vec3::new(
                                    rng.next_f32() - 0.5,
                                    rng.next_f32() - 0.5,
                                    rng.next_f32() - 0.5,
                                )
                                .normalize_or_zero();
                                if wo == Vec3::ZERO {
                                    continue;
                                }
                                let f = m.eval(wi, wo, &mut rng);
                                assert!(f.is_finite() && f.min_element() >= 0.0, "{f}");
                                let p = m.pdf(wi, wo);
                                assert!(p.is_finite() && p >= 0.0);
                            }
                        }
                    }
                }
            }
        }
    }
}
