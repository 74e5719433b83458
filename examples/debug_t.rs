use glam::Vec3;
use msbsdf::{FacetKind, Material, MaterialDesc, Model, NdfId, Rng};
fn main() {
    let mut rng = Rng::new(1, 2);
    let m = Material::new(&MaterialDesc {
        model: Model::Single,
        ndf: NdfId::Ggx,
        facet: FacetKind::Dielectric,
        eta: Vec3::splat(1.5),
        alpha_x: 0.7,
        alpha_y: 0.7,
        ..MaterialDesc::default()
    })
    .unwrap();
    let wi = Vec3::new(0.6427876, 0.0, 0.7660444);
    let wo = Vec3::new(-0.3, 0.1, -0.9).normalize();
    let a = m.eval(wi, wo, &mut rng).x; // f(wi,wo)|wo.z|
    let b = m.eval(wo, wi, &mut rng).x; // f(wo,wi)|wi.z|
    let fa = a / wo.z.abs();
    let fb = b / wi.z.abs();
    println!("f(wi,wo) {fa} f(wo,wi) {fb} ratio {}", fa / fb);
}
